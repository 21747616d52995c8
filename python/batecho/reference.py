"""The NumPy reference: docs/model.md written out for clarity, not speed.

Plain NumPy and SciPy, a brute-force lobe test (no BVH, no Rust). ``simulate`` and
``lobe_members`` have the same signatures and results as ``batecho.simulate`` and
``batecho.lobe_members``, receivers at their own places included (docs/model.md §5a:
``_heard``, ``_bisector_incidence``, ``_simulate_heard``); the property tests hold the Rust
core to this module.

One deliberate detail: the lobe test is a threshold, and a leaf on its boundary is decided by
the last bit of ``atan2`` and ``exp``. The Rust core calls the C library's ``atan2`` and
``exp``; NumPy's SIMD versions may differ from it in the last bit. So the inputs of the
decision use Python's ``math`` functions (the same C library), and boundary leaves are decided
identically. Everything else is vectorised NumPy.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np
from scipy.special import erf, j1

from .echoes.simulate import Echoes
from .flight.poses import Poses
from .sonar.absorption import iso9613_alpha_db_per_m
from .sonar.beam import Beam
from .sonar.sonar import Sonar
from .trees.leaves import Leaves, as_leaves

_atan2 = np.frompyfunc(math.atan2, 2, 1)
_exp = np.frompyfunc(math.exp, 1, 1)


def _libm(f, *args) -> np.ndarray:
    return np.asarray(f(*args), dtype=np.float64).reshape(np.shape(args[0]))


# Section 2: the beampattern ----------------------------------------------------------------
def _sigma_from_beamwidth(beamwidth_deg: float) -> float:
    # sigma = (BW/2) / sqrt(2 (-ln 0.7079)), BW in radians
    return (math.radians(beamwidth_deg) / 2.0) / math.sqrt(2.0 * -math.log(0.7079))


def _one_way_gain(beam: Beam, az: np.ndarray, el: np.ndarray) -> np.ndarray:
    """S = A1 exp(-(a daz^2 + 2b daz del + c del^2))."""
    if beam.beamwidth_deg is not None:
        sx = sy = _sigma_from_beamwidth(beam.beamwidth_deg)
    else:
        s = np.atleast_1d(np.asarray(beam.sigma_deg, dtype=np.float64))
        sx, sy = math.radians(float(s[0])), math.radians(float(s[-1]))
    th = math.radians(beam.rotation_deg)
    st, ct, s2t = math.sin(th), math.cos(th), math.sin(2.0 * th)
    a = ct * ct / (2.0 * sx * sx) + st * st / (2.0 * sy * sy)
    b = -s2t / (4.0 * sx * sx) + s2t / (4.0 * sy * sy)
    c = st * st / (2.0 * sx * sx) + ct * ct / (2.0 * sy * sy)
    daz = az - math.radians(beam.center_deg[0])
    daz = np.where(daz > math.pi, daz - 2.0 * math.pi, daz)  # wrap to [-pi, pi]
    daz = np.where(daz < -math.pi, daz + 2.0 * math.pi, daz)
    dl = el - math.radians(beam.center_deg[1])
    q = a * daz * daz + 2.0 * b * daz * dl + c * dl * dl
    return float(beam.amplitude) * _libm(_exp, -q)


def _two_way_gain(sonar: Sonar, az: np.ndarray, el: np.ndarray) -> np.ndarray:
    s_tx = _one_way_gain(cast(Beam, sonar.beam), az, el)
    s_rx = s_tx if sonar.receiver is None else _one_way_gain(sonar.receiver, az, el)
    return s_tx * s_rx


# Section 1 and 3: angles and the lobe --------------------------------------------------------
def _view(leaves: Leaves, sonar: Sonar, poses: Poses, i: int):
    """Range, unit direction, azimuth, elevation and two-way gain of every leaf from pose i."""
    p = poses.positions[i]
    d, u, l_ = poses.forward[i], poses.up[i], poses.left[i]
    dx = leaves.centers - p
    r = np.sqrt(dx[:, 0] * dx[:, 0] + dx[:, 1] * dx[:, 1] + dx[:, 2] * dx[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        e = dx / r[:, None]
    ed = e[:, 0] * d[0] + e[:, 1] * d[1] + e[:, 2] * d[2]
    el_ = e[:, 0] * l_[0] + e[:, 1] * l_[1] + e[:, 2] * l_[2]
    eu = e[:, 0] * u[0] + e[:, 1] * u[1] + e[:, 2] * u[2]
    az = _libm(_atan2, el_, ed)
    el = _libm(_atan2, eu, np.sqrt(ed * ed + el_ * el_))
    G = _two_way_gain(sonar, az, el)
    return r, e, ed, G


def _reach_sq(sonar: Sonar) -> float:
    """K = r0^2 p0 / (10^(T/20) p_ref): a leaf counts out to r^2 <= K G."""
    return (
        sonar.r0_m
        * sonar.r0_m
        * sonar.p0_pa
        / (10.0 ** (sonar.threshold_db / 20.0) * sonar.p_ref_pa)
    )


def _record_limit(sonar: Sonar) -> float:
    record = sonar.sound_speed * cast(int, sonar.n_samples) / (2.0 * sonar.fs)
    return record if sonar.max_range_m is None else min(float(sonar.max_range_m), record)


def _counting(leaves: Leaves, sonar: Sonar, poses: Poses, i: int):
    """Boolean mask of counting leaves for pose i, with the view quantities."""
    r, e, ed, G = _view(leaves, sonar, poses, i)
    too_close = ~(r >= sonar.min_range_m)
    if too_close.any() and sonar.too_close == "raise":
        j = int(np.argmax(too_close))
        raise ValueError(
            f"leaf {j} is {r[j]:.3e} m from pose {i}, closer than min_range_m = "
            f"{sonar.min_range_m} m"
        )
    mask = ~too_close & (r <= _record_limit(sonar))
    if sonar.lobe == "cone":
        mask &= ed >= math.cos(math.radians(cast(float, sonar.cone_half_angle_deg)))
    else:
        # r <= sqrt(r0^2 p0 G / (10^(T/20) p_ref))
        with np.errstate(invalid="ignore"):
            mask &= r <= np.sqrt(_reach_sq(sonar) * G)
    return mask, r, e, G


# Section 5a: receivers at their own places -------------------------------------------------
def _receiver_position(poses: Poses, i: int, offset) -> np.ndarray:
    """p + (o_f d + o_l l + o_u u), componentwise in that order."""
    p, d, l_, u = poses.positions[i], poses.forward[i], poses.left[i], poses.up[i]
    return p + (offset[0] * d + offset[1] * l_ + offset[2] * u)


def _seen_from(leaves: Leaves, at: np.ndarray, beam: Beam, poses: Poses, i: int):
    """Range, unit direction, e . d and one-way gain of every leaf from the point ``at``, with
    the angles in pose i's frame (the same operations as ``_view``)."""
    d, u, l_ = poses.forward[i], poses.up[i], poses.left[i]
    dx = leaves.centers - at
    r = np.sqrt(dx[:, 0] * dx[:, 0] + dx[:, 1] * dx[:, 1] + dx[:, 2] * dx[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        e = dx / r[:, None]
    ed = e[:, 0] * d[0] + e[:, 1] * d[1] + e[:, 2] * d[2]
    el_ = e[:, 0] * l_[0] + e[:, 1] * l_[1] + e[:, 2] * l_[2]
    eu = e[:, 0] * u[0] + e[:, 1] * u[1] + e[:, 2] * u[2]
    az = _libm(_atan2, el_, ed)
    el = _libm(_atan2, eu, np.sqrt(ed * ed + el_ * el_))
    return r, e, ed, _one_way_gain(beam, az, el)


def _heard(leaves: Leaves, sonar: Sonar, poses: Poses, i: int):
    """For each receiver of pose i: the mask of counting leaves, the emitter's and the
    receiver's ranges and directions, and the two-way gain ``S_tx S_rx``.

    A leaf counts for a receiver when it is at least ``min_range_m`` from emitter and receiver,
    its delay range ``(r_tx + r_rx) / 2`` is within the record (and ``max_range_m``), and
    ``sqrt(r_tx r_rx) <= sqrt(K S_tx S_rx)`` (detectable rule) or it lies in the cone seen
    from the emitter and from the receiver (cone rule).
    """
    tx_beam = cast(Beam, sonar.beam)
    r_tx, e_tx, ed_tx, s_tx = _seen_from(leaves, poses.positions[i], tx_beam, poses, i)
    rxs = cast(tuple, sonar.receivers)
    views = []
    near = ~(r_tx >= sonar.min_range_m)
    for rx in rxs:
        at = _receiver_position(poses, i, rx.offset_m)
        beam = tx_beam if rx.beam is None else rx.beam
        views.append(_seen_from(leaves, at, beam, poses, i))
        near |= ~(views[-1][0] >= sonar.min_range_m)
    if near.any() and sonar.too_close == "raise":
        j = int(np.argmax(near))
        raise ValueError(f"leaf {j} is closer than min_range_m = {sonar.min_range_m} m to pose {i}")
    out = []
    for r_rx, e_rx, ed_rx, s_rx in views:
        G = s_tx * s_rx
        mask = (r_tx >= sonar.min_range_m) & (r_rx >= sonar.min_range_m)
        mask &= (r_tx + r_rx) / 2.0 <= _record_limit(sonar)
        if sonar.lobe == "cone":
            cos_h = math.cos(math.radians(cast(float, sonar.cone_half_angle_deg)))
            mask &= (ed_tx >= cos_h) & (ed_rx >= cos_h)
        else:
            with np.errstate(invalid="ignore"):
                mask &= np.sqrt(r_tx * r_rx) <= np.sqrt(_reach_sq(sonar) * G)
        out.append((mask, r_tx, e_tx, r_rx, e_rx, G))
    return out


#: Below this ``|e_tx + e_rx| = 2 cos(gamma / 2)`` (a bistatic angle within about 1e-4 rad of
#: 180 degrees) a leaf is forward scattering, at grazing incidence (docs/model.md §5a).
FORWARD_SCATTER_B = 1e-4


def _bisector_incidence(e_tx: np.ndarray, e_rx: np.ndarray, n: np.ndarray):
    """The incidence from the bisector b = (e_tx + e_rx) / |e_tx + e_rx| of the two directions:
    an approximation for small bistatic angles, exact at zero. |b| below
    ``FORWARD_SCATTER_B`` (a leaf on or next to the segment between emitter and receiver:
    forward scattering, no specular direction, b decided by rounding) is grazing incidence
    (beta = pi/2, cos = 0, sin = 1)."""
    b = e_tx + e_rx
    nb = np.sqrt(b[:, 0] * b[:, 0] + b[:, 1] * b[:, 1] + b[:, 2] * b[:, 2])
    zero = ~(nb >= FORWARD_SCATTER_B)
    with np.errstate(invalid="ignore", divide="ignore"):
        beta, cos_b, sin_b = _incidence(b / nb[:, None], n)
    beta = np.where(zero, np.pi / 2, beta)
    return beta, np.where(zero, 0.0, cos_b), np.where(zero, 1.0, sin_b)


def lobe_members(
    scene: Any,
    sonar: Sonar,
    pose: Poses,
    *,
    search: str = "brute_force",
    receiver: int | None = None,
) -> np.ndarray:
    """Indices (ascending) of the leaves that count for one pose (for receiver ``receiver`` of
    a sonar with receivers of its own), by testing every leaf."""
    leaves = as_leaves(scene)
    if len(pose) != 1:
        raise ValueError(f"lobe_members takes one pose; got {len(pose)}")
    if sonar.receivers is not None:
        mask = _heard(leaves, sonar, pose, 0)[cast(int, receiver)][0]
    else:
        mask = _counting(leaves, sonar, pose, 0)[0]
    return np.flatnonzero(mask).astype(np.int64)


# Section 5: the frequency grid -------------------------------------------------------------
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


def simulate(scene: Any, sonar: Sonar, poses: Poses, method: str = "exact") -> Echoes:
    """Echoes of ``scene`` for every pose, straight from docs/model.md (``method`` is ignored: the
    reference is always the exact sum)."""
    leaves = as_leaves(scene)
    if not isinstance(sonar, Sonar) or not isinstance(poses, Poses):
        raise TypeError("simulate(scene, sonar: Sonar, poses: Poses)")
    if sonar.is_auto:
        # the record holds the farthest counting leaf of any pose plus the pulse tail
        provisional = sonar.resolve(sonar._provisional_n())
        far = 0.0
        for i in range(len(poses)):
            if sonar.receivers is not None:
                for mask, r_tx, _, r_rx, _, _ in _heard(leaves, provisional, poses, i):
                    far = max(far, float(((r_tx + r_rx) / 2.0)[mask].max(initial=0.0)))
            else:
                mask, r, _, _ = _counting(leaves, provisional, poses, i)
                far = max(far, float(r[mask].max(initial=0.0)))
        sonar = sonar.resolve(sonar.record_length_for(far))
    k0, k1, f, w = _grid(sonar)
    a_all = leaves.radii
    if sonar.min_ka > 0:
        ka = 2.0 * np.pi * f[0] / sonar.sound_speed * a_all
        if ka.min() < sonar.min_ka:
            raise ValueError(f"leaf {int(np.argmin(ka))} has k a = {ka.min():.4g} < min_ka")
    n = cast(int, sonar.n_samples)
    if sonar.receivers is not None:
        return _simulate_heard(leaves, sonar, poses, k0, k1, f, w)
    spectra = np.zeros((len(poses), len(f)), dtype=np.complex128)
    impulses = np.zeros((len(poses), n))
    counts = np.zeros(len(poses), dtype=np.int64)
    for i in range(len(poses)):
        mask, r, e, G = _counting(leaves, sonar, poses, i)
        idx = np.flatnonzero(mask)
        counts[i] = idx.size
        if idx.size:
            beta = _incidence(e[idx], leaves.normals[idx])
            spectra[i] = _spectrum(sonar, r[idx], G[idx], beta, a_all[idx], f, w)
        full = np.zeros(n // 2 + 1, dtype=np.complex128)
        full[k0 : k1 + 1] = spectra[i]
        impulses[i] = 2.0 * np.fft.irfft(full, n)
    return Echoes(
        spectrum=spectra,
        freqs=f,
        impulse=impulses,
        times=np.arange(n) / sonar.fs,
        n_leaves=counts,
        sonar=sonar,
        poses=poses,
    )


def _simulate_heard(leaves: Leaves, sonar: Sonar, poses: Poses, k0, k1, f, w) -> Echoes:
    """Every receiver's echoes (docs/model.md §5a): the amplitude ``g S_tx S_rx L / (k r_tx
    r_rx)``, the phase ``-k (r_tx + r_rx) - psi``, absorption over ``r_tx + r_rx``, the
    incidence from the bisector."""
    n = cast(int, sonar.n_samples)
    n_rx = len(cast(tuple, sonar.receivers))
    spectra = np.zeros((len(poses), n_rx, len(f)), dtype=np.complex128)
    impulses = np.zeros((len(poses), n_rx, n))
    counts = np.zeros((len(poses), n_rx), dtype=np.int64)
    for i in range(len(poses)):
        for j, (mask, r_tx, e_tx, r_rx, e_rx, G) in enumerate(_heard(leaves, sonar, poses, i)):
            idx = np.flatnonzero(mask)
            counts[i, j] = idx.size
            if idx.size:
                beta = _bisector_incidence(e_tx[idx], e_rx[idx], leaves.normals[idx])
                r = (r_tx[idx] + r_rx[idx]) / 2.0
                spread = r_tx[idx] * r_rx[idx]
                spectra[i, j] = _spectrum(
                    sonar, r, G[idx], beta, leaves.radii[idx], f, w, spread=spread
                )
            full = np.zeros(n // 2 + 1, dtype=np.complex128)
            full[k0 : k1 + 1] = spectra[i, j]
            impulses[i, j] = 2.0 * np.fft.irfft(full, n)
    return Echoes(
        spectrum=spectra,
        freqs=f,
        impulse=impulses,
        times=np.arange(n) / sonar.fs,
        n_leaves=counts,
        sonar=sonar,
        poses=poses,
    )


# Section 6: clearance ----------------------------------------------------------------------
def point_disk_distance(
    p: np.ndarray, c: np.ndarray, n: np.ndarray, a: np.ndarray | float
) -> np.ndarray:
    """Distance from points ``p`` to disks (centre ``c``, unit normal ``n``, radius ``a``),
    broadcast row by row (``(..., 3)`` arrays).

    ``d = p - c``, height ``h = d . n``, in-plane part ``q = d - h n`` of length ``rho``: the
    nearest disk point is ``c + q`` if ``rho <= a`` (distance ``|h|``), else the rim point
    ``c + a q / rho`` (distance ``sqrt(h^2 + (rho - a)^2)``). Written in the Rust core's order
    of operations (no FMA), so both give the same bits.
    """
    d = p - c
    h = d[..., 0] * n[..., 0] + d[..., 1] * n[..., 1] + d[..., 2] * n[..., 2]
    q = d - h[..., None] * n
    rho = np.sqrt(q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    t = rho - a
    return np.where(rho <= a, np.abs(h), np.sqrt(h * h + t * t))


def clearance(scene: Any, points: Any, chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Per point (n, 3), the distance (m) to the nearest leaf disk of ``scene`` and that leaf's
    index (the smallest among equally near leaves), by testing every leaf."""
    leaves = as_leaves(scene)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    c, nv, a = leaves.centers, leaves.normals, leaves.radii
    dist = np.full(len(pts), np.inf)
    index = np.zeros(len(pts), dtype=np.int64)
    step = max(1, chunk // len(c))
    for s in range(0, len(pts), step):
        d = point_disk_distance(pts[s : s + step, None, :], c[None], nv[None], a[None])
        k = np.argmin(d, axis=1)  # the first of equal minima: the smallest index
        dist[s : s + step] = d[np.arange(len(k)), k]
        index[s : s + step] = k
    return dist, index


__all__ = ["clearance", "lobe_members", "point_disk_distance", "simulate"]
