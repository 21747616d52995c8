"""Drawing samples and writing them: in this process, in local worker processes, or on a
Dask cluster.

Sample ``i`` is a pure function of ``(spec, i)``: its random numbers come from
``SeedSequence(spec.seed).spawn(n)[i]`` (its child 0 draws the scene, child 1 the rest), so
the dataset does not depend on how many workers run it, or in which order. The unit of work
is a chunk of ``output.chunk_size`` samples: a worker draws them, writes the chunk to the
store and then marks it complete. A rerun skips marked chunks.

Local runs use a ``concurrent.futures.ProcessPoolExecutor`` (forkserver start), not a local
Dask cluster: it needs no extra package, starts in well under a second, opens no ports, and
runs the very task function (:func:`_run_chunk`) a Dask worker runs, so the two paths cannot
drift apart. Processes, not threads: the Python around each sample (scene drawing, labels,
Zarr encoding) holds the GIL. Dask (``client=``) adds what a cluster needs: many machines,
work stealing, and retrying a chunk whose worker died.
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing
import os
import sys
import time
from collections import OrderedDict
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import flag
from ..echoes.simulate import Echoes, lobe_members, simulate
from ..flight.poses import Poses
from ..sonar.sonar import Sonar
from .guard import StoreLock, watch_parent
from .scenes import BuiltScene, build_scene, scene_label_names
from .spec import DatasetSpec
from .store import StoreLike, _is_url, _zarr, open_for_generate, schema, write_chunk

__all__ = [
    "GenerateReport",
    "Sample",
    "SampleError",
    "compute_chunk",
    "draw_sample",
    "generate",
    "sample_seed",
]


class SampleError(RuntimeError):
    """Drawing or simulating one sample failed (the message names the sample)."""


# ------------------------------------------------------------------------------ seeds


def sample_seed(spec: DatasetSpec, i: int) -> np.random.SeedSequence:
    """Sample ``i``'s seed: ``SeedSequence(spec.seed).spawn(n_samples)[i]``, made directly."""
    if not 0 <= i < spec.n_samples:
        raise IndexError(f"sample {i} out of range (0..{spec.n_samples - 1})")
    return np.random.SeedSequence(spec.seed, spawn_key=(i,))


def _scene_rng(spec: DatasetSpec, j: int) -> np.random.Generator:
    # Scene j is drawn from child 0 of sample j's seed.
    return np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(j, 0)))


def _sample_rng(spec: DatasetSpec, i: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(spec.seed, spawn_key=(i, 1)))


class SceneCache:
    """The last few scenes built, by (spec hash, scene index): a worker builds a pooled scene
    once and reuses it for every sample of it that it draws."""

    def __init__(self, maxsize: int = 2):
        self.maxsize = maxsize
        self._items: OrderedDict[tuple[str, int], BuiltScene] = OrderedDict()

    def get(self, spec: DatasetSpec, j: int) -> BuiltScene:
        if spec.scene.reuse == "per_sample":
            return build_scene(spec, _scene_rng(spec, j))
        key = (spec.sha256, j)
        if key in self._items:
            self._items.move_to_end(key)
            return self._items[key]
        built = build_scene(spec, _scene_rng(spec, j))
        self._items[key] = built
        while len(self._items) > self.maxsize:
            self._items.popitem(last=False)
        return built


# ---------------------------------------------------------------------------- samples


@dataclass(frozen=True)
class Sample:
    """One drawn sample: its scene, sonar, poses, echoes and labels.

    ``labels`` maps each label to a scalar (per sample) or a (p,) array (per pulse).
    """

    index: int
    scene_index: int
    scene: BuiltScene
    sonar: Sonar
    poses: Poses
    echoes: Echoes
    labels: dict[str, Any]
    #: With a [call]: what the receivers record (the impulses convolved, plus the noise).
    received: np.ndarray | None = None


