"""The sonar: every parameter of the echo model -- beams, lobe rule, frequency grid, leaf model,
absorption, shading -- checked and handed to the Rust core, and its record length
(docs/model.md sections 2-5, 9, 10).

Angles are in degrees at this edge (names ending ``_deg``) and radians inside; lengths in m,
frequencies in Hz, times in s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _core
from .._pickle import MadeAgainOnLoading
from .._validate import finite_scalar, flag, integer, keep_python_values, positive_scalar
from .absorption import Atmosphere
from .beam import Beam, horseshoe_bat_beamwidth_deg
from .receivers import MAX_RECEIVERS, Receiver, binaural_receivers
from .shading import Shading

_LOBES = ("detectable", "cone")
_MODELS = ("paper", "physical_optics")
_WINDOWS = ("hann", "rect")
# Record lengths whose resolved sonars an n_samples="auto" sonar keeps (the records a flight
# needs vary little: each is a 2-3-5-smooth length).
_RESOLVED_KEPT = 16

#: The largest |threshold_db| (dB): 10^(T/20) stays far inside float64.
MAX_ABS_THRESHOLD_DB = 300.0

#: The longest record (samples) a sonar may have, as the core's limit.
MAX_N_SAMPLES = 2**31

#: The parameters that are numbers, flags or pairs of numbers (kept as Python values).
_NUMBERS = (
    "beamwidth_deg",
    "fs",
    "n_samples",
    "band_hz",
    "sound_speed",
    "threshold_db",
    "cone_half_angle_deg",
    "max_range_m",
    "r0_m",
    "p0_pa",
    "p_ref_pa",
    "spreading",
    "gain",
    "min_range_m",
    "min_ka",
    "record_tail_s",
    "branch_piece_scale",
)

#: Beamwidth used when neither ``beamwidth_deg`` nor ``beam`` is given (Ming's canonical 30 deg).
DEFAULT_BEAMWIDTH_DEG = 30.0


@dataclass(frozen=True)
class Sonar(MadeAgainOnLoading):
    """Every parameter of the echo model (docs/model.md), with its defaults.

    Beam: ``beamwidth_deg`` (full -3 dB width, default 30) or a :class:`Beam` as ``beam`` for
    sigma per axis, rotation and beam centre. ``receiver`` gives the receiver its own pattern
    (default: the emitter's, so the two-way gain is ``S^2``).

    Receivers: ``receivers`` (a sequence of :class:`Receiver`) puts receivers at their own
    places, each with its own pattern (docs/model.md §5a); every per-pose array of the echoes
    then has a receiver axis after the pose axis. :meth:`binaural` makes two ears.

    Grid: sample rate ``fs`` (Hz), record length ``n_samples``, ``band_hz = (f_lo, f_hi)``,
    ``sound_speed`` (m/s). Band bins run from ``round(f_lo/df)`` to ``round(f_hi/df)``,
    ``df = fs/n_samples``. ``n_samples="auto"`` takes the record, per call of ``simulate``,
    from the farthest leaf that counts for any of the poses, plus ``record_tail_s`` for the
    pulse to ring down (the result's ``echoes.sonar`` holds the length used).

    Lobe: ``lobe="detectable"`` (the authors' rule with ``threshold_db`` T, ``r0_m``, ``p0_pa``,
    ``p_ref_pa``: on the axis the reach is 10 m) or ``"cone"`` with ``cone_half_angle_deg``.
    Leaves beyond ``max_range_m`` (default: the record's range ``v n / (2 fs)``) never count.

    Leaves: ``leaf_model="paper"`` (Ming et al.'s fit) or ``"physical_optics"``; ``spreading``
    keeps the 1/r^2 of docs/model.md §5 (False cancels it, as the authors' UAV scripts did);
    ``gain`` g; ``window`` "hann" (periodic, over the band bins) or "rect"; ``absorption``
    None or an :class:`Atmosphere` (ISO 9613-1).

    Guards: a leaf closer than ``min_range_m`` to a pulse raises (``too_close="raise"``) or is
    left out (``"skip"``); leaves with ``k a < min_ka`` at the band's lowest frequency are
    refused (the leaf models do not hold in the Rayleigh regime). The same holds for branch
    pieces and branch radii.

    Forests: ``shading`` None (the paper's model: every scatterer echoes as though it stood
    alone) or a :class:`Shading` (leaves and branches in the way dim or silence an echo,
    docs/model.md §10). ``branch_piece_scale`` in (0, 1] shortens the pieces branches are cut
    into below the longest the rule allows (docs/model.md §9), to check that they are short
    enough.
    """

    beamwidth_deg: float | None = None
    beam: Beam | None = None
    receiver: Beam | None = None
    receivers: tuple[Receiver, ...] | None = None
    fs: float = 400e3
    n_samples: int | str = 24_000
    band_hz: tuple[float, float] = (60e3, 80e3)
    sound_speed: float = 340.0
    lobe: str = "detectable"
    threshold_db: float = 20.0
    cone_half_angle_deg: float | None = None
    max_range_m: float | None = None
    r0_m: float = 0.1
    p0_pa: float = 2.0
    p_ref_pa: float = 20e-6
    leaf_model: str = "paper"
    spreading: bool = True
    gain: float = 0.2
    window: str = "hann"
    absorption: Atmosphere | None = None
    min_range_m: float = 0.01
    too_close: str = "raise"
    min_ka: float = 0.5
    record_tail_s: float = 1e-3
    shading: Shading | None = None
    branch_piece_scale: float = 1.0
    _core: Any = field(default=None, init=False, repr=False, compare=False)
    # n_samples="auto": the fixed-record sonars already resolved, by record length (see resolve)
    _resolved: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        keep_python_values(self, _NUMBERS)
        if self.beam is not None and self.beamwidth_deg is not None:
            raise ValueError("give beamwidth_deg or beam, not both")
        beam = self.beam
        if beam is None:
            bw = DEFAULT_BEAMWIDTH_DEG if self.beamwidth_deg is None else self.beamwidth_deg
            beam = Beam(beamwidth_deg=bw)
            object.__setattr__(self, "beam", beam)
        for name, b in (("beam", self.beam), ("receiver", self.receiver)):
            if b is not None and not isinstance(b, Beam):
                raise TypeError(f"{name} must be a batecho.Beam, got {type(b).__name__}")
        if self.receivers is not None:
            if isinstance(self.receivers, Receiver):
                raise TypeError("receivers must be a sequence of batecho.Receiver: (receiver,)")
            try:
                rxs = tuple(self.receivers)
            except TypeError:
                raise TypeError(
                    f"receivers must be a sequence of batecho.Receiver, got {self.receivers!r}"
                ) from None
            for i, r in enumerate(rxs):
                if not isinstance(r, Receiver):
                    raise TypeError(f"receivers[{i}] must be a batecho.Receiver, got {r!r}")
            if not 1 <= len(rxs) <= MAX_RECEIVERS:
                raise ValueError(
                    f"receivers must hold 1 to {MAX_RECEIVERS} receivers, got {len(rxs)}"
                )
            if self.receiver is not None:
                raise ValueError(
                    "give the receiving pattern as receiver or as receivers, not both "
                    "(a Receiver has a beam of its own)"
                )
            object.__setattr__(self, "receivers", rxs)
        if self.lobe not in _LOBES:
            raise ValueError(f"lobe must be one of {_LOBES}, got {self.lobe!r}")
        if self.leaf_model not in _MODELS:
            raise ValueError(f"leaf_model must be one of {_MODELS}, got {self.leaf_model!r}")
        if self.window not in _WINDOWS:
            raise ValueError(f"window must be one of {_WINDOWS}, got {self.window!r}")
        if self.too_close not in ("raise", "skip"):
            raise ValueError(f"too_close must be 'raise' or 'skip', got {self.too_close!r}")
        if self.absorption is not None and not isinstance(self.absorption, Atmosphere):
            raise TypeError("absorption must be None or a batecho.Atmosphere")
        if self.shading is not None and not isinstance(self.shading, Shading):
            raise TypeError(
                f"shading must be None or a batecho.Shading, got {type(self.shading).__name__}"
            )
        object.__setattr__(self, "spreading", flag(self.spreading, "spreading"))
        # (numbers as numbers: text such as "400e3" would be kept as given and fail later)
        scale = finite_scalar(self.branch_piece_scale, "branch_piece_scale", strict=True)
        if not 0.0 < scale <= 1.0:
            raise ValueError(f"branch_piece_scale must be in (0, 1], got {scale!r}")
        auto = isinstance(self.n_samples, str)
        if auto and self.n_samples != "auto":
            raise ValueError(f"n_samples must be an integer or 'auto', got {self.n_samples!r}")
        if not auto:
            n = integer(self.n_samples, "n_samples", minimum=2, wrong_type=TypeError)
            if n > MAX_N_SAMPLES:
                raise ValueError(
                    f"n_samples must be at most 2^31 = {MAX_N_SAMPLES}, got {self.n_samples!r}"
                )
        positive_scalar(self.record_tail_s, "record_tail_s", allow_zero=True, strict=True)
        try:
            band = tuple(self.band_hz)
        except TypeError:
            raise TypeError(f"band_hz must be (f_lo, f_hi) in Hz, got {self.band_hz!r}") from None
        if len(band) != 2:
            raise ValueError(f"band_hz must be (f_lo, f_hi), got {self.band_hz!r}")
        f_lo, f_hi = (finite_scalar(v, "band_hz", strict=True) for v in band)
        num = {
            name: positive_scalar(getattr(self, name), name, strict=True)
            for name in ("sound_speed", "r0_m", "p0_pa", "p_ref_pa", "gain", "min_range_m")
        }
        num["threshold_db"] = finite_scalar(self.threshold_db, "threshold_db", strict=True)
        if abs(num["threshold_db"]) > MAX_ABS_THRESHOLD_DB:
            raise ValueError(
                f"threshold_db must be in [-{MAX_ABS_THRESHOLD_DB:g}, {MAX_ABS_THRESHOLD_DB:g}] "
                f"dB, got {self.threshold_db!r}"
            )
        num["min_ka"] = positive_scalar(self.min_ka, "min_ka", allow_zero=True, strict=True)
        max_range = (
            None
            if self.max_range_m is None
            else positive_scalar(self.max_range_m, "max_range_m", strict=True)
        )
        fs = positive_scalar(self.fs, "fs", strict=True)
        if f_hi > fs / 2:
            raise ValueError(
                f"band upper edge {f_hi} Hz is above the Nyquist frequency fs/2 = {fs / 2} Hz"
            )
        cone = None
        if self.lobe == "cone":
            if self.cone_half_angle_deg is None:
                raise ValueError("lobe='cone' needs cone_half_angle_deg")
            h = finite_scalar(self.cone_half_angle_deg, "cone_half_angle_deg", strict=True)
            if not 0.0 < h < 180.0:
                raise ValueError(f"cone_half_angle_deg must be in (0, 180), got {h}")
            cone = math.radians(h)
        atm = None
        if self.absorption is not None:
            a = self.absorption
            atm = (float(a.temperature_c), float(a.relative_humidity), float(a.pressure_pa))
        n_record = self._provisional_n() if auto else int(self.n_samples)
        core = _core.Sonar(
            beam._core_tuple(),
            None if self.receiver is None else self.receiver._core_tuple(),
            self.lobe,
            num["threshold_db"],
            num["r0_m"],
            num["p0_pa"],
            num["p_ref_pa"],
            cone,
            max_range,
            fs,
            n_record,
            f_lo,
            f_hi,
            num["sound_speed"],
            self.leaf_model,
            bool(self.spreading),
            num["gain"],
            self.window,
            atm,
            num["min_range_m"],
            self.too_close,
            num["min_ka"],
            None if self.receivers is None else [r._core_tuple() for r in self.receivers],
            None if self.shading is None else self.shading._core_tuple(),
            scale,
        )
        k0, k1 = core.bins
        if self.window == "hann" and k0 == k1:
            raise ValueError(
                f"band_hz = {self.band_hz!r} holds one band bin (bin {k0} of a record of "
                f"{n_record} samples), where the periodic Hann window is 0: every echo would be "
                "zero; widen the band, lengthen the record (n_samples) or pass window='rect'"
            )
        object.__setattr__(self, "_core", core)
        object.__setattr__(self, "_resolved", {})

    @classmethod
    def binaural(
        cls,
        separation_m: float,
        ear_yaw_deg: float,
        ear_pitch_deg: float = 0.0,
        *,
        ear_beam: Beam | None = None,
        **sonar_kw,
    ) -> Sonar:
        """A sonar with two ears at ``±separation_m / 2`` along the left axis, each turned
        outward by ``ear_yaw_deg`` (the left ear to the left) and up by ``ear_pitch_deg``. The
        left ear comes first on the receiver axis.

        Each ear's pattern is ``ear_beam``'s shape (default: the emitter's, from
        ``beamwidth_deg`` or ``beam`` in ``sonar_kw``) centred on its own direction. The other
        keywords are :class:`Sonar`'s.
        """
        sep = positive_scalar(separation_m, "separation_m", allow_zero=True)
        yaw = finite_scalar(ear_yaw_deg, "ear_yaw_deg")
        pitch = finite_scalar(ear_pitch_deg, "ear_pitch_deg")
        if abs(yaw) > 180.0 or abs(pitch) > 90.0:
            raise ValueError(
                f"ear_yaw_deg must be in [-180, 180] and ear_pitch_deg in [-90, 90], "
                f"got {yaw}, {pitch}"
            )
        for key in ("receiver", "receivers"):
            if key in sonar_kw:
                raise TypeError(f"Sonar.binaural makes the receivers; do not pass {key}")
        if ear_beam is not None and not isinstance(ear_beam, Beam):
            raise TypeError(f"ear_beam must be a batecho.Beam, got {type(ear_beam).__name__}")
        emitter = cls(**sonar_kw)
        shape = ear_beam if ear_beam is not None else emitter.beam
        assert shape is not None  # set in __post_init__
        return emitter.replace(receivers=binaural_receivers(sep, yaw, pitch, shape))

    @property
    def n_receivers(self) -> int:
        """The number of receivers of their own (0: the echo is heard at the emitter, and
        results have no receiver axis)."""
        return 0 if self.receivers is None else len(self.receivers)

    @classmethod
    def horseshoe_bat(cls, f_khz: float = 70.0, **kwargs) -> Sonar:
        """A sonar whose beamwidth is the horseshoe-bat fit ``BW(f)`` at ``f_khz`` (one value for
        the whole band, as the authors did). The fit gives a beamwidth in (0, 180) deg from
        about 48.4 to 94.3 kHz; a frequency outside it is refused."""
        f = finite_scalar(f_khz, "f_khz", strict=True)
        bw = horseshoe_bat_beamwidth_deg(f)
        if not 0.0 < bw < 180.0:
            raise ValueError(
                f"f_khz = {f:g}: the horseshoe-bat fit gives a beamwidth of {bw:.6g} deg there, "
                "not in (0, 180); it gives one from about 48.4 to 94.3 kHz (f_khz is in kHz)"
            )
        return cls(beamwidth_deg=bw, **kwargs)

    def _init_parameters(self) -> dict[str, Any]:
        """The keyword arguments that make this sonar again (for ``replace`` and pickling;
        the beam as ``beamwidth_deg`` when it was given so)."""
        params = super()._init_parameters()
        if params["beamwidth_deg"] is not None:
            params["beam"] = None  # the beam was derived from beamwidth_deg
        return params

    def replace(self, **changes) -> Sonar:
        """A copy with some parameters changed."""
        params = self._init_parameters()
        if "beamwidth_deg" in changes:
            params["beam"] = None
        elif "beam" in changes:
            params["beamwidth_deg"] = None
        return type(self)(**{**params, **changes})

    # n_samples = "auto" ---------------------------------------------------------------------
    @property
    def is_auto(self) -> bool:
        """True when the record length is chosen per simulation (``n_samples="auto"``)."""
        return isinstance(self.n_samples, str)

    def reach_m(self) -> float:
        """The farthest a leaf can count from the lobe rule alone (m): ``sqrt(K A_tx A_rx)``
        for the detectable rule (10 m with the defaults), ``max_range_m`` for the cone. With
        receivers, the farthest delay range ``(r_tx + r_rx) / 2``."""
        if self.lobe == "cone":
            if self.max_range_m is None:
                return math.inf
            return float(self.max_range_m)
        level = 10.0 ** (self.threshold_db / 20.0) * self.p_ref_pa
        K = self.r0_m * self.r0_m * self.p0_pa / level
        tx = self.beam
        assert tx is not None  # set in __post_init__
        if self.receivers is None:
            rx = tx if self.receiver is None else self.receiver
            reach = math.sqrt(K * tx.amplitude * rx.amplitude)
        else:
            # the delay range (r_tx + r_rx) / 2 with r_tx r_rx <= K A_tx A_rx and
            # |r_tx - r_rx| <= |offset| (docs/model.md §5a)
            reach = max(
                math.sqrt(
                    K * tx.amplitude * (tx if r.beam is None else r.beam).amplitude
                    + r.distance_m**2 / 4.0
                )
                for r in self.receivers
            )
        return reach if self.max_range_m is None else min(reach, float(self.max_range_m))

    def record_length_for(self, range_m: float) -> int:
        """The record (samples, a 2-3-5-smooth even number) that holds echoes out to
        ``range_m`` plus ``record_tail_s``; ValueError when that is longer than
        :data:`MAX_N_SAMPLES`."""
        range_m = positive_scalar(range_m, "range_m", allow_zero=True, strict=True, unit="m")
        need = self.fs * (2.0 * range_m / self.sound_speed + self.record_tail_s)
        if not need <= MAX_N_SAMPLES:
            raise ValueError(
                f"n_samples='auto' needs a record of {need:.3g} samples to hold echoes out to "
                f"{range_m:.4g} m (fs = {self.fs:g} Hz, sound_speed = "
                f"{self.sound_speed:g} m/s, record_tail_s = {self.record_tail_s:g} s), more than "
                f"the longest record, 2^31 samples; bound the reach with max_range_m (or a "
                "higher threshold_db), shorten record_tail_s, or give n_samples"
            )
        return _fft_size(max(256, math.ceil(need)))

    def _provisional_n(self) -> int:
        reach = self.reach_m()
        if not math.isfinite(reach):
            raise ValueError(
                "n_samples='auto' with lobe='cone' needs max_range_m (the cone has no "
                "range of its own)"
            )
        return self.record_length_for(reach)

    def resolve(self, n_samples: int) -> Sonar:
        """This sonar with a fixed record length. The same length gives the same (immutable)
        sonar again, so that its FFT and fast-method plans, built on first use, serve every
        later call instead of being rebuilt for each ``n_samples="auto"`` simulation."""
        n = integer(n_samples, "n_samples", minimum=2, wrong_type=TypeError)
        kept = self._resolved.get(n)
        if kept is None:
            kept = self.replace(n_samples=n)
            if len(self._resolved) >= _RESOLVED_KEPT:
                del self._resolved[next(iter(self._resolved))]  # the oldest
            self._resolved[n] = kept
        return kept

    # Derived quantities -------------------------------------------------------------------
    def _fixed(self, what: str) -> None:
        if self.is_auto:
            raise ValueError(
                f"{what} depends on the record length, which n_samples='auto' chooses "
                "per simulation: use echoes.sonar, or Sonar.resolve(n_samples)"
            )

    @property
    def bins(self) -> tuple[int, int]:
        """(k0, k1): first and last band bin (inclusive) of the length-``n_samples`` rFFT."""
        self._fixed("bins")
        return self._core.bins

    @property
    def n_bins(self) -> int:
        """M, the number of band bins."""
        k0, k1 = self.bins
        return k1 - k0 + 1

    @property
    def delta_f(self) -> float:
        """Bin spacing fs / n_samples (Hz)."""
        self._fixed("delta_f")
        return self.fs / int(self.n_samples)

    @property
    def freqs(self) -> np.ndarray:
        """(M,) band-bin frequencies ``k fs / n`` (Hz)."""
        self._fixed("freqs")
        return self._core.freqs

    @property
    def times(self) -> np.ndarray:
        """(n_samples,) sample times (s)."""
        self._fixed("times")
        return np.arange(int(self.n_samples)) / self.fs

    @property
    def record_range_m(self) -> float:
        """Range covered by the record, ``v n / (2 fs)`` (m)."""
        self._fixed("record_range_m")
        return self.sound_speed * int(self.n_samples) / (2.0 * self.fs)

    @property
    def range_limit_m(self) -> float:
        """Leaves beyond this range never count (m)."""
        return self._core.range_limit

    @property
    def max_reach_m(self) -> float:
        """The farthest a counting leaf can be (m): 10 m on the axis with the defaults."""
        return self._core.max_reach


def _fft_size(n: int) -> int:
    """The smallest even 2-3-5-smooth integer >= n (fast FFT lengths): the least
    ``2^a 3^b 5^c >= n`` with ``a >= 1``, found over the powers of 5 and 3 (a few hundred
    steps for any n that fits in memory)."""
    n = max(int(n), 2)
    best = 2 ** max(1, (n - 1).bit_length())
    p5 = 1
    while p5 < 2 * n:
        p35 = p5
        while p35 < 2 * n:
            m = 2 * p35  # a >= 1
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


__all__ = ["DEFAULT_BEAMWIDTH_DEG", "MAX_N_SAMPLES", "Sonar"]
