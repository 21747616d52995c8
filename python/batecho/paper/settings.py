"""The paper's settings and what its experiments share: its circle, beams and Table 1 grid,
the sonar of its figures, the record of a tree model's parameters and of the machine a timing
ran on."""

from __future__ import annotations

import dataclasses
import inspect
import math
import os
import platform
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from ..forest.clearance import DEFAULT_MIN_CLEARANCE_M
from ..forest.forest import Forest
from ..forest.models import tree_function
from ..sonar.sonar import Sonar

__all__ = [
    "DEFAULT_SEED",
    "PAPER_ALTITUDE_M",
    "PAPER_BEAMWIDTHS_DEG",
    "PAPER_CLEARANCE_M",
    "PAPER_MACHINE",
    "PAPER_POINTS",
    "PAPER_RADIUS_M",
    "PAPER_TABLE1",
    "PAPER_TREES",
    "TABLE1_BEAMWIDTH_DEG",
    "Progress",
    "jsonable",
    "machine_info",
    "no_progress",
    "paper_circle_radius",
    "paper_sonar",
    "tree_settings",
]

#: The paper's circle: radius (m) and sonar height (m).
PAPER_RADIUS_M = 6.2
PAPER_ALTITUDE_M = 5.0
#: The paper's circle passes through its own crowns. Its trees are about 8.4 m tall with
#: crowns from 2.4 m up that reach 3-4 m from the trunk (3 m at the 5 m flight height), and
#: the IPP's two clumps lie 10.6 m apart, so two or more trees stand about 5 m from their mean
#: position and the 6.2 m circle passes 1 m from their trunks. Our experiments keep the
#: 6.2 m where it clears every crown by this margin (m), and otherwise fly the smallest wider
#: circle that does (:func:`paper_circle_radius`).
PAPER_CLEARANCE_M = DEFAULT_MIN_CLEARANCE_M
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

Progress = Callable[..., Iterable]


def no_progress(iterable: Iterable, total: int | None = None, desc: str | None = None):
    return iterable


def tree_settings(model: str = "grow_tree", tree_params: dict | None = None) -> dict[str, Any]:
    """The tree model's full parameter set: its defaults (from its signature) with
    ``tree_params`` applied, as a JSON-able dict (for the record of an experiment)."""
    fn = tree_function(model)
    out: dict[str, Any] = {}
    for name, p in inspect.signature(fn).parameters.items():
        if name == "rng" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if p.default is not inspect.Parameter.empty:
            out[name] = jsonable(p.default)
    out.update({k: jsonable(v) for k, v in (tree_params or {}).items()})
    return {"function": f"batecho.trees.{fn.__name__}", "params": out}


def jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
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
            f.name: jsonable(getattr(x, f.name))
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
        usable: int | None = len(os.sched_getaffinity(0))
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


def paper_circle_radius(forest: Forest, center: Any) -> float:
    """The radius (m) of our circle about ``center``: the paper's 6.2 m if it passes at least
    :data:`PAPER_CLEARANCE_M` outside every crown at the paper's 5 m height, else the smallest
    radius that does (:meth:`batecho.Forest.clear_circle_radius`), rounded up to 0.1 m."""
    r = PAPER_RADIUS_M
    while True:
        c = forest.clear_circle_radius(center, r, PAPER_CLEARANCE_M, altitude=PAPER_ALTITUDE_M)
        if c == r:
            return r
        r = math.ceil(round(c * 10.0, 9)) / 10.0


def paper_sonar(beamwidth_deg: float, **kw: Any) -> Sonar:
    # Leaves within 1 cm of a pulse are left out instead of raising: the paper's circle around
    # the mean tree position can pass through a crown.
    kw.setdefault("too_close", "skip")
    return Sonar(beamwidth_deg=beamwidth_deg, **kw)