def draw_poses(
    spec: DatasetSpec, built: BuiltScene, rng: np.random.Generator
) -> tuple[Poses, dict[str, float]]:
    """The sample's ``pulses_per_sample`` poses and the pose parameters drawn."""
    from ..flight import kinematic as trajectories

    ps, p = spec.poses, spec.pulses_per_sample
    if ps.mode == "random":
        lo = built.bounds[0] - ps.margin_m
        hi = built.bounds[1] + ps.margin_m
        if np.any(lo > hi):
            raise ValueError(
                f"poses.margin_m = {ps.margin_m} m shrinks the scene's bounding box "
                f"({built.bounds[0].tolist()} .. {built.bounds[1].tolist()}) to nothing"
            )
        pos = rng.uniform(lo, hi, (p, 3))
        yaw = rng.uniform(0.0, 2.0 * np.pi, p)
        pitch = np.radians([ps.pitch_deg.draw(rng) for _ in range(p)])
        fwd = np.column_stack(
            [np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)]
        )
        return Poses(pos, fwd), {}
    c = built.center
    labels = {"altitude_m": ps.altitude_m.draw(rng)}
    if ps.path == "circle":
        labels["circle_radius_m"] = ps.circle_radius_m.draw(rng)
        labels["start_angle_deg"] = ps.start_angle_deg.draw(rng)
        poses = trajectories.circle(
            c[:2],
            radius=labels["circle_radius_m"],
            altitude=labels["altitude_m"],
            n_points=p,
            heading=ps.heading,
            start_angle_deg=labels["start_angle_deg"],
        )
        return poses, labels
    labels["bearing_deg"] = ps.bearing_deg.draw(rng)
    labels["start_distance_m"] = ps.start_distance_m.draw(rng)
    labels["run_length_m"] = ps.run_length_m.draw(rng)
    b, d = math.radians(labels["bearing_deg"]), labels["start_distance_m"]
    z = labels["altitude_m"]
    start = np.array([c[0] + d * math.cos(b), c[1] + d * math.sin(b), z])
    target = np.array([c[0], c[1], z])
    poses = trajectories.line_to(
        start,
        target,
        n_points=p,
        stop_distance=d - labels["run_length_m"],
        heading="look_at" if ps.heading == "center" else "velocity",
    )
    return poses, labels


def _lobe_labels(built: BuiltScene, sonar: Sonar, poses: Poses) -> dict[str, np.ndarray]:
    """Per pulse (and receiver, with ears): the range from the emitter to the nearest counting
    leaf and the counting leaves' mean radius (NaN where none counts)."""
    leaves = built.scene.leaves
    assert leaves is not None  # (the dataset's scenes always hold leaves)
    p, r = len(poses), sonar.n_receivers
    ears: list[int | None] = list(range(r)) if r else [None]
    nearest = np.full((p, len(ears)), np.nan)
    mean_radius = np.full((p, len(ears)), np.nan)
    for k in range(p):
        for j, ear in enumerate(ears):
            idx = lobe_members(built.scene, sonar, poses[k], receiver=ear)
            if idx.size:
                d = np.linalg.norm(leaves.centers[idx] - poses.positions[k], axis=1)
                nearest[k, j] = d.min()
                mean_radius[k, j] = leaves.radii[idx].mean()
    if not r:
        nearest, mean_radius = nearest[:, 0], mean_radius[:, 0]
    return {"nearest_range_m": nearest, "lobe_mean_radius_m": mean_radius}


def _wood_labels(spec: DatasetSpec, built: BuiltScene, poses: Poses, echoes: Any) -> dict:
    """``n_shaded`` (with shading) and ``nearest_wood_m``, ``n_pieces`` (with branches)."""
    out: dict[str, Any] = {}
    if spec.sonar.shading:
        out["n_shaded"] = echoes.n_shaded
    wood = built.scene.branches
    if spec.has_wood and wood is not None:
        out["nearest_wood_m"] = np.array([wood.distance_to(p).min() for p in poses.positions])
        out["n_pieces"] = echoes.n_pieces
    return out


