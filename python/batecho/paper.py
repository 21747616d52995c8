"""The experiments of Tanveer et al., "Recreating Bat Behavior on Quad-rotor UAVs": Figures 5-10
and Table 1 (MODEL.md section 7), rerun with batecho.

* :func:`paper_figures` writes PNG figures in the spirit of the paper's Figures 5-10, plus a
  straight run toward a tree and echo images along the circle, and an NPZ with their data.
* :func:`table1` times the impulse computation for a whole circle (radius 6.2 m, altitude 5 m,
  around the mean tree position) with 1, 5, 10, 15 pulse points and T = 1...5 trees, and
  prints it beside the paper's MATLAB figures (:meth:`Table1Result.to_markdown`).

Trees come from :mod:`batecho.trees` and forests from :mod:`batecho.forest`. Tree positions are
drawn from the paper's inhomogeneous Poisson process (:func:`batecho.paper_intensity` on the
20 m x 20 m :data:`batecho.PAPER_WINDOW`) *conditioned on the number of trees*
(:func:`draw_tree_positions`). Units: metres, seconds; degrees only in names ending ``_deg``.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import math
import os
import platform
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .echoes import lobe_members, simulate
from .ipp import PAPER_WINDOW, paper_intensity, sample_ipp
from .poses import Poses, look_at
from .scene import Scene
from .sonar import Sonar
from .trajectories import circle, line_to

__all__ = [
    "PAPER_ALTITUDE_M",
    "PAPER_BEAMWIDTHS_DEG",
    "PAPER_MACHINE",
    "PAPER_POINTS",
    "PAPER_RADIUS_M",
    "PAPER_TABLE1",
    "PAPER_TREES",
    "TABLE1_BEAMWIDTH_DEG",
    "Table1Result",
    "draw_tree_positions",
    "forest_available",
    "machine_info",
    "make_forest",
    "paper_figures",
    "table1",
]

#: The paper's circle: radius (m) and sonar height (m).
PAPER_RADIUS_M = 6.2
PAPER_ALTITUDE_M = 5.0
#: The beamwidths (full -3 dB, degrees) the paper's figures use.
PAPER_BEAMWIDTHS_DEG = (10.0, 20.0, 50.0)
#: Table 1's grid: pulse points on the circle, and numbers of trees.
PAPER_POINTS = (1, 5, 10, 15)
PAPER_TREES = (1, 2, 3, 4, 5)
#: Table 1 of the paper: total impulse-computation time (s) for a whole circle,
#: ``PAPER_TABLE1[points][T - 1]``.
PAPER_TABLE1: dict[int, tuple[float, ...]] = {
    1: (0.73, 0.77, 0.86, 0.93, 1.07),
    5: (0.88, 1.00, 1.19, 1.33, 1.52),
    10: (0.97, 1.21, 1.42, 1.72, 2.11),
    15: (1.03, 1.68, 1.92, 2.54, 3.03),
}
PAPER_MACHINE = "MATLAB, Intel Core i7-3632QM (4 cores, 2.2 GHz), Ubuntu 16.04"
#: The paper does not say which beamwidth Table 1 used; we take its widest (most leaves).
TABLE1_BEAMWIDTH_DEG = 50.0
DEFAULT_SEED = 2021

_FOREST_MISSING = (
    "the paper's experiments need trees and forests (batecho.trees, batecho.forest), "
    "which this installation of batecho does not have"
)

Progress = Callable[..., Iterable]


def _no_progress(iterable: Iterable, total: int | None = None, desc: str | None = None):
    return iterable


# ------------------------------------------------------------------------------ forests


def _forest_modules():
    """``(batecho.trees, batecho.forest)``, or a RuntimeError saying they are missing."""
    try:
        from . import forest as forest_mod
        from . import trees as trees_mod
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise RuntimeError(f"{_FOREST_MISSING} ({exc})") from exc
    return trees_mod, forest_mod


def forest_available() -> bool:
    """Whether :mod:`batecho.trees` and :mod:`batecho.forest` can be imported."""
    try:
        _forest_modules()
    except RuntimeError:
        return False
    return True


def _tree_function(model: str):
    trees_mod, _ = _forest_modules()
    names = {"grow_tree": "grow_tree", "lsystem": "grow_lsystem_tree"}
    if model not in names:
        raise ValueError(f"tree model must be one of {sorted(names)}, got {model!r}")
    return getattr(trees_mod, names[model])


def tree_settings(model: str = "grow_tree", tree_params: dict | None = None) -> dict[str, Any]:
    """The tree model's full parameter set: its defaults (from its signature) with
    ``tree_params`` applied, as a JSON-able dict (for the record of an experiment)."""
    fn = _tree_function(model)
    out: dict[str, Any] = {}
    for name, p in inspect.signature(fn).parameters.items():
        if name == "rng" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if p.default is not inspect.Parameter.empty:
            out[name] = _jsonable(p.default)
    out.update({k: _jsonable(v) for k, v in (tree_params or {}).items()})
    return {"function": f"batecho.trees.{fn.__name__}", "params": out}


def draw_tree_positions(
    n_trees: int,
    rng: np.random.Generator,
    intensity: Any = None,
    window: Any = PAPER_WINDOW,
    max_rounds: int = 100_000,
) -> np.ndarray:
    """``n_trees`` tree positions (n, 2) m from the IPP conditioned on having ``n_trees`` points.

    Draws IPP realisations by thinning (:func:`batecho.sample_ipp`, default intensity
    :func:`batecho.paper_intensity` on :data:`batecho.PAPER_WINDOW`) and keeps the points in the
    order drawn until there are ``n_trees``. Given its count, an IPP's points are independent
    with density ``lambda / integral(lambda)``, and which points are kept depends on the counts
    only, so this is exactly the IPP conditioned on ``N = n_trees`` (Table 1 needs T trees; an
    unconditioned draw has a Poisson number of them, 6.6 on average for the paper's intensity).
    """
    if isinstance(n_trees, bool) or not isinstance(n_trees, (int, np.integer)) or n_trees < 1:
        raise ValueError(f"n_trees must be an integer >= 1, got {n_trees!r}")
    lam = paper_intensity() if intensity is None else intensity
    got: list[np.ndarray] = []
    have = 0
    for _ in range(int(max_rounds)):
        pts = sample_ipp(lam, window, rng)
        got.append(pts)
        have += len(pts)
        if have >= n_trees:
            return np.concatenate(got)[:n_trees]
    raise ValueError(
        f"the intensity gave only {have} points in {max_rounds} realisations; is it zero on "
        "the window?"
    )


def make_forest(
    positions: Any,
    rng: np.random.Generator,
    model: str = "grow_tree",
    tree_params: dict | None = None,
    **forest_kw: Any,
):
    """A :class:`batecho.forest.Forest` with a tree (``model``: ``"grow_tree"`` or
    ``"lsystem"``, with ``tree_params``) grown at each (x, y) of ``positions`` (m);
    ``forest_kw`` go to ``Forest.from_positions`` (``variants``, ``scale_sd``)."""
    _, forest_mod = _forest_modules()
    return forest_mod.Forest.from_positions(
        np.asarray(positions, dtype=np.float64).reshape(-1, 2),
        rng,
        tree=_tree_function(model),
        tree_params=dict(tree_params or {}),
        **forest_kw,
    )


# ------------------------------------------------------------------------------ records


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (Path,)):
        return str(x)
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        return {
            f.name: _jsonable(getattr(x, f.name))
            for f in dataclasses.fields(x)
            if not f.name.startswith("_")
        }
    if x is None or isinstance(x, (bool, int, float, str)):
        return x
    return repr(x)


def machine_info() -> dict[str, Any]:
    """Where a timing ran: CPU model (with its x86 family and model, and the widest vector
    instructions batecho dispatches to), CPU count, threads, OS, Python, NumPy and batecho
    versions. Lent machines change CPU between runs, and timings from different CPUs do not
    compare."""
    from . import _core

    info: dict[str, str] = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if not line.strip():
                    break  # the first processor's entry is enough
                key, _, value = line.partition(":")
                info.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    cpu = info.get("model name") or platform.processor() or ""
    flags = set(info.get("flags", "").split())
    vector = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else None
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not on Linux
        usable = os.cpu_count()
    try:
        load = [round(v, 2) for v in os.getloadavg()]
    except (AttributeError, OSError):  # pragma: no cover - not on Unix
        load = None
    return {
        "cpu": cpu or "unknown",
        "cpu_family_model": (
            f"{info['cpu family']}/{info.get('model', '?')}" if "cpu family" in info else None
        ),
        "vector_isa": vector,
        "load_average_1_5_15min": load,
        "cpu_count": os.cpu_count(),
        "usable_cpus": usable,
        "rayon_num_threads": os.environ.get("RAYON_NUM_THREADS", "unset (all usable CPUs)"),
        "platform": platform.platform(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "batecho": _core.__version__,
    }


def _sonar(beamwidth_deg: float, **kw: Any) -> Sonar:
    # Leaves within 1 cm of a pulse are left out instead of raising: the paper's circle around
    # the mean tree position can pass through a crown.
    kw.setdefault("too_close", "skip")
    return Sonar(beamwidth_deg=beamwidth_deg, **kw)


# ------------------------------------------------------------------------------ Table 1


@dataclass
class Table1Result:
    """Table 1 measured: arrays indexed ``[point index, tree index, repeat]``.

    ``times_s`` (P, T, R): wall time (s) of the ``batecho.simulate`` call for the whole circle
    (best of ``timing_runs``); ``build_times_s`` (T, R): ``Scene`` (BVH) construction, s;
    ``grow_times_s`` (T, R): growing the forest, s; ``n_leaves_scene`` (T, R): leaves in the
    scene; ``n_leaves_lobe`` (P, T, R): leaves that counted, summed over the circle's pulses;
    ``cpu_times_s`` (P, T, R): CPU time of the process (all threads) during the simulate call,
    s (a measure of the work that other programs on the machine do not inflate).
    ``settings``: everything needed to rerun it (seed, sonar, tree model, machine...).
    """

    points: tuple[int, ...]
    trees: tuple[int, ...]
    repeats: int
    times_s: np.ndarray
    build_times_s: np.ndarray
    grow_times_s: np.ndarray
    n_leaves_scene: np.ndarray
    n_leaves_lobe: np.ndarray
    settings: dict[str, Any] = field(default_factory=dict)
    cpu_times_s: np.ndarray | None = None

    @property
    def mean_times_s(self) -> np.ndarray:
        """(P, T) mean over the repeats (forests) of the circle's simulate time, s."""
        return self.times_s.mean(axis=-1)

    def paper_time_s(self, points: int, trees: int) -> float | None:
        """The paper's figure for ``points`` and ``trees``, s (None outside its grid)."""
        row = PAPER_TABLE1.get(int(points))
        if row is None or not 1 <= int(trees) <= len(row):
            return None
        return row[int(trees) - 1]

    def command(self) -> str:
        """The ``batecho`` command line that reruns this table."""
        s = self.settings
        return (
            "batecho paper table1"
            f" --points {','.join(map(str, self.points))}"
            f" --trees {','.join(map(str, self.trees))}"
            f" --repeats {self.repeats}"
            f" --seed {s.get('seed')}"
            f" --beamwidth {s.get('sonar', {}).get('beamwidth_deg', TABLE1_BEAMWIDTH_DEG):g}"
            f" --heading {s.get('heading', 'center')}"
            + (
                f" --method {s['method']} --tol {s['tol']:g}"
                if s.get("method", "exact") != "exact"
                else ""
            )
            + (
                f" --tree-model {s['tree_model']}"
                if s.get("tree_model", "grow_tree") != "grow_tree"
                else ""
            )
        )

    def to_markdown(self) -> str:
        """The table as Markdown: measured time beside the paper's, leaf counts, settings."""
        s = self.settings
        m = s.get("machine", {})
        head = "| points | " + " | ".join(f"T={t}" for t in self.trees) + " |"
        sep = "|---:|" + "---:|" * len(self.trees)
        lines = [
            "## Table 1: impulse-computation time for a whole circle",
            "",
            f"Each cell: **batecho** time in seconds (mean over {self.repeats} "
            f"forest{'s' if self.repeats != 1 else ''}), then the paper's MATLAB time "
            f"({PAPER_MACHINE}) in brackets, then the speed-up. batecho ran on "
            f"{m.get('cpu', '?')} ({m.get('usable_cpus', '?')} usable CPUs).",
            "",
            head,
            sep,
        ]
        mean = self.mean_times_s
        for i, p in enumerate(self.points):
            cells = []
            for j, t in enumerate(self.trees):
                ours = mean[i, j]
                ref = self.paper_time_s(p, t)
                cell = f"{ours:.4f}"
                if ref is not None:
                    cell += f" ({ref:.2f}; {ref / ours:,.0f}x)" if ours > 0 else f" ({ref:.2f})"
                cells.append(cell)
            lines.append(f"| {p} | " + " | ".join(cells) + " |")
        lines += [
            "",
            "Leaves that counted, summed over the circle's pulses (mean over forests):",
            "",
            head,
            sep,
        ]
        lobe = self.n_leaves_lobe.mean(axis=-1)
        for i, p in enumerate(self.points):
            lines.append(f"| {p} | " + " | ".join(f"{v:,.0f}" for v in lobe[i]) + " |")
        if self.cpu_times_s is not None:
            lines += [
                "",
                "CPU time of those calls, all threads together (s; mean over forests):",
                "",
                head,
                sep,
            ]
            cpu = self.cpu_times_s.mean(axis=-1)
            for i, p in enumerate(self.points):
                lines.append(f"| {p} | " + " | ".join(f"{v:.4f}" for v in cpu[i]) + " |")
        lines += [
            "",
            "The scenes (mean over forests; these are not in the times above):",
            "",
            "| | " + " | ".join(f"T={t}" for t in self.trees) + " |",
            "|---|" + "---:|" * len(self.trees),
            "| leaves in the scene | "
            + " | ".join(f"{v:,.0f}" for v in self.n_leaves_scene.mean(axis=-1))
            + " |",
            "| growing the forest (s) | "
            + " | ".join(f"{v:.3f}" for v in self.grow_times_s.mean(axis=-1))
            + " |",
            "| building the Scene / BVH (s) | "
            + " | ".join(f"{v:.4f}" for v in self.build_times_s.mean(axis=-1))
            + " |",
            "",
            "### Settings",
            "",
            f"- rerun: `{self.command()}`",
            f"- seed {s.get('seed')}; forest k of T trees uses "
            "`numpy.random.default_rng([seed, T, k])`, so a row does not depend on the others",
            f"- trees: {s.get('tree', {}).get('function', '?')} with "
            f"`{json.dumps(s.get('tree', {}).get('params', {}), sort_keys=True)}`",
            f"- positions: {s.get('positions', '')}",
            f"- flight: circle of radius {s.get('radius_m')} m at {s.get('altitude_m')} m "
            f"around the mean tree position, pulses at equal angles, heading "
            f"`{s.get('heading')}`",
            f"- sonar: `{json.dumps(s.get('sonar', {}), sort_keys=True)}` (other parameters at "
            "MODEL.md defaults)",
            f"- timing: {s.get('timing', '')}",
            f"- machine: `{json.dumps(m, sort_keys=True)}`",
            "",
        ]
        return "\n".join(lines)

    def to_npz(self, path: str | os.PathLike) -> Path:
        """Save the arrays and the settings (as JSON) to an NPZ file."""
        p = Path(path)
        np.savez(
            p,
            points=np.asarray(self.points),
            trees=np.asarray(self.trees),
            repeats=self.repeats,
            times_s=self.times_s,
            cpu_times_s=np.full_like(self.times_s, np.nan)
            if self.cpu_times_s is None
            else self.cpu_times_s,
            build_times_s=self.build_times_s,
            grow_times_s=self.grow_times_s,
            n_leaves_scene=self.n_leaves_scene,
            n_leaves_lobe=self.n_leaves_lobe,
            paper_times_s=np.array(
                [[self.paper_time_s(p_, t) or np.nan for t in self.trees] for p_ in self.points]
            ),
            settings_json=json.dumps(self.settings, sort_keys=True),
            batecho_version=self.settings.get("machine", {}).get("batecho", ""),
        )
        return p


def _grid(values: Sequence[int], name: str) -> tuple[int, ...]:
    out = []
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be integers >= 1, got {v!r}")
        out.append(int(v))
    if not out:
        raise ValueError(f"{name} must not be empty")
    return tuple(out)


def table1(
    points: Sequence[int] = PAPER_POINTS,
    trees: Sequence[int] = PAPER_TREES,
    seed: int = DEFAULT_SEED,
    repeats: int = 3,
    beamwidth_deg: float = TABLE1_BEAMWIDTH_DEG,
    *,
    heading: str = "center",
    radius_m: float = PAPER_RADIUS_M,
    altitude_m: float = PAPER_ALTITUDE_M,
    tree_model: str = "grow_tree",
    tree_params: dict | None = None,
    timing_runs: int = 3,
    sonar_params: dict | None = None,
    method: str = "exact",
    tol: float = 1e-12,
    progress: Progress | None = None,
) -> Table1Result:
    """Rerun the paper's Table 1 with batecho.

    For each number of trees T in ``trees`` and each of ``repeats`` forests: T positions from
    the paper's IPP conditioned on T points (:func:`draw_tree_positions`), a tree grown at
    each (``tree_model``, ``tree_params``), one ``Scene`` for the forest; then for each count N
    in ``points``, N pulses at equal angles on a circle of ``radius_m`` at ``altitude_m``
    around the mean tree position, the beam ``heading`` toward the centre (``"center"``) or
    along the path (``"velocity"``), and the impulse responses of the whole circle in one
    ``batecho.simulate`` call, timed (best of ``timing_runs``, after one warm-up call for the
    whole table). ``sonar_params`` are further :class:`batecho.Sonar` arguments; ``method``
    and ``tol`` go to ``batecho.simulate`` (``"exact"``: every leaf-bin term). ``progress``
    wraps the loop over forests (e.g. ``tqdm``).
    """
    pts = _grid(points, "points")
    trs = _grid(trees, "trees")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    if isinstance(timing_runs, bool) or not isinstance(timing_runs, int) or timing_runs < 1:
        raise ValueError(f"timing_runs must be an integer >= 1, got {timing_runs!r}")
    from .scenefile import simulate_options

    opts = simulate_options(method, tol)
    sonar = _sonar(beamwidth_deg, **(sonar_params or {}))
    settings: dict[str, Any] = {
        "method": method,
        "tol": float(tol),
        "seed": int(seed),
        "repeats": int(repeats),
        "points": list(pts),
        "trees": list(trs),
        "radius_m": float(radius_m),
        "altitude_m": float(altitude_m),
        "heading": heading,
        "sonar": {"beamwidth_deg": float(beamwidth_deg), "too_close": "skip"}
        | {k: _jsonable(v) for k, v in (sonar_params or {}).items()},
        "tree_model": tree_model,
        "tree": tree_settings(tree_model, tree_params),
        "positions": "the paper's IPP (batecho.paper_intensity on batecho.PAPER_WINDOW, "
        "20 m x 20 m) conditioned on T points, drawn by thinning",
        "timing": f"wall time of one batecho.simulate(method={method!r}) call for the whole "
        "circle, best of "
        f"{timing_runs}; mean over {repeats} forests",
        "machine": machine_info(),
    }
    P, T, R = len(pts), len(trs), int(repeats)
    times = np.zeros((P, T, R))
    cpu = np.zeros((P, T, R))
    build = np.zeros((T, R))
    grow = np.zeros((T, R))
    n_scene = np.zeros((T, R), dtype=np.int64)
    n_lobe = np.zeros((P, T, R), dtype=np.int64)
    wrap = progress or _no_progress
    jobs = [(j, t, r) for j, t in enumerate(trs) for r in range(R)]
    warmed = False
    for j, t, r in wrap(jobs, total=len(jobs), desc="Table 1 forests"):
        rng = np.random.default_rng([int(seed), t, r])
        t0 = time.perf_counter()
        pos = draw_tree_positions(t, rng)
        forest = make_forest(pos, rng, tree_model, tree_params)
        t1 = time.perf_counter()
        scene = Scene(forest.leaves)
        t2 = time.perf_counter()
        grow[j, r], build[j, r] = t1 - t0, t2 - t1
        n_scene[j, r] = scene.n_leaves
        center = np.asarray(pos, dtype=np.float64).mean(axis=0)
        for i, n in enumerate(pts):
            poses = circle(center, radius_m, altitude_m, n_points=n, heading=heading)
            if not warmed:
                simulate(scene, sonar, poses, **opts)
                warmed = True
            best, best_cpu = math.inf, math.inf
            for _ in range(timing_runs):
                c0, s0 = time.process_time(), time.perf_counter()
                echoes = simulate(scene, sonar, poses, **opts)
                best = min(best, time.perf_counter() - s0)
                best_cpu = min(best_cpu, time.process_time() - c0)
            times[i, j, r] = best
            cpu[i, j, r] = best_cpu
            n_lobe[i, j, r] = int(echoes.n_leaves.sum())
    return Table1Result(pts, trs, R, times, build, grow, n_scene, n_lobe, settings, cpu)


# ------------------------------------------------------------------------------ figures


def _savefig(fig, path: Path, dpi: int) -> Path:
    fig.savefig(path, dpi=dpi)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


def _scene_and_impulse(forest, sonar, pose, members, echoes, title3d: str):
    """A figure: the scene with one pose and its lobe (left), its impulse response (right)."""
    from .plotting import _plt, plot_impulse, plot_scene_3d

    plt = _plt()
    fig = plt.figure(figsize=(13, 5.5), constrained_layout=True)
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    plot_scene_3d(forest, pose, sonar, members=members, ax=ax3, lobe_poses=[0], title=title3d)
    ax = fig.add_subplot(1, 2, 2)
    plot_impulse(echoes, 0, ax=ax)
    return fig


def _leaf_centroid(forest) -> np.ndarray:
    return np.asarray(forest.leaves.centers, dtype=np.float64).mean(axis=0)


def _crown_radius(forest, xy: np.ndarray) -> float:
    c = forest.leaves.centers
    return float(np.max(np.hypot(c[:, 0] - xy[0], c[:, 1] - xy[1])))


def paper_figures(
    out_dir: str | os.PathLike,
    seed: int = DEFAULT_SEED,
    *,
    tree_model: str = "grow_tree",
    tree_params: dict | None = None,
    dpi: int = 110,
    echo_pulses: int = 72,
    progress: Progress | None = None,
) -> dict[str, Path]:
    """Write the paper's Figures 5-10 (in spirit) as PNG files into ``out_dir``; return
    ``{name: path}``.

    * ``fig05_no_leaf_in_lobe.png``: one tree, a pose on the 6.2 m circle (5 m up) whose lobe
      (10 deg beam, along the path) holds no leaf, and its impulse response: exactly zero.
    * ``fig06_leaves_in_lobe.png``: the same tree, a pose looking at the crown (20 deg beam),
      the leaves in its lobe highlighted, and its impulse response (Figure 7).
    * ``fig07_impulse_beamwidths.png``: that pose's impulse responses with 10, 20, 50 deg beams.
    * ``fig08_two_trees_circle.png``: two trees and the circle (radius 6.2 m, 5 m up, around the
      mean tree position), 4 sample points looking at the centre (20 deg beam), chosen where
      the lobe holds leaves (spread over a 5 deg grid).
    * ``fig09_impulses_circle.png``: the impulse responses at those 4 points.
    * ``fig10_two_three_trees.png``: two and three trees, 15 sample points each (50 deg beam).
    * ``echo_image_circle.png``: envelopes of ``echo_pulses`` pulses around the two-tree circle,
      looking at the centre, with 10, 20 and 50 deg beams.
    * ``straight_run.png``: a straight run toward the single tree (20 deg beam, looking at the
      trunk at 5 m) with the echo image along it; ``straight_run_impulses.png``: 4 of its
      impulse responses.
    * ``paper_figures.npz``: poses, impulse responses and leaf counts behind the figures, the
      seed, the settings (JSON) and the batecho version.

    Tree positions for two and three trees come from the paper's IPP conditioned on the count;
    the single tree stands at the origin. Leaves within 1 cm of a pulse are left out.
    """
    from .plotting import (
        _plt,
        plot_echo_image,
        plot_impulse,
        plot_impulses,
        plot_scene_3d,
    )

    plt = _plt()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ss = np.random.SeedSequence(int(seed))
    rngs = [np.random.default_rng(s) for s in ss.spawn(3)]
    written: dict[str, Path] = {}
    data: dict[str, Any] = {}
    bw10, bw20, bw50 = PAPER_BEAMWIDTHS_DEG
    R, Z = PAPER_RADIUS_M, PAPER_ALTITUDE_M
    steps = ["one tree", "two trees", "three trees", "straight run"]
    wrap = progress or _no_progress
    it = iter(wrap(steps, total=len(steps), desc="paper figures"))

    # -- one tree: Figures 5, 6, 7 ---------------------------------------------------------
    next(it)
    tree_xy = np.zeros(2)
    forest1 = make_forest(tree_xy[None, :], rngs[0], tree_model, tree_params)
    scene1 = Scene(forest1.leaves)
    s10 = _sonar(bw10)
    cands = Poses.concatenate(
        [
            circle(tree_xy, R, Z, n_points=24, heading="velocity"),
            circle(tree_xy, R, Z, n_points=24, heading="fixed", yaw_deg=0.0),
        ]
    )
    empty = None
    for i in range(len(cands)):
        if len(lobe_members(scene1, s10, cands[i])) == 0:
            empty = cands[i]
            break
    if empty is None:
        raise RuntimeError("no pose on the circle has an empty lobe; is the tree that large?")
    e5 = simulate(scene1, s10, empty)
    if np.any(e5.impulse != 0.0):  # pragma: no cover - a bug, not a user error
        raise AssertionError("an empty lobe gave a non-zero echo")
    fig = _scene_and_impulse(
        forest1,
        s10,
        empty,
        None,
        e5,
        f"Figure 5: no leaf in the main lobe ({bw10:g} deg beam)",
    )
    written["fig05"] = _savefig(fig, out / "fig05_no_leaf_in_lobe.png", dpi)
    data["fig05_position"] = empty.positions[0]
    data["fig05_forward"] = empty.forward[0]
    data["fig05_impulse"] = e5.impulse[0]

    crown = _leaf_centroid(forest1)
    p6 = look_at([tree_xy[0] + R, tree_xy[1], Z], crown)
    s20 = _sonar(bw20)
    members6 = lobe_members(scene1, s20, p6)
    if len(members6) == 0:
        raise RuntimeError("the pose looking at the crown has no leaf in its lobe")
    e6 = simulate(scene1, s20, p6)
    fig = _scene_and_impulse(
        forest1,
        s20,
        p6,
        members6,
        e6,
        f"Figure 6: {len(members6)} leaves in the main lobe ({bw20:g} deg beam)",
    )
    written["fig06"] = _savefig(fig, out / "fig06_leaves_in_lobe.png", dpi)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), constrained_layout=True, sharex=True)
    imp7 = []
    for ax, bw in zip(axes, PAPER_BEAMWIDTHS_DEG, strict=True):
        e = simulate(scene1, _sonar(bw), p6)
        imp7.append(e.impulse[0])
        plot_impulse(
            e, 0, ax=ax, title=f"Figure 7: {bw:g} deg beam, {e.n_leaves[0]} leaves in the lobe"
        )
    written["fig07"] = _savefig(fig, out / "fig07_impulse_beamwidths.png", dpi)
    data["fig06_position"] = p6.positions[0]
    data["fig06_forward"] = p6.forward[0]
    data["fig06_members"] = members6
    data["fig07_beamwidths_deg"] = np.asarray(PAPER_BEAMWIDTHS_DEG)
    data["fig07_impulses"] = np.asarray(imp7)
    data["one_tree_positions"] = tree_xy[None, :]
    data["one_tree_n_leaves"] = scene1.n_leaves

    # -- two trees: Figures 8, 9 and the echo images ----------------------------------------
    next(it)
    pos2 = draw_tree_positions(2, rngs[1])
    forest2 = make_forest(pos2, rngs[1], tree_model, tree_params)
    scene2 = Scene(forest2.leaves)
    c2 = pos2.mean(axis=0)
    # Four sample points where the lobe holds leaves (the paper's "four instances"), spread
    # over the 72 points of a 5 deg grid; the quarter points if fewer than four hold any.
    grid = circle(c2, R, Z, n_points=72, heading="center")
    lit = np.flatnonzero(simulate(scene2, s20, grid).n_leaves > 0)
    pick = (
        lit[np.linspace(0, len(lit) - 1, 4).round().astype(int)]
        if len(lit) >= 4
        else np.arange(4) * 18
    )
    p8 = grid[pick]
    angles8 = 5.0 * pick
    e8 = simulate(scene2, s20, p8)
    m8 = [lobe_members(scene2, s20, p8[i]) for i in range(len(p8))]
    fig = plot_scene_3d(
        forest2,
        p8,
        s20,
        members=m8,
        trajectory=np.vstack([grid.positions, grid.positions[:1]]),
        title=f"Figure 8: two trees, circle of {R:g} m at {Z:g} m, 4 sample points "
        f"({bw20:g} deg beam)",
    )
    written["fig08"] = _savefig(fig, out / "fig08_two_trees_circle.png", dpi)
    fig = plot_impulses(
        e8,
        range(4),
        titles=[
            f"Figure 9: point {i + 1} ({angles8[i]:g} deg), {e8.n_leaves[i]} leaves"
            for i in range(4)
        ],
    )
    written["fig09"] = _savefig(fig, out / "fig09_impulses_circle.png", dpi)
    data["two_trees_positions"] = pos2
    data["fig09_angles_deg"] = angles8
    data["fig09_positions"] = p8.positions
    data["fig09_forward"] = p8.forward
    data["fig09_impulses"] = e8.impulse
    data["fig09_n_leaves"] = e8.n_leaves

    n_e = int(echo_pulses)
    angles = 360.0 * np.arange(n_e) / n_e
    pe = circle(c2, R, Z, n_points=n_e, heading="center")
    fig, axes = plt.subplots(3, 1, figsize=(9, 9.5), constrained_layout=True, sharex=True)
    for ax, bw in zip(axes, PAPER_BEAMWIDTHS_DEG, strict=True):
        ee = simulate(scene2, _sonar(bw), pe)
        plot_echo_image(
            ee,
            ax=ax,
            x=angles,
            xlabel="angle on the circle (deg)",
            title=f"Echoes around two trees, looking at the centre ({bw:g} deg beam)",
        )
        data[f"echo_image_{bw:g}deg_n_leaves"] = ee.n_leaves
    written["echo_image"] = _savefig(fig, out / "echo_image_circle.png", dpi)
    data["echo_image_angles_deg"] = angles
    data["echo_image_positions"] = pe.positions
    data["echo_image_forward"] = pe.forward

    # -- Figure 10: two and three trees, 15 points -------------------------------------------
    next(it)
    pos3 = draw_tree_positions(3, rngs[2])
    forest3 = make_forest(pos3, rngs[2], tree_model, tree_params)
    scene3 = Scene(forest3.leaves)
    s50 = _sonar(bw50)
    fig = plt.figure(figsize=(15, 7), constrained_layout=True)
    for k, (forest, scene, pos) in enumerate(((forest2, scene2, pos2), (forest3, scene3, pos3))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        p10 = circle(pos.mean(axis=0), R, Z, n_points=15, heading="center")
        m10 = [lobe_members(scene, s50, p10[i]) for i in range(len(p10))]
        e10 = simulate(scene, s50, p10)
        plot_scene_3d(
            forest,
            p10,
            s50,
            members=m10,
            ax=ax,
            lobe_poses=[0, 5, 10],
            trajectory=np.vstack([p10.positions, p10.positions[:1]]),
            title=f"Figure 10: {len(pos)} trees, 15 points, {int(e10.n_leaves.sum()):,} "
            f"leaf echoes ({bw50:g} deg beam)",
        )
        data[f"fig10_{len(pos)}_trees_n_leaves"] = e10.n_leaves
    written["fig10"] = _savefig(fig, out / "fig10_two_three_trees.png", dpi)
    data["three_trees_positions"] = pos3

    # -- a straight run toward the tree ----------------------------------------------------
    next(it)
    rc = _crown_radius(forest1, tree_xy)
    start = [tree_xy[0] - rc - 10.0, tree_xy[1], Z]
    target = [tree_xy[0], tree_xy[1], Z]
    pr = line_to(start, target, n_points=24, stop_distance=rc + 0.5)
    er = simulate(scene1, s20, pr)
    dist = np.linalg.norm(pr.positions[:, :2] - tree_xy, axis=1)
    mr = [lobe_members(scene1, s20, pr[i]) for i in (0, len(pr) - 1)]
    fig = plt.figure(figsize=(10, 11), constrained_layout=True)
    ax3 = fig.add_subplot(2, 1, 1, projection="3d")
    plot_scene_3d(
        forest1,
        pr,
        s20,
        members=mr,
        ax=ax3,
        lobe_poses=[0, len(pr) - 1],
        trajectory=pr.positions,
        title=f"A straight run toward the tree ({bw20:g} deg beam)",
    )
    ax = fig.add_subplot(2, 1, 2)
    plot_echo_image(
        er,
        ax=ax,
        x=dist,
        xlabel="distance to the trunk (m)",
        title="Echoes along the run (approaching from left to right)",
    )
    ax.invert_xaxis()
    written["straight_run"] = _savefig(fig, out / "straight_run.png", dpi)
    sel = np.unique(np.linspace(0, len(pr) - 1, 4).round().astype(int))
    fig = plot_impulses(
        er, sel, titles=[f"{dist[i]:.1f} m from the trunk, {er.n_leaves[i]} leaves" for i in sel]
    )
    written["straight_run_impulses"] = _savefig(fig, out / "straight_run_impulses.png", dpi)
    data["straight_run_positions"] = pr.positions
    data["straight_run_forward"] = pr.forward
    data["straight_run_n_leaves"] = er.n_leaves
    for _ in it:
        pass

    settings = {
        "seed": int(seed),
        "tree": tree_settings(tree_model, tree_params),
        "radius_m": R,
        "altitude_m": Z,
        "beamwidths_deg": list(PAPER_BEAMWIDTHS_DEG),
        "sonar": "MODEL.md defaults with too_close='skip' and the beamwidth of each figure",
        "rngs": "numpy SeedSequence(seed).spawn(3): one tree (also the straight run), two "
        "trees, three trees",
        "machine": machine_info(),
    }
    npz = out / "paper_figures.npz"
    np.savez(
        npz,
        seed=int(seed),
        settings_json=json.dumps(settings),
        **data,
        batecho_version=settings["machine"]["batecho"],
    )
    written["data"] = npz
    return written
