"""What a receiver records (docs/model.md §5b): the impulse response convolved with the emitted
call (by FFT), truncated to the record, plus white Gaussian noise; and the matched filter's
pulse-compressed output; and the warning for a call that lies largely outside the band.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from .._random import generator
from .._validate import positive_scalar
from ..sonar.call import Call


class CallBandWarning(UserWarning):
    """Much of a call's energy lies outside the sonar's ``band_hz``: the record holds only the
    call's in-band part (docs/model.md §5b), so the rest is not heard."""


#: The share of a call's energy outside ``band_hz`` above which recording it warns.
CALL_OUT_OF_BAND_WARN = 0.1


def out_of_band_share(call: Call, band_hz: tuple[float, float]) -> float:
    """The share of ``call``'s energy (the power of its rFFT) at frequencies outside
    ``band_hz = (f_lo, f_hi)`` (Hz)."""
    power = np.abs(np.fft.rfft(call.samples)) ** 2
    f = np.fft.rfftfreq(call.samples.size, 1.0 / call.fs)
    lo, hi = band_hz
    return float(power[(f < lo) | (f > hi)].sum() / power.sum())


def warn_if_out_of_band(call: Call, band_hz: tuple[float, float], stacklevel: int = 2) -> None:
    """Warn (:class:`CallBandWarning`) when more than :data:`CALL_OUT_OF_BAND_WARN` of
    ``call``'s energy lies outside ``band_hz``; ``stacklevel`` as for ``warnings.warn``, from
    the caller's frame."""
    share = out_of_band_share(call, band_hz)
    if share > CALL_OUT_OF_BAND_WARN:
        lo, hi = band_hz
        warnings.warn(
            f"{share:.0%} of the call's energy lies outside the sonar's band_hz = "
            f"({lo:g}, {hi:g}) Hz, and the record holds only the call's in-band part "
            "(docs/model.md §5b); widen band_hz to hear the whole call",
            CallBandWarning,
            stacklevel=stacklevel + 1,
        )


def _check_call(call: Any, fs: float) -> Call:
    if not isinstance(call, Call):
        raise TypeError(f"call must be a batecho.Call, got {type(call).__name__}")
    if abs(call.fs - fs) > 1e-9 * fs:
        raise ValueError(
            f"the call is sampled at {call.fs:g} Hz but the echoes at fs = {fs:g} Hz; "
            "make the call at the sonar's fs"
        )
    return call


def received(
    impulse: np.ndarray, fs: float, call: Call, noise_rms: float = 0.0, rng: Any = None
) -> np.ndarray:
    """``impulse`` (..., n) convolved with ``call`` along the last axis (by FFT,
    ``scipy.signal.oaconvolve``), the first ``n`` samples kept, plus white Gaussian noise of
    rms ``noise_rms`` drawn from ``rng`` (a Generator, an int seed or None)."""
    from scipy.signal import oaconvolve

    call = _check_call(call, fs)
    sigma = positive_scalar(noise_rms, "noise_rms", allow_zero=True)
    h = np.asarray(impulse, dtype=np.float64)
    n = h.shape[-1]
    # (the call's samples past the record's n reach none of the n kept)
    c = call.samples[:n].reshape((1,) * (h.ndim - 1) + (-1,))
    y = np.asarray(oaconvolve(h, c, axes=-1)[..., :n], dtype=np.float64)
    if sigma > 0.0:
        y = y + generator(rng).normal(0.0, sigma, size=y.shape)
        if not np.all(np.isfinite(y)):
            raise ValueError(f"noise_rms = {noise_rms!r} gives noise beyond float64's range")
    return y


def matched_filter(x: np.ndarray, call: Call) -> np.ndarray:
    """The matched filter of ``call`` applied to ``x`` (..., n): the cross-correlation
    ``z[t] = sum_tau x[t + tau] c[tau] / sum c^2`` (by FFT): a single sample of amplitude
    ``A`` at ``t0``, convolved with the call, gives ``z[t0] = A`` (docs/model.md §5b)."""
    from scipy.signal import oaconvolve

    n = x.shape[-1]
    c = call.samples[:n]  # (tau >= n meets no sample of x)
    m = c.size
    k = c[::-1].reshape((1,) * (x.ndim - 1) + (-1,))
    z = oaconvolve(x, k, axes=-1)[..., m - 1 : m - 1 + n]
    return np.asarray(z, dtype=np.float64) / call.energy


def compressed(
    impulse: np.ndarray, fs: float, call: Call, noise_rms: float = 0.0, rng: Any = None
) -> np.ndarray:
    """The pulse-compressed output: :func:`matched_filter` of :func:`received`."""
    return matched_filter(received(impulse, fs, call, noise_rms, rng), call)


__all__ = [
    "CALL_OUT_OF_BAND_WARN",
    "CallBandWarning",
    "compressed",
    "matched_filter",
    "out_of_band_share",
    "received",
    "warn_if_out_of_band",
]