def draw_sample(spec: DatasetSpec, i: int, scenes: SceneCache | None = None) -> Sample:
    """Sample ``i`` of ``spec``: scene, beamwidth, poses, echoes and labels.

    The same for any caller, worker or order (see :func:`sample_seed`).
    """
    if not 0 <= i < spec.n_samples:
        raise IndexError(f"sample {i} out of range (0..{spec.n_samples - 1})")
    j = spec.scene_index(i)
    built = (scenes or SceneCache(0)).get(spec, j)
    rng = _sample_rng(spec, i)
    beamwidth = spec.sonar.beamwidth_deg.draw(rng)
    sonar = spec.sonar.make(beamwidth)
    poses, pose_labels = draw_poses(spec, built, rng)
    echoes = simulate(built.scene, sonar, poses)
    received = None
    if spec.call is not None:
        # (the noise drawn after everything else the sample draws)
        received = echoes.received(spec.call.make(sonar.fs), spec.call.noise_rms, rng)
    labels: dict[str, Any] = {
        "scene_index": j,
        "beamwidth_deg": beamwidth,
        **pose_labels,
        **{name: built.labels[name] for name in scene_label_names(spec)},
        "n_leaves": echoes.n_leaves,
        **_lobe_labels(built, sonar, poses),
        **_wood_labels(spec, built, poses, echoes),
    }
    return Sample(i, j, built, sonar, poses, echoes, labels, received)


def sample_arrays(spec: DatasetSpec, s: Sample) -> dict[str, np.ndarray]:
    """One sample's stored arrays (no sample axis), by variable name."""
    t0, t1 = spec.sonar.time_slice()
    out: dict[str, np.ndarray] = {}
    for v in schema(spec):
        if v.name == "impulse":
            a = s.echoes.impulse[..., t0:t1]
        elif v.name == "received":
            assert s.received is not None
            a = s.received[..., t0:t1]
        elif v.name in ("spectrum", "wood_spectrum"):
            a = getattr(s.echoes, v.name)
        elif v.name in ("position", "forward", "up"):
            a = getattr(s.poses, "positions" if v.name == "position" else v.name)
        else:
            a = s.labels[v.name]
        out[v.name] = np.asarray(a).astype(v.dtype, copy=False)
    return out


def compute_chunk(
    spec: DatasetSpec, k: int, scenes: SceneCache | None = None
) -> dict[str, np.ndarray]:
    """Chunk ``k``'s arrays (sample axis first), by variable name."""
    i0, i1 = spec.chunk_range(k)
    scenes = scenes if scenes is not None else SceneCache()
    rows = []
    for i in range(i0, i1):
        try:
            rows.append(sample_arrays(spec, draw_sample(spec, i, scenes)))
        except Exception as exc:
            raise SampleError(f"sample {i} (chunk {k}): {type(exc).__name__}: {exc}") from exc
    return {name: np.stack([r[name] for r in rows]) for name in rows[0]}


# ------------------------------------------------------------------- the worker task

_WORKER_SCENES = SceneCache()
_WORKER_GROUPS: OrderedDict[tuple[str, str], Any] = OrderedDict()


def _init_worker(rayon_threads: int, run_pid: int) -> None:
    """Process-pool initializer: bound the Rust thread pool before its first use, and end
    this worker when the run (process ``run_pid``) dies."""
    os.environ.setdefault("RAYON_NUM_THREADS", str(rayon_threads))
    watch_parent(run_pid)


def _run_chunk(store: str, spec_toml: str, k: int) -> tuple[int, int, float]:
    """The task a worker runs: compute chunk ``k`` and write it. Returns (k, marker, s)."""
    t0 = time.perf_counter()
    spec = DatasetSpec.from_toml_string(spec_toml)
    key = (store, spec.sha256)
    g = _WORKER_GROUPS.get(key)
    if g is None:
        g = _zarr().open_group(store, mode="r+", use_consolidated=False)
        _WORKER_GROUPS[key] = g
        while len(_WORKER_GROUPS) > 4:
            _WORKER_GROUPS.popitem(last=False)
    block = compute_chunk(spec, k, _WORKER_SCENES)
    marker = write_chunk(g, spec, k, block)
    return k, marker, time.perf_counter() - t0


