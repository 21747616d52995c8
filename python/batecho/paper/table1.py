"""Table 1 of the paper rerun: the impulse computation of a whole circle timed for 1-15 pulse
points and 1-5 trees, beside the paper's MATLAB times."""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._resources import check_memory, echoes_bytes_per_pulse
from ..echoes.simulate import DEFAULT_METHOD, DEFAULT_TOL, simulate
from ..flight.kinematic import circle
from ..forest.ipp import draw_tree_positions
from ..forest.models import make_forest
from ..forest.scene import Scene
from ..outputs.npz import write_npz
from .settings import (
    DEFAULT_SEED,
    PAPER_ALTITUDE_M,
    PAPER_MACHINE,
    PAPER_POINTS,
    PAPER_RADIUS_M,
    PAPER_TABLE1,
    PAPER_TREES,
    TABLE1_BEAMWIDTH_DEG,
    Progress,
    jsonable,
    machine_info,
    no_progress,
    paper_circle_radius,
    paper_sonar,
    tree_settings,
)

__all__ = ["Table1Result", "table1"]


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
        method, tol = s.get("method", DEFAULT_METHOD), s.get("tol", DEFAULT_TOL)
        return (
            "batecho paper table1"
            f" --points {','.join(map(str, self.points))}"
            f" --trees {','.join(map(str, self.trees))}"
            f" --repeats {self.repeats}"
            f" --seed {s.get('seed')}"
            f" --beamwidth {s.get('sonar', {}).get('beamwidth_deg', TABLE1_BEAMWIDTH_DEG):g}"
            f" --heading {s.get('heading', 'center')}"
            + (
                f" --method {method} --tol {tol:g}"
                if (method, tol) != (DEFAULT_METHOD, DEFAULT_TOL)
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
            f"- flight: circle of radius {_radius_text(s)} at {s.get('altitude_m')} m "
            f"around the mean tree position, pulses at equal angles, heading "
            f"`{s.get('heading')}`",
            f"- sonar: `{json.dumps(s.get('sonar', {}), sort_keys=True)}` (other parameters at "
            "the model's defaults (docs/model.md))",
            f"- timing: {s.get('timing', '')}",
            f"- machine: `{json.dumps(m, sort_keys=True)}`",
            "",
        ]
        return "\n".join(lines)

    def to_npz(self, path: str | os.PathLike) -> Path:
        """Save the arrays and the settings (as JSON) to an NPZ file."""
        return write_npz(
            path,
            {
                "points": np.asarray(self.points),
                "trees": np.asarray(self.trees),
                "repeats": self.repeats,
                "times_s": self.times_s,
                "cpu_times_s": np.full_like(self.times_s, np.nan)
                if self.cpu_times_s is None
                else self.cpu_times_s,
                "build_times_s": self.build_times_s,
                "grow_times_s": self.grow_times_s,
                "n_leaves_scene": self.n_leaves_scene,
                "n_leaves_lobe": self.n_leaves_lobe,
                "paper_times_s": np.array(
                    [[self.paper_time_s(p_, t) or np.nan for t in self.trees] for p_ in self.points]
                ),
                "batecho_version": self.settings.get("machine", {}).get("batecho", ""),
            },
            {"settings_json": self.settings},
        )


def _radius_text(s: dict[str, Any]) -> str:
    if s.get("radius_m") is not None:
        return f"{s['radius_m']} m"
    radii = s.get("radii_m", {})
    return (
        f"{PAPER_RADIUS_M:g} m, widened to clear every crown by 0.5 m where it does not ("
        + ", ".join(f"{k}: {v:g} m" for k, v in radii.items())
        + ")"
    )


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
    radius_m: float | None = None,
    altitude_m: float = PAPER_ALTITUDE_M,
    tree_model: str = "grow_tree",
    tree_params: dict | None = None,
    timing_runs: int = 3,
    sonar_params: dict | None = None,
    method: str = DEFAULT_METHOD,
    tol: float = DEFAULT_TOL,
    progress: Progress | None = None,
) -> Table1Result:
    """Rerun the paper's Table 1 with batecho.

    For each number of trees T in ``trees`` and each of ``repeats`` forests: T positions from
    the paper's IPP conditioned on T points (:func:`draw_tree_positions`), a tree grown at
    each (``tree_model``, ``tree_params``), one ``Scene`` for the forest; then for each count N
    in ``points``, N pulses at equal angles on a circle at ``altitude_m`` around the mean tree
    position, of radius ``radius_m`` or by default the paper's 6.2 m widened where needed to
    clear every crown by 0.5 m (:func:`~batecho.paper.settings.paper_circle_radius`; the
    radii are in ``settings["radii_m"]``), the beam ``heading`` toward the centre (``"center"``) or
    along the path (``"velocity"``), and the impulse responses of the whole circle in one
    ``batecho.simulate`` call, timed (best of ``timing_runs``, after one warm-up call for the
    whole table). ``sonar_params`` are further :class:`batecho.Sonar` arguments; ``method``
    and ``tol`` go to ``batecho.simulate`` (``"exact"``: every leaf-bin term; the default
    ``"auto"`` picks, per pose, the cheaper of the exact sum and the fast method). ``progress``
    wraps the loop over forests (e.g. ``tqdm``).
    """
    pts = _grid(points, "points")
    trs = _grid(trees, "trees")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    if isinstance(timing_runs, bool) or not isinstance(timing_runs, int) or timing_runs < 1:
        raise ValueError(f"timing_runs must be an integer >= 1, got {timing_runs!r}")
    opts: dict[str, Any] = {"method": method, "tol": float(tol)}
    sonar = paper_sonar(beamwidth_deg, **(sonar_params or {}))
    # The largest circle's echoes, sized before any forest is grown.
    n = sonar._provisional_n() if sonar.is_auto else int(sonar.n_samples)
    bins = (float(sonar.band_hz[1]) - float(sonar.band_hz[0])) * n / sonar.fs + 1.0
    check_memory(
        max(pts) * echoes_bytes_per_pulse(bins, n),
        f"points = {max(pts)}: a circle of {max(pts)} pulses",
        "use fewer points",
    )
    settings: dict[str, Any] = {
        "method": method,
        "tol": float(tol),
        "seed": int(seed),
        "repeats": int(repeats),
        "points": list(pts),
        "trees": list(trs),
        "radius_m": None if radius_m is None else float(radius_m),
        "radii_m": {},
        "altitude_m": float(altitude_m),
        "heading": heading,
        "sonar": {"beamwidth_deg": float(beamwidth_deg), "too_close": "skip"}
        | {k: jsonable(v) for k, v in (sonar_params or {}).items()},
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
    wrap = progress or no_progress
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
        radius = paper_circle_radius(forest, center) if radius_m is None else float(radius_m)
        settings["radii_m"][f"T={t}, forest {r}"] = radius
        for i, n in enumerate(pts):
            poses = circle(center, radius, altitude_m, n_points=n, heading=heading)
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
