"""The emitted call (docs/model.md §5b): sampled samples at a rate, and the calls bats make --
linear and hyperbolic FM sweeps, and a constant-frequency call with an FM tail (horseshoe bats)
-- each with a window and a duration."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._pickle import ReadOnlyOnLoading, loaded_arrays, refused_on_loading
from .._resources import check_copies
from .._validate import finite_scalar, positive_scalar, real_array

__all__ = ["WINDOWS", "Call"]

#: Window names a call's constructors take (``"rect"`` is no window); SciPy's
#: ``scipy.signal.get_window`` gives the shapes, symmetric.
WINDOWS = ("hann", "hamming", "blackman", "tukey", "rect")


def _window(name: str, m: int) -> np.ndarray:
    if name not in WINDOWS:
        raise ValueError(f"window must be one of {WINDOWS}, got {name!r}")
    if name == "rect":
        return np.ones(m)
    from scipy.signal import get_window

    spec: Any = ("tukey", 0.25) if name == "tukey" else name
    return np.asarray(get_window(spec, m, fftbins=False), dtype=np.float64)


def _n_samples(duration_s: float, fs: float) -> int:
    m = round(duration_s * fs)
    if m < 2:
        raise ValueError(
            f"duration_s = {duration_s} s at fs = {fs} Hz is {m} samples; a call needs >= 2"
        )
    if m > 10_000_000:
        raise ValueError(f"duration_s = {duration_s} s at fs = {fs} Hz is too long ({m} samples)")
    return m


def _windowed(wave: np.ndarray, window: str, duration_s: float, fs: float) -> np.ndarray:
    """``wave`` times the window ``window``; a ValueError naming the duration when the window
    leaves no sample (two samples under a Hann window are both zero)."""
    x = wave * _window(window, wave.size)
    if not np.any(x):
        raise ValueError(
            f"duration_s = {duration_s} s at fs = {fs} Hz is {wave.size} samples, all zero "
            f"under the {window} window; lengthen the call"
        )
    return x


def _band(f: float, fs: float, name: str) -> float:
    f = positive_scalar(f, name)
    if f >= fs / 2:
        raise ValueError(f"{name} = {f} Hz is at or above the Nyquist frequency fs/2 = {fs / 2} Hz")
    return f


@dataclass(frozen=True)
class Call(ReadOnlyOnLoading):
    """An emitted call: ``samples`` (m,) at the rate ``fs`` (Hz), starting at time 0.

    :meth:`linear_fm`, :meth:`hyperbolic_fm` and :meth:`cf_fm` make the calls bats emit;
    ``Call(samples, fs)`` takes any other: real and finite, with an energy ``sum(samples^2)``
    that is neither zero nor beyond float64 (the matched filter divides by it). The samples are
    copied and read-only.
    """

    samples: np.ndarray
    fs: float
    name: str = field(default="custom")

    def __post_init__(self):
        check_copies(samples=self.samples)
        s = real_array(self.samples, "samples")
        if s.ndim != 1 or s.size < 1:
            raise ValueError(f"samples must be a non-empty 1-D array, got shape {s.shape}")
        if not np.isfinite(s).all():
            raise ValueError(f"samples must be finite (sample {int(np.argmin(np.isfinite(s)))})")
        # the matched filter divides by the energy: it must be a normal float64, not 0 or inf
        with np.errstate(over="ignore", under="ignore"):
            energy = float(np.dot(s, s))
        if not np.finfo(np.float64).tiny <= energy < np.inf:
            raise ValueError(
                f"the samples' energy sum(samples^2) is {energy:g}: zero, or outside float64's "
                "normal range; scale the samples"
            )
        s.flags.writeable = False
        object.__setattr__(self, "samples", s)
        object.__setattr__(self, "fs", positive_scalar(self.fs, "fs"))

    def _check_loaded(self) -> None:
        (samples,) = loaded_arrays(self, ("samples",))
        with refused_on_loading(self):
            made = Call(samples, self.fs, self.name)
            if made.fs != self.fs:
                raise ValueError(f"fs is {self.fs!r}, not a rate in Hz")
            if not isinstance(self.name, str):
                raise TypeError(f"name is {self.name!r}, not a string")

    # (the samples compare and hash by value; the generated methods would compare arrays)
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Call):
            return NotImplemented
        return (
            self.fs == other.fs
            and self.name == other.name
            and np.array_equal(self.samples, other.samples)
        )

    def __hash__(self) -> int:
        return hash((self.samples.tobytes(), self.fs, self.name))

    def __len__(self) -> int:
        return self.samples.size

    @property
    def duration_s(self) -> float:
        """The call's length (s)."""
        return self.samples.size / self.fs

    @property
    def times(self) -> np.ndarray:
        """(m,) sample times (s)."""
        return np.arange(self.samples.size) / self.fs

    @property
    def energy(self) -> float:
        """``sum(samples^2)``, the matched filter's gain at its peak."""
        return float(np.dot(self.samples, self.samples))

    @classmethod
    def linear_fm(
        cls,
        f_start_hz: float,
        f_end_hz: float,
        duration_s: float,
        fs: float = 400e3,
        window: str = "hann",
    ) -> Call:
        """A linear FM sweep: instantaneous frequency from ``f_start_hz`` to ``f_end_hz``
        linearly over ``duration_s``, ``sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))`` times the
        window."""
        fs = positive_scalar(fs, "fs")
        f0, f1 = _band(f_start_hz, fs, "f_start_hz"), _band(f_end_hz, fs, "f_end_hz")
        T = positive_scalar(duration_s, "duration_s")
        m = _n_samples(T, fs)
        t = np.arange(m) / fs
        phase = 2.0 * np.pi * (f0 * t + (f1 - f0) * t * t / (2.0 * T))
        return cls(_windowed(np.sin(phase), window, T, fs), fs, "linear_fm")

    @classmethod
    def hyperbolic_fm(
        cls,
        f_start_hz: float,
        f_end_hz: float,
        duration_s: float,
        fs: float = 400e3,
        window: str = "hann",
    ) -> Call:
        """A hyperbolic FM sweep (the period linear in time, as in many FM bats' calls):
        ``f(t) = 1 / (1/f0 + (1/f1 - 1/f0) t / T)``, phase ``2 pi ln(1 + b f0 t) / b`` with
        ``b = (1/f1 - 1/f0) / T``, times the window."""
        fs = positive_scalar(fs, "fs")
        f0, f1 = _band(f_start_hz, fs, "f_start_hz"), _band(f_end_hz, fs, "f_end_hz")
        T = positive_scalar(duration_s, "duration_s")
        m = _n_samples(T, fs)
        t = np.arange(m) / fs
        b = (1.0 / f1 - 1.0 / f0) / T
        if b == 0.0:
            phase = 2.0 * np.pi * f0 * t
        else:
            phase = 2.0 * np.pi * np.log1p(b * f0 * t) / b
        return cls(_windowed(np.sin(phase), window, T, fs), fs, "hyperbolic_fm")

    @classmethod
    def cf_fm(
        cls,
        f_cf_hz: float,
        duration_s: float,
        fm_end_hz: float,
        fm_duration_s: float,
        fs: float = 400e3,
        window: str = "tukey",
    ) -> Call:
        """A constant-frequency call with a terminal FM sweep (horseshoe bats): ``f_cf_hz``
        for ``duration_s - fm_duration_s``, then a linear sweep to ``fm_end_hz`` over
        ``fm_duration_s``, the phase continuous; times the window (a Tukey window, 25 %
        tapered, by default)."""
        fs = positive_scalar(fs, "fs")
        fc, fe = _band(f_cf_hz, fs, "f_cf_hz"), _band(fm_end_hz, fs, "fm_end_hz")
        T = positive_scalar(duration_s, "duration_s")
        Tf = finite_scalar(fm_duration_s, "fm_duration_s")
        if not 0.0 <= Tf <= T:
            raise ValueError(f"fm_duration_s must be in [0, duration_s = {T}], got {Tf}")
        m = _n_samples(T, fs)
        t = np.arange(m) / fs
        t_cf = T - Tf
        tau = np.clip(t - t_cf, 0.0, None)
        sweep = (fe - fc) * tau * tau / (2.0 * Tf) if Tf > 0 else 0.0 * tau
        phase = 2.0 * np.pi * (fc * t + sweep)
        return cls(_windowed(np.sin(phase), window, T, fs), fs, "cf_fm")

    def __repr__(self) -> str:
        return f"Call({self.name}, {self.duration_s * 1e3:.3g} ms at {self.fs:g} Hz)"