# ----------------------------------------------------------------------- progress bar


class _Progress:
    """tqdm when installed, else a plain line on stderr (at most twice a second)."""

    def __init__(self, total: int, initial: int, desc: str, enabled: bool):
        self.total, self.n, self.desc, self.enabled = total, initial, desc, enabled
        self._bar = None
        self._t0 = time.perf_counter()
        self._last = 0.0
        self._first = initial
        if not enabled:
            return
        try:
            from tqdm.auto import tqdm
        except ImportError:
            self._write()
            return
        self._bar = tqdm(total=total, initial=initial, desc=desc, unit="sample", file=sys.stderr)

    def update(self, n: int) -> None:
        self.n += n
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.update(n)
        elif time.perf_counter() - self._last > 0.5 or self.n >= self.total:
            self._write()

    def _write(self) -> None:
        self._last = time.perf_counter()
        dt = self._last - self._t0
        rate = (self.n - self._first) / dt if dt > 0 else 0.0
        pct = 100.0 * self.n / self.total if self.total else 100.0
        sys.stderr.write(
            f"\r{self.desc}: {self.n}/{self.total} samples ({pct:.0f}%), {rate:.2f} samples/s"
        )
        sys.stderr.flush()

    def close(self) -> None:
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.close()
        else:
            sys.stderr.write("\n")
            sys.stderr.flush()


# ------------------------------------------------------------------------- generate


@dataclass(frozen=True)
class GenerateReport:
    """What :func:`generate` did. ``samples_per_s``: samples computed per second of wall time
    (store creation included)."""

    store: str
    n_samples: int
    n_chunks: int
    chunks_computed: int
    chunks_skipped: int
    samples_computed: int
    elapsed_s: float
    runner: str

    @property
    def samples_per_s(self) -> float:
        return self.samples_computed / self.elapsed_s if self.elapsed_s > 0 else float("inf")

    def summary(self) -> str:
        skipped = f", {self.chunks_skipped} already complete" if self.chunks_skipped else ""
        return (
            f"{self.store}: {self.samples_computed} samples in {self.chunks_computed} chunks "
            f"written in {self.elapsed_s:.1f} s ({self.samples_per_s:.2f} samples/s, "
            f"{self.runner}){skipped}"
        )


def _as_spec(spec: DatasetSpec | str | Path) -> DatasetSpec:
    if isinstance(spec, DatasetSpec):
        return spec
    if isinstance(spec, (str, Path)):
        return DatasetSpec.from_toml(spec)
    raise TypeError(f"spec must be a DatasetSpec or a path to a TOML file, got {spec!r}")


def _store_name(store: StoreLike) -> str:
    if isinstance(store, (str, Path)) and not _is_url(store):
        return str(Path(store).expanduser().resolve())
    if isinstance(store, str):
        return store
    raise TypeError(f"store must be a path or a URL, got {type(store).__name__}")


def _mp_context() -> Any:
    # Never fork a process whose Rust thread pool may already be running.
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


