"""The reference's leaves (docs/model.md §4-§5): the band's frequency grid, a leaf disk's
scattering (the paper's fit and physical optics), its incidence angle, and the windowed band
spectrum summed over the counting leaves.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np
from scipy.special import erf, j1

from ..sonar.absorption import iso9613_alpha_db_per_m
from ..sonar.sonar import Sonar


def _grid(sonar: Sonar):
    n, fs = cast(int, sonar.n_samples), sonar.fs
    df = fs / n
    k0 = math.floor(sonar.band_hz[0] / df + 0.5)  # round half up
    k1 = math.floor(sonar.band_hz[1] / df + 0.5)
    k = np.arange(k0, k1 + 1)
    f = k * fs / n
    M = k1 - k0 + 1
    if sonar.window == "hann":
        w = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(M) / M)  # periodic Hann
    else:
        w = np.ones(M)
    return k0, k1, f, w


# Section 4: leaf scattering ----------------------------------------------------------------
def _leaf_paper(c: np.ndarray, beta: np.ndarray, cos_b=None, sin_b=None):
    A = 0.5003 * c**2 + 0.6867
    B = 0.3999 * c ** (-0.9065) + 0.9979
    L = np.maximum(0.0, A * np.cos(B * beta))
    P = 0.9824 * c**0.3523 - 0.9459
    psi = erf(P * (1.57 - beta)) - 2.6343
    return L, psi


def _leaf_physical_optics(c: np.ndarray, beta: np.ndarray, cos_b: np.ndarray, sin_b: np.ndarray):
    # cos(beta) = |e . n| and sin(beta) = |e x n| from the geometry: the same values as the
    # cosine and sine of beta, but accurate at grazing incidence
    x = 2.0 * c * sin_b
    with np.errstate(invalid="ignore", divide="ignore"):
        jinc = np.where(x == 0.0, 1.0, 2.0 * j1(x) / x)  # 2 J1(x)/x, limit 1 at x = 0
    L = c**2 / 2.0 * cos_b * np.abs(jinc)
    return L, np.full_like(L, -np.pi / 2)


def _spectrum(sonar: Sonar, r, G, incidence, a, f, w, spread=None, chunk: int = 2048) -> np.ndarray:
    """Y_k = w_k sum_i A_ki exp(j phi_ki) over the band bins. ``r`` is the (delay) range, whose
    round trip ``2 r`` gives the phase and the absorption; ``spread`` is the spreading divisor
    (``r^2``, or ``r_tx r_rx`` for a receiver of its own)."""
    spread = r * r if spread is None else spread
    v = sonar.sound_speed
    k = 2.0 * np.pi * f / v
    model = _leaf_paper if sonar.leaf_model == "paper" else _leaf_physical_optics
    alpha = None
    if sonar.absorption is not None:
        atm = sonar.absorption
        alpha = iso9613_alpha_db_per_m(f, atm.temperature_c, atm.relative_humidity, atm.pressure_pa)
    beta, cos_b, sin_b = incidence
    Y = np.zeros(f.shape, dtype=np.complex128)
    for s in range(0, len(r), chunk):
        ri, Gi, bi, ci, si, ai, qi = (
            x[s : s + chunk, None] for x in (r, G, beta, cos_b, sin_b, a, spread)
        )
        c = k * ai
        L, psi = model(c, bi, ci, si)
        A = sonar.gain * Gi * L / k
        if sonar.spreading:
            A = A / qi
        if alpha is not None:
            A = A * 10.0 ** (-alpha * 2.0 * ri / 20.0)
        # phi = -2 k r - psi, with 2 k r reduced through the fractional part of f 2r / v
        cycles = f * (2.0 * ri / v)
        phi = -2.0 * np.pi * (cycles - np.round(cycles)) - psi
        Y += np.sum(A * np.exp(1j * phi), axis=0)
    return w * Y


def _incidence(e: np.ndarray, n: np.ndarray):
    """beta = angle(e, n) folded into [0, pi/2], via atan2(|e x n|, e . n); with
    cos(beta) = |e . n| and sin(beta) = |e x n|."""
    cx = e[:, 1] * n[:, 2] - e[:, 2] * n[:, 1]
    cy = e[:, 2] * n[:, 0] - e[:, 0] * n[:, 2]
    cz = e[:, 0] * n[:, 1] - e[:, 1] * n[:, 0]
    sin_b = np.sqrt(cx * cx + cy * cy + cz * cz)
    cos_b = e[:, 0] * n[:, 0] + e[:, 1] * n[:, 1] + e[:, 2] * n[:, 2]
    beta = np.arctan2(sin_b, cos_b)
    return np.minimum(beta, np.pi - beta), np.minimum(np.abs(cos_b), 1.0), np.minimum(sin_b, 1.0)
