"""The pulses of EchoFlight environments: each drone's sonar pose, all the environments' pulses
through one Rust call (:func:`batecho._core.simulate_many`, each forest's echoes those of
:func:`~batecho.simulate` for it alone), and each ear's echo levels in range bins.

One environment's pulse and a batch's take this same path, so that a batched step gives the
single environment's observation bit for bit.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from .. import _core
from ..echoes.envelope import band_envelope

__all__ = [
    "ENVELOPE_OVERSAMPLING",
    "EchoBins",
    "echo_levels",
    "echo_levels_db",
    "start_echo_levels",
]

#: The envelope is sampled this many times finer than its Nyquist rate (its spectrum spans the
#: band, ``f_hi - f_lo``) before each range bin takes its largest sample.
ENVELOPE_OVERSAMPLING = 4.0


def echo_levels_db(
    envelope: np.ndarray,
    ranges: np.ndarray,
    reach_m: float,
    n_bins: int,
    floor_db: float,
    ceiling_db: float,
) -> np.ndarray:
    """(p, n_bins) the largest of each row of ``envelope`` (p, n) in each of ``n_bins`` equal
    range bins over [0, ``reach_m``) (``ranges`` (n,) m, increasing), in dB re 1, clipped to
    [``floor_db``, ``ceiling_db``]; an empty bin is ``floor_db``."""
    return EchoBins(ranges, reach_m, n_bins, floor_db, ceiling_db).levels(envelope)


class EchoBins:
    """The range bins of an echo record: ``n_bins`` equal bins over [0, ``reach_m``) of the
    samples at ``ranges`` (n,) m (increasing), levels in dB re 1 clipped to
    [``floor_db``, ``ceiling_db``]."""

    def __init__(
        self, ranges: np.ndarray, reach_m: float, n_bins: int, floor_db: float, ceiling_db: float
    ):
        edges = np.searchsorted(ranges, np.linspace(0.0, reach_m, n_bins + 1))
        #: which bins hold samples; the samples of those: [starts[j], next start or stop)
        self.filled = edges[1:] > edges[:-1]
        self.starts = edges[:-1][self.filled]
        self.stop = int(edges[-1])
        self.n_bins = int(n_bins)
        self.floor_db, self.ceiling_db = float(floor_db), float(ceiling_db)
        self.tiny = 10.0 ** (self.floor_db / 20.0)

    def levels(self, envelope: np.ndarray) -> np.ndarray:
        """(..., n_bins) the largest of ``envelope`` (..., n) in each bin, in dB, clipped."""
        out = np.full((*envelope.shape[:-1], self.n_bins), self.floor_db)
        if len(self.starts):
            # An empty bin has no width, so each filled bin runs to the next one's start.
            peaks = np.maximum.reduceat(envelope[..., : self.stop], self.starts, axis=-1)
            out[..., self.filled] = 20.0 * np.log10(np.maximum(peaks, self.tiny))
        return np.clip(out, self.floor_db, self.ceiling_db)


def ear_frames(attitudes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The sonar frames (forward, up, left), each (n, 3), of drones with body -> world
    ``attitudes`` (n, 3, 3): the sonar sits at the body's centre, looking along its nose."""
    return (
        np.ascontiguousarray(attitudes[:, :, 0]),
        np.ascontiguousarray(attitudes[:, :, 2]),
        np.ascontiguousarray(attitudes[:, :, 1]),
    )


def echo_levels(envs: Sequence[Any]) -> list[np.ndarray]:
    """Each environment's ears' echo levels now, (2, n_range_bins) dB: one pulse of its sonar
    from its drone's pose in its forest, all the environments' pulses in one Rust call (one
    per distinct sonar, method and tolerance). An environment without trees hears nothing
    (``floor_db`` everywhere)."""
    return start_echo_levels(envs)()


def start_echo_levels(envs: Sequence[Any]) -> Callable[[], list[np.ndarray]]:
    """Send the pulses of :func:`echo_levels` to the Rust core on a worker thread (which
    releases the GIL), so that the caller's Python work overlaps them; the returned function
    waits for them and gives what :func:`echo_levels` gives."""
    out: list[np.ndarray] = [np.full((2, e.n_range_bins), e.floor_db) for e in envs]
    groups: list[tuple[Any, list[int]]] = []
    for i, e in enumerate(envs):
        if e.forest.n_trees == 0:
            continue
        key = (e.sonar, e.method, e.tol)
        for k, members in groups:
            if k == key:
                members.append(i)
                break
        else:
            groups.append((key, [i]))
    calls = []
    for (sonar, method, tol), members in groups:
        positions, attitudes = [], []
        for i in members:
            st = envs[i].drone_state()
            positions.append(st[0:3][None, :].copy())
            attitudes.append(st[6:15].reshape(1, 3, 3))
        frames = [ear_frames(a) for a in attitudes]
        calls.append(
            (
                [envs[i].echo_scene()._core for i in members],
                sonar._core,
                positions,
                [f[0] for f in frames],
                [f[1] for f in frames],
                [f[2] for f in frames],
                "bvh",
                method,
                tol,
            )
        )
    pending = _worker().submit(lambda: [_core.simulate_many(*args) for args in calls])

    def finish() -> list[np.ndarray]:
        for ((sonar, _, _), members), results in zip(groups, pending.result(), strict=True):
            first = envs[members[0]]
            k0 = round(float(sonar.freqs[0]) * int(sonar.n_samples) / sonar.fs)
            # (the group's envelopes in one inverse FFT: each row's is the one it gets alone)
            spectra = np.stack([spectrum[0] for spectrum, _ in results])
            envelopes = band_envelope(spectra, k0, int(sonar.n_samples), first.envelope_stride)
            for i, envelope in zip(members, envelopes, strict=True):
                out[i] = envs[i].echo_bins.levels(envelope)
        return out

    return finish


_WORKER: tuple[int, ThreadPoolExecutor] | None = None


def _worker() -> ThreadPoolExecutor:
    """The one thread that sends pulses, made in this process (a forked child, as in
    Gymnasium's async vector environments, makes its own: threads do not survive a fork)."""
    global _WORKER
    if _WORKER is None or _WORKER[0] != os.getpid():
        _WORKER = (os.getpid(), ThreadPoolExecutor(1, thread_name_prefix="batecho-pulses"))
    return _WORKER[1]