def _run_local(
    store: str, text: str, todo: list[int], workers: int, bar: _Progress, spec: DatasetSpec
) -> None:
    cpus = os.cpu_count() or 1
    with ProcessPoolExecutor(
        max_workers=workers,
        mp_context=_mp_context(),
        initializer=_init_worker,
        initargs=(max(1, cpus // workers), os.getpid()),
    ) as ex:
        futures = {ex.submit(_run_chunk, store, text, k): k for k in todo}
        pending = set(futures)
        try:
            while pending:
                # (each chunk as it completes: the progress bar moves, a failure stops the run)
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for f in done:
                    k = futures[f]
                    exc = f.exception()
                    if exc is not None:
                        raise RuntimeError(f"chunk {k} failed: {exc}") from exc
                    bar.update(len(range(*spec.chunk_range(k))))
        finally:
            for f in pending:
                f.cancel()


def _run_dask(
    store: str, text: str, todo: list[int], client: Any, bar: _Progress, spec: DatasetSpec
) -> None:
    from distributed import as_completed

    futures = [client.submit(_run_chunk, store, text, k, pure=False, retries=2) for k in todo]
    index = {f.key: k for f, k in zip(futures, todo, strict=True)}
    try:
        for f in as_completed(futures):
            k = index[f.key]
            try:
                f.result()
            except Exception as exc:
                raise RuntimeError(f"chunk {k} failed: {exc}") from exc
            bar.update(len(range(*spec.chunk_range(k))))
    finally:
        client.cancel([f for f in futures if not f.done()])


def generate(
    spec: DatasetSpec | str | Path,
    store: StoreLike,
    client: Any = None,
    workers: int | None = None,
    progress: bool = True,
) -> GenerateReport:
    """Generate the dataset ``spec`` into the Zarr store ``store`` (a path or URL).

    With no ``client`` it runs on this machine: ``workers`` processes (default: one per CPU;
    ``workers=1`` runs in this process). ``client`` (a ``distributed.Client`` or a scheduler
    address such as ``"tcp://10.0.0.1:8786"``) runs each chunk as a task on that Dask cluster;
    the workers must reach ``store`` (a shared file system, or an object-store URL).

    A store that already holds this spec is resumed: complete chunks are re-checked against
    their checksums and skipped (a damaged one is computed again), the others computed. A
    store made from another spec, or not by batecho, is refused. A local store is locked
    (``OUT.zarr.lock`` beside it) while this runs: a second ``generate`` on it raises
    :class:`~batecho.dataset.guard.StoreLockedError`. Local workers end when this process
    dies, however it dies.
    """
    spec = _as_spec(spec)
    progress = flag(progress, "progress")
    if workers is not None and (
        isinstance(workers, bool) or int(workers) != workers or workers < 1
    ):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if client is not None and workers is not None:
        raise ValueError(
            "give workers (local processes) or client (a Dask cluster, which has its own "
            "workers), not both"
        )
    t_start = time.perf_counter()
    name = _store_name(store)
    own_client = None
    if isinstance(client, str):  # connect first: a wrong address creates no store
        from distributed import Client

        client = own_client = Client(client)
    held = contextlib.ExitStack()
    try:
        if not _is_url(name):
            held.enter_context(StoreLock(name))  # one generate per store
        g, markers = open_for_generate(name, spec)
        todo = [k for k in range(spec.n_chunks) if markers[k] == 0]
        done = spec.n_samples - sum(len(range(*spec.chunk_range(k))) for k in todo)
        bar = _Progress(spec.n_samples, done, f"batecho dataset {spec.name}", progress)
        text = spec.to_toml()
        try:
            if client is not None:
                runner = f"dask scheduler {client.scheduler.address}"
                if todo:
                    _run_dask(name, text, todo, client, bar, spec)
            else:
                n = min(int(workers or os.cpu_count() or 1), max(1, len(todo)))
                if n == 1:
                    runner = "in-process"
                    scenes = SceneCache()
                    for k in todo:
                        write_chunk(g, spec, k, compute_chunk(spec, k, scenes))
                        bar.update(len(range(*spec.chunk_range(k))))
                else:
                    runner = f"{n} local processes"
                    _run_local(name, text, todo, n, bar, spec)
        finally:
            bar.close()
    finally:
        held.close()
        if own_client is not None:
            own_client.close()
    computed = sum(len(range(*spec.chunk_range(k))) for k in todo)
    return GenerateReport(
        store=name,
        n_samples=spec.n_samples,
        n_chunks=spec.n_chunks,
        chunks_computed=len(todo),
        chunks_skipped=spec.n_chunks - len(todo),
        samples_computed=computed,
        elapsed_s=time.perf_counter() - t_start,
        runner=runner,
    )
