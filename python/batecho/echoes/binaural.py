"""Interaural differences of two receivers' echoes along a flight: the level difference (dB)
and the time difference (s), the cues a bat (or an echo-guided drone) steers by."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._validate import positive_scalar
from .simulate import samples_within

__all__ = ["interaural_level_difference", "interaural_time_difference"]


def _pair(echoes: Any, ears: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    if echoes.n_receivers < 2:
        raise ValueError(
            f"interaural differences need two receivers (Sonar.binaural), got {echoes.n_receivers}"
        )
    pair: Any = ears
    try:
        a, b = pair
    except (TypeError, ValueError):
        a = b = None
    for j in (a, b):
        if isinstance(j, bool) or not isinstance(j, (int, np.integer)):
            raise TypeError(f"ears must be two int receiver indices (a, b), got {ears!r}")
        if not 0 <= j < echoes.n_receivers:
            raise ValueError(f"receiver {j} out of range: the echoes have {echoes.n_receivers}")
    return echoes.impulse[:, a], echoes.impulse[:, b]


def _peaks(x: np.ndarray) -> np.ndarray:
    """(p,) each row's largest magnitude (1 where the row is zero): dividing by it keeps
    squares and products of the row within float64, whatever its scale."""
    peak = np.max(np.abs(x), axis=-1)
    return np.where(peak > 0, peak, 1.0)


def _level_db(x: np.ndarray) -> np.ndarray:
    """(p,) ``10 log10(sum x^2)`` of each row (dB), computed on the row over its peak so that
    neither overflows nor underflows; -inf where the row is zero."""
    peak = _peaks(x)
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(peak) + 10.0 * np.log10(np.sum((x / peak[:, None]) ** 2, axis=-1))


def interaural_level_difference(
    echoes: Any, ears: tuple[int, int] = (0, 1), max_range_m: float | None = None
) -> np.ndarray:
    """(p,) the level difference ``10 log10(E_a / E_b)`` (dB) of each pose's echo energy at
    receivers ``ears = (a, b)`` (left minus right for :meth:`Sonar.binaural`), over the record
    or out to ``max_range_m``; NaN where either ear hears nothing."""
    a, b = _pair(echoes, ears)
    keep = samples_within(echoes, max_range_m)
    la, lb = _level_db(a[:, keep]), _level_db(b[:, keep])
    with np.errstate(invalid="ignore"):  # (-inf - -inf where neither ear hears)
        out = la - lb
    return np.where(np.isfinite(la) & np.isfinite(lb), out, np.nan)


def interaural_time_difference(
    echoes: Any,
    ears: tuple[int, int] = (0, 1),
    max_lag_s: float | None = None,
    max_range_m: float | None = None,
) -> np.ndarray:
    """(p,) the time difference ``t_b - t_a`` (s) of each pose's echo at receivers ``ears``
    (positive: the echo reaches receiver ``a``, the left ear, first): the lag of the largest
    cross-correlation of the two envelopes within ``±max_lag_s`` (default: the receivers'
    distance over the speed of sound, plus four samples), refined by a parabola through the
    peak and its neighbours. NaN where either ear hears nothing."""
    from scipy.signal import hilbert

    a, b = _pair(echoes, ears)
    keep = samples_within(echoes, max_range_m)
    fs = echoes.sonar.fs
    if max_lag_s is None:
        rxs = echoes.sonar.receivers
        assert rxs is not None
        d = float(np.linalg.norm(np.subtract(rxs[ears[0]].offset_m, rxs[ears[1]].offset_m)))
        max_lag_s = d / echoes.sonar.sound_speed + 4.0 / fs
    max_lag_s = positive_scalar(max_lag_s, "max_lag_s", strict=True, unit="s")
    lag = max(1, int(np.ceil(max_lag_s * fs)))
    # (each ear's record over its peak: the lag of the largest correlation is the same, and the
    # correlation neither overflows nor underflows whatever the echoes' scale)
    a, b = a[:, keep], b[:, keep]
    env_a = np.abs(hilbert(a / _peaks(a)[:, None], axis=-1))
    env_b = np.abs(hilbert(b / _peaks(b)[:, None], axis=-1))
    from scipy.signal import correlate

    out = np.full(len(a), np.nan)
    n = env_a.shape[-1]
    lag = min(lag, n - 1)
    lags = np.arange(-lag, lag + 1)
    for i in range(len(a)):
        if not (env_a[i].any() and env_b[i].any()):
            continue
        # c[k] = sum_t env_a(t) env_b(t + k), by FFT
        c = correlate(env_b[i], env_a[i], mode="full", method="fft")[n - 1 - lag : n + lag]
        m = int(np.argmax(c))
        shift = 0.0
        if 0 < m < len(c) - 1:
            den = c[m - 1] - 2.0 * c[m] + c[m + 1]
            if den < 0:
                shift = 0.5 * (c[m - 1] - c[m + 1]) / den
        out[i] = (lags[m] + shift) / fs
    return out
