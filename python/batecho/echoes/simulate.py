"""Echo simulation: the public ``simulate`` and ``lobe_members`` and the ``Echoes`` result."""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from .. import _core
from .._equal import EqualByValue, same
from .._validate import flag
from ..flight.poses import Poses
from ..forest.clearance import (
    DEFAULT_MIN_CLEARANCE_M,
    ClearanceWarning,
    check_margin,
    clearance_part,
    low_clearance,
)
from ..forest.scene import Scene, as_scene
from ..sonar.call import Call
from ..sonar.sonar import Sonar

#: The methods of :func:`simulate`.
METHODS = ("exact", "fast", "auto")
#: The method :func:`simulate`, scene files and the command line use unless told otherwise.
DEFAULT_METHOD = "auto"
#: The tolerance of the fast and auto methods unless told otherwise.
DEFAULT_TOL = 1e-12


@dataclass(frozen=True, eq=False)
class Echoes(EqualByValue):
    """Echoes of ``p`` poses.

    ``spectrum`` (p, M) complex128: the windowed band spectrum ``Y_k`` at ``freqs`` (M,) Hz.
    ``impulse`` (p, n_samples) float64: ``2 irfft(Y, n)`` at ``times`` (n_samples,) s.
    ``n_leaves`` (p,): how many leaves counted for each pose.

    With receivers of their own (``Sonar(receivers=...)``, ``R`` of them), every per-pose
    array has a receiver axis after the pose axis: ``spectrum`` (p, R, M), ``impulse``
    (p, R, n_samples), ``n_leaves`` (p, R), and with branches ``wood_spectrum`` (p, R, M)
    and ``n_pieces`` (p, R).
    With branches in the scene: ``wood_spectrum`` (p, M), the branches' share of ``spectrum``
    (None without branches; :meth:`wood_impulse` is its impulse response), and ``n_pieces``
    (p,), how many branch pieces counted. With shading: ``n_shaded`` (p,), or (p, R) with
    receivers, how many counting leaves it dimmed or silenced (zeros without shading).
    """

    spectrum: np.ndarray
    freqs: np.ndarray
    impulse: np.ndarray
    times: np.ndarray
    n_leaves: np.ndarray
    sonar: Sonar
    poses: Poses
    #: For the echoes of one receiver taken from a sonar's receivers (:meth:`for_receiver`),
    #: its index there.
    receiver: int | None = None
    wood_spectrum: np.ndarray | None = None
    n_pieces: np.ndarray | None = None
    n_shaded: np.ndarray | None = None

    def _same_field(self, name: str, a: Any, b: Any) -> bool:
        if name == "poses":  # (Poses compare by identity; echoes by the frames they hold)
            frames = ("positions", "forward", "up", "left")
            return all(same(getattr(a, k), getattr(b, k)) for k in frames)
        return same(a, b)

    def __post_init__(self):
        if self.n_pieces is None:
            object.__setattr__(self, "n_pieces", np.zeros(self.n_leaves.shape, dtype=np.int64))
        if self.n_shaded is None:
            object.__setattr__(self, "n_shaded", np.zeros(self.n_leaves.shape, dtype=np.int64))

    @property
    def ranges(self) -> np.ndarray:
        """(n_samples,) range of each sample, ``v t / 2`` (m)."""
        return self.sonar.sound_speed * self.times / 2.0

    @property
    def n_receivers(self) -> int:
        """The length of the receiver axis (0: none)."""
        return self.spectrum.shape[1] if self.spectrum.ndim == 3 else 0

    def for_receiver(self, j: int) -> Echoes:
        """The echoes of receiver ``j`` alone: every array without the receiver axis (so
        that the plots of one receiver's echoes take them)."""
        if not self.n_receivers:
            raise ValueError("these echoes have no receiver axis (Sonar(receivers=...))")
        if isinstance(j, bool) or not isinstance(j, (int, np.integer)):
            raise TypeError(f"receiver must be an int index, got {j!r}")
        if not 0 <= j < self.n_receivers:
            raise ValueError(f"receiver {j} out of range: the echoes have {self.n_receivers}")
        return Echoes(
            spectrum=self.spectrum[:, j],
            freqs=self.freqs,
            impulse=self.impulse[:, j],
            times=self.times,
            n_leaves=self.n_leaves[:, j],
            sonar=self.sonar,
            poses=self.poses,
            receiver=int(j),
            wood_spectrum=None if self.wood_spectrum is None else self.wood_spectrum[:, j],
            n_pieces=None if self.n_pieces is None else self.n_pieces[:, j],
            n_shaded=cast(np.ndarray, self.n_shaded)[:, j],
        )

    def envelope(self) -> np.ndarray:
        """(p, [R,] n_samples) envelope ``|analytic signal|`` of the impulse responses."""
        from scipy.signal import hilbert

        return np.abs(hilbert(self.impulse, axis=-1))

    def wood_impulse(self) -> np.ndarray | None:
        """(p, [R,] n_samples) impulse response of the wood's share of the echo,
        ``2 irfft(wood_spectrum, n)`` (None without branches)."""
        if self.wood_spectrum is None:
            return None
        n = len(self.times)
        k0 = int(np.rint(self.freqs[0] * n / self.sonar.fs))  # freqs[0] = k0 fs / n
        full = np.zeros((*self.wood_spectrum.shape[:-1], n // 2 + 1), dtype=np.complex128)
        full[..., k0 : k0 + self.wood_spectrum.shape[-1]] = self.wood_spectrum
        return 2.0 * np.fft.irfft(full, n, axis=-1)

    def __len__(self) -> int:
        return self.spectrum.shape[0]

    # The call, the noise and the matched filter (docs/model.md §5b) -------------------------
    def received(self, call: Call, noise_rms: float = 0.0, rng: Any = None) -> np.ndarray:
        """(p, [R,] n_samples) what the receivers record: the impulse responses convolved with
        ``call`` (by FFT), truncated to the record, plus white Gaussian noise of rms
        ``noise_rms`` drawn from ``rng`` (a Generator, an int seed or None). Only the call's
        part within the sonar's ``band_hz`` is heard: more than a tenth of its energy outside
        warns (:class:`CallBandWarning`)."""
        from .received import _check_call, received, warn_if_out_of_band

        warn_if_out_of_band(_check_call(call, self.sonar.fs), self.sonar.band_hz)
        return received(self.impulse, self.sonar.fs, call, noise_rms, rng)

    def compressed(self, call: Call, noise_rms: float = 0.0, rng: Any = None) -> np.ndarray:
        """(p, [R,] n_samples) the pulse-compressed output: :meth:`received` through the
        matched filter of ``call`` (its correlation with the call over the call's energy).
        Without noise it is :attr:`impulse` filtered by the call's autocorrelation normalised
        to 1 at lag 0 (docs/model.md §5b): an echo arriving at ``t0`` peaks at ``t0``, higher
        than in :attr:`impulse` (a band-limited pulse summed over the autocorrelation's main
        lobe). A call largely outside the band warns, as for :meth:`received`."""
        from .received import _check_call, compressed, warn_if_out_of_band

        warn_if_out_of_band(_check_call(call, self.sonar.fs), self.sonar.band_hz)
        return compressed(self.impulse, self.sonar.fs, call, noise_rms, rng)

    # Exports -----------------------------------------------------------------------------
    def to_xarray(self, call: Call | None = None, received: np.ndarray | None = None):
        """An ``xarray.Dataset`` with dimensions (pose, receiver, time, frequency), units and
        the sonar's parameters; with ``call``, what the receivers record (see
        :func:`batecho.echoes.export.to_xarray`)."""
        from .export import to_xarray

        return to_xarray(self, call, received)

    def to_wav(
        self,
        path: str | os.PathLike,
        time_expansion: float = 10.0,
        receiver: int | None = None,
        call: Call | None = None,
        noise_rms: float = 0.0,
        rng: Any = None,
    ) -> Path:
        """A WAV file to listen to: time-expanded ``time_expansion`` times (rate
        ``fs / time_expansion``), normalised, one channel per receiver (stereo for two ears),
        the poses one after another (see :func:`batecho.echoes.export.to_wav`)."""
        from .export import to_wav

        return to_wav(self, path, time_expansion, receiver, call, noise_rms, rng)

    def to_mat(
        self,
        path: str | os.PathLike,
        call: Call | None = None,
        received: np.ndarray | None = None,
    ) -> Path:
        """A MATLAB MAT file of the echoes; with ``call``, what the receivers record (see
        :func:`batecho.echoes.export.to_mat`)."""
        from .export import to_mat

        return to_mat(self, path, call, received)


def samples_within(echoes: Echoes, max_range_m: Any) -> np.ndarray:
    """(n_samples,) bool: the samples of ``echoes`` at ranges up to ``max_range_m`` (m; None:
    every sample), as the figures and the interaural cues cut the record. A ``max_range_m``
    that is not a number > 0 (NaN, 0, negative) would keep no sample: ValueError naming it."""
    if max_range_m is None:
        return np.ones(echoes.times.size, dtype=bool)
    if isinstance(max_range_m, bool) or not isinstance(max_range_m, (int, float, np.number)):
        raise TypeError(f"max_range_m must be a number (m) or None, got {max_range_m!r}")
    if not max_range_m > 0:
        raise ValueError(f"max_range_m must be > 0 (m) or None, got {max_range_m!r}")
    return echoes.ranges <= float(max_range_m)


def method_and_tol(method: Any, tol: Any) -> tuple[str, float]:
    """``method`` (one of :data:`METHODS`) and ``tol`` (a number in (0, 1)) as
    :func:`simulate` takes them, or a clear error."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    try:
        t = float(tol)
    except (TypeError, ValueError):
        raise TypeError(f"tol must be a number, got {tol!r}") from None
    if not (0.0 < t < 1.0):
        raise ValueError(f"tol must be in (0, 1), got {tol!r}")
    return method, t


def _check(sonar: Any, poses: Any) -> tuple[Sonar, Poses]:
    if not isinstance(sonar, Sonar):
        raise TypeError(f"sonar must be a batecho.Sonar, got {type(sonar).__name__}")
    if not isinstance(poses, Poses):
        raise TypeError(
            f"poses must be batecho.Poses (see batecho.look_at), got {type(poses).__name__}"
        )
    return sonar, poses


def refuse_receivers(sonar: Sonar, what: str) -> None:
    """ValueError when ``sonar`` has receivers of its own: ``what`` casts rays from the
    emitter and takes the monostatic lobe (docs/model.md §10)."""
    if sonar.n_receivers:
        raise ValueError(
            f"{what} casts its rays from the emitter, for the leaves heard there; this sonar "
            f"has {sonar.n_receivers} receivers of their own (simulate's Echoes.n_leaves and "
            "n_shaded count their leaves and shading): pass a sonar without receivers"
        )


def warn_low_clearance(scene: Scene, poses: Poses, min_clearance_m: float, stacklevel: int) -> None:
    """Warn (:class:`ClearanceWarning`) if a pose is closer than ``min_clearance_m`` to a leaf
    of ``scene`` (one nearest-leaf query per pose, on the BVH)."""
    if min_clearance_m <= 0:
        return
    d, idx = scene.clearance(poses.positions, return_index=True)
    msg = low_clearance(d, lambda i: clearance_part(idx[i]), poses.positions, min_clearance_m)
    if msg is not None:
        warnings.warn(
            msg + "; move the flight, or pass min_clearance_m=0 to switch this check off",
            ClearanceWarning,
            stacklevel=stacklevel + 1,
        )


def simulate(
    scene: Any,
    sonar: Sonar,
    poses: Poses,
    method: str = DEFAULT_METHOD,
    tol: float = DEFAULT_TOL,
    *,
    min_clearance_m: float = DEFAULT_MIN_CLEARANCE_M,
) -> Echoes:
    """Echoes of ``scene`` (a Scene, Leaves, or anything with ``.scene()``) for each pose in
    ``poses``.

    ``method``:

    - ``"exact"`` sums every (leaf, bin) term (docs/model.md, exact to rounding);
    - ``"fast"`` uses a type-1 NUFFT in the round-trip delays, with a relative L2 error of the
      spectrum at most ``tol`` (``1e-13 <= tol < 1``); on bands wider than twice their
      lowest frequency it works at ``tol / 10`` or ``tol / 100``, which costs more, and
      beyond six times, or below a working ``tol`` of 1e-12 there, it sums exactly
      (docs/model.md §6);
    - ``"auto"`` (the default) picks, per pose, whichever of the two is cheaper for ``tol``.

    With the default ``tol=1e-12`` the result agrees with the exact sum to ~1e-13 (and so
    with the authors' reference implementation); pass e.g. ``tol=1e-6`` for speed on large
    scenes (see docs/performance.md).

    ``min_clearance_m`` (m, default 0.5): a pose closer than this to a leaf disk is warned of
    (:class:`ClearanceWarning`, naming the nearest such pose, its distance and the leaf): the
    drone would fly through the foliage (docs/model.md §6). ``0`` switches the check off; the
    echoes are the same either way.

    Poses run in parallel in Rust with the GIL released; results are bit-identical for any
    number of threads. Ctrl-C (or any signal handler that raises) stops the call between
    poses, within about one pose's time, and its exception propagates; nothing is returned.
    """
    sonar, poses = _check(sonar, poses)
    margin = check_margin(min_clearance_m)
    method, tol = method_and_tol(method, tol)
    sc = as_scene(scene)
    warn_low_clearance(sc, poses, margin, stacklevel=2)
    if sonar.is_auto:
        # Record from the farthest counting leaf of any pose (the provisional core sonar's
        # record covers the lobe's whole reach, so it finds every counting leaf).
        far = _core.farthest_members(
            sc._core, sonar._core, poses.positions, poses.forward, poses.up, poses.left
        )
        sonar = sonar.resolve(sonar.record_length_for(float(far.max())))
    spec, imp, counts, wood, pieces, shaded = _core.simulate(
        sc._core,
        sonar._core,
        poses.positions,
        poses.forward,
        poses.up,
        poses.left,
        True,
        "bvh",
        method,
        tol,
    )
    assert imp is not None  # asked for with impulse=True
    return Echoes(
        spectrum=spec,
        freqs=sonar.freqs,
        impulse=imp,
        times=sonar.times,
        n_leaves=counts.astype(np.int64),
        sonar=sonar,
        poses=poses,
        wood_spectrum=wood,
        n_pieces=pieces.astype(np.int64),
        n_shaded=shaded.astype(np.int64),
    )


def lobe_members(
    scene: Any, sonar: Sonar, pose: Poses, *, search: str = "bvh", receiver: int | None = None
) -> np.ndarray:
    """Indices (ascending, int64) of the leaves that count for one pose (branches apart).

    ``search="bvh"`` traverses the BVH; ``"brute_force"`` tests every leaf. Both apply the same
    exact f64 test per leaf, so they return the same set. For a sonar with receivers of its
    own, ``receiver`` (an index) names the one whose counting leaves are wanted.
    """
    sonar, pose = _check(sonar, pose)
    if len(pose) != 1:
        raise ValueError(f"lobe_members takes one pose; got {len(pose)} (index it: poses[i])")
    if receiver is not None and (
        isinstance(receiver, bool) or not isinstance(receiver, (int, np.integer))
    ):
        raise TypeError(f"receiver must be an int index or None, got {receiver!r}")
    if receiver is not None and receiver < 0:
        raise ValueError(f"receiver must be >= 0, got {receiver}")
    if receiver is not None and receiver >= sonar.n_receivers:
        raise ValueError(
            f"receiver {receiver} out of range: the sonar has {sonar.n_receivers} receivers"
        )
    if search not in ("bvh", "brute_force"):
        raise ValueError(f"search must be 'bvh' or 'brute_force', got {search!r}")
    sc = as_scene(scene)
    return _core.lobe_members(
        sc._core,
        sonar._core,
        pose.positions,
        pose.forward,
        pose.up,
        pose.left,
        search,
        None if receiver is None else int(receiver),
    )


@dataclass(frozen=True, eq=False)
class LeafSights(EqualByValue):
    """What lies on the rays to the counting leaves of one pose (docs/model.md §10).

    ``index`` (int64, ascending): the leaves that count; ``crossings`` (int64): how many other
    leaf disks the open segment from the sonar to each one's centre crosses; ``blocked``
    (bool): whether a branch cylinder lies across it.
    """

    index: np.ndarray
    crossings: np.ndarray
    blocked: np.ndarray


def leaf_sights(
    scene: Any, sonar: Sonar, pose: Poses, *, branches_block: bool = True
) -> LeafSights:
    """The sights of the leaves that count for one pose: the crossings and blocks that
    shading turns into the factor ``tau^(2 m)`` or 0. Rays are cast with the scene's BVH and
    a light buffer round the sonar, in parallel; every candidate crossing is decided by the
    exact test of docs/model.md §10. Branches are tested only with ``branches_block``.

    The rays run from the sonar, so ``sonar`` must hear at the emitter: one with receivers of
    its own is refused (their echoes' shading is in ``Echoes.n_shaded``)."""
    sonar, pose = _check(sonar, pose)
    if len(pose) != 1:
        raise ValueError(f"leaf_sights takes one pose; got {len(pose)} (index it: poses[i])")
    refuse_receivers(sonar, "leaf_sights")
    branches_block = flag(branches_block, "branches_block")
    sc = as_scene(scene)
    ids, crossings, blocked = _core.leaf_sights(
        sc._core,
        sonar._core,
        pose.positions,
        pose.forward,
        pose.up,
        pose.left,
        bool(branches_block),
    )
    return LeafSights(ids, crossings.astype(np.int64), blocked)


__all__ = [
    "DEFAULT_METHOD",
    "DEFAULT_TOL",
    "METHODS",
    "Echoes",
    "LeafSights",
    "leaf_sights",
    "lobe_members",
    "refuse_receivers",
    "samples_within",
    "simulate",
    "warn_low_clearance",
]
