#!/usr/bin/env python3
"""Fuzzer of scene files through the command line (``batecho simulate SCENE.toml``).

Each input is a seed scene file (leaf boxes, an OBJ tree, a grown tree, flown and kinematic
flights) with a few of its keys set to absurd values (negative, zero, -0.0, 1e-300, 1e300,
NaN, infinities, 2^63 - 1, wrong types, empty arrays and tables), deleted, or joined by
unknown keys, and now and then its text mutated byte by byte. The command must end with
status 0 (and finite echoes in its NPZ) or 2 with one line naming the problem; a traceback,
a crash, an abort, a hang or a run of more than a minute is a failure.

    python tools/fuzz/scenefile_fuzz.py            # short seeded run (CI)
    python tools/fuzz/scenefile_fuzz.py --long
"""

from __future__ import annotations

import argparse
import io
import json
import math
import random
import sys
import tempfile
import time
import warnings
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import child_main, run_campaign  # noqa: E402

ROOT = HERE.parents[1]
OBJ = ROOT / "tests" / "fixtures" / "obj" / "groups.obj"
#: A case slower than this (s) is a failure: no input may run for minutes unannounced.
SLOW_S = 60.0

BASES: list[dict] = [
    {
        "seed": 3,
        "scene": {
            "kind": "leaf_box",
            "density_per_m3": 3.0,
            "box": [[1.0, 4.0], [-1.0, 1.0], [-1.0, 1.0]],
        },
        "sonar": {"beamwidth_deg": 20, "n_samples": 4000},
        "flight": {
            "path": "circle",
            "radius": 6.0,
            "altitude": 0.0,
            "heading": "center",
            "n_pulses": 3,
        },
        "output": {"plots": []},
    },
    {
        "scene": {"kind": "leaf_box", "density_per_m3": 2.0},
        "sonar": {"n_samples": "auto", "lobe": "detectable"},
        "flight": {
            "path": "line",
            "start": [-3.0, 0.0, 0.0],
            "target": [5.0, 0.0, 0.0],
            "n_pulses": 2,
            "heading": "look_at",
        },
        "output": {"plots": [], "impulse": False},
    },
    {
        "scene": {"kind": "obj", "path": str(OBJ), "leaf_patterns": ["leaves", "foliage"]},
        "sonar": {"too_close": "skip", "n_samples": 3000, "fs": 200000.0},
        "flight": {
            "path": "waypoints",
            "points": [[-2.0, 0.0, 0.5], [2.0, 1.0, 0.5]],
            "pulse_rate_hz": 2.0,
            "speed": 2.0,
        },
        "output": {"plots": []},
    },
    {
        "scene": {"kind": "leaf_box", "density_per_m3": 1.0},
        "sonar": {"n_samples": 3000, "fs": 200000.0},
        "flight": {
            "path": "circle",
            "mode": "flown",
            "radius": 6.0,
            "pulse_rate_hz": 1.0,
            "duration": 1.0,
            "dt": 0.004,
            "heading": "center",
        },
        "output": {"plots": []},
    },
    {
        "seed": 5,
        "scene": {"kind": "tree", "tree": {}},
        "sonar": {"too_close": "skip", "n_samples": 3000, "fs": 200000.0},
        "flight": {"path": "circle", "radius": 6.0, "altitude": 4.0, "n_pulses": 2},
        "output": {"plots": []},
    },
]

KEYS = {
    "": ["seed", "method", "tol", "description"],
    "scene": [
        "density_per_m3",
        "box",
        "radius_mean_m",
        "radius_sd_m",
        "normal_angle_mean_deg",
        "normal_angle_sd_deg",
        "scale",
        "offset",
        "up",
        "per",
        "path",
        "n_trees",
        "position",
    ],
    "sonar": [
        "beamwidth_deg",
        "fs",
        "n_samples",
        "record_tail_s",
        "band_hz",
        "sound_speed",
        "lobe",
        "threshold_db",
        "cone_half_angle_deg",
        "max_range_m",
        "gain",
        "min_range_m",
        "min_ka",
        "horseshoe_bat_khz",
        "r0_m",
        "p0_pa",
        "p_ref_pa",
    ],
    "flight": [
        "n_pulses",
        "pulse_rate_hz",
        "duration",
        "dt",
        "radius",
        "altitude",
        "speed",
        "stop_distance",
        "start_angle_deg",
        "mode",
        "path",
        "heading",
        "yaw_deg",
        "center",
        "target",
        "start",
    ],
    "output": ["dpi", "sample_points", "max_scene_points", "plots", "npz", "impulse", "obj"],
    "sonar.beam": ["beamwidth_deg", "sigma_deg", "amplitude", "rotation_deg", "center_deg"],
    "sonar.absorption": ["temperature_c", "relative_humidity", "pressure_pa"],
    "flight.mount": ["offset", "pitch_deg", "yaw_deg", "roll_deg"],
}

VALUES = [
    -1,
    0,
    1,
    2,
    3,
    15,
    10_000_000,
    2**31,
    2**63 - 1,
    -(2**63),
    0.0,
    -0.0,
    -0.1,
    1e-12,
    1e-300,
    1e300,
    1e9,
    1e6,
    0.5,
    179.9,
    float("nan"),
    float("inf"),
    -float("inf"),
    "",
    "auto",
    "x",
    "line",
    "circle",
    "flown",
    "cone",
    "../../etc/passwd",
    "/dev/zero",
    True,
    False,
    [],
    [0.0, 0.0],
    [1.0, 2.0, 3.0],
    [[1.0, 2.0], [3.0]],
    [float("nan"), 1.0],
    ["scene", "impulses", "echo_image", "spectrogram", "spectrum"],
    ["scene"],
    {},
    {"x": 1},
    [1e300, -1e300],
    [[0.0, 1.0], [0.0, 1.0], [0.0, 1.0]],
]


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(doc: dict) -> str:
    """A scene document as TOML: top-level keys, then each table (nested ones dotted)."""
    out: list[str] = []

    def table(prefix: str, d: dict) -> None:
        plain = {k: v for k, v in d.items() if not (isinstance(v, dict) and v and prefix != "x")}
        subs = {k: v for k, v in d.items() if k not in plain}
        if prefix:
            out.append(f"[{prefix}]")
        out.extend(f"{json.dumps(k)} = {toml_value(v)}" for k, v in plain.items())
        for k, v in subs.items():
            table(f"{prefix}.{k}" if prefix else k, v)

    table("", doc)
    return "\n".join(out) + "\n"


def near(rng: random.Random, x: float) -> float:
    """A number of the same kind as ``x``, scaled or moved to an edge."""
    f = rng.choice([-1.0, 0.0, -0.0, 1e-9, 1e-3, 0.5, 2.0, 1e3, 1e6, 1e12, 1e300])
    if isinstance(x, int):
        return int(max(-(2**63), min(2**63 - 1, x * f)))
    return x * f if x else f


def make_input(seed: int, i: int) -> tuple[str, bool]:
    """Scene-file text and whether to draw the plots."""
    rng = random.Random(seed * 1_000_003 + i)
    doc = json.loads(json.dumps(rng.choice(BASES)))
    for _ in range(rng.choice([1, 1, 2, 3])):
        where = rng.choice(list(KEYS))
        t = doc
        for part in [p for p in where.split(".") if p]:
            t = t.setdefault(part, {})
            if not isinstance(t, dict):
                break
        if not isinstance(t, dict):
            continue
        present = [k for k, v in t.items() if not isinstance(v, dict)]
        key = rng.choice(present if present and rng.random() < 0.7 else KEYS[where])
        r = rng.random()
        if r < 0.08:
            t.pop(key, None)
        elif r < 0.12:
            t["unknown_" + key] = 1
        elif r < 0.6 and isinstance(t.get(key), (int, float)) and not isinstance(t[key], bool):
            t[key] = near(rng, t[key])
        else:
            t[key] = rng.choice(VALUES)
    text = to_toml(doc)
    if rng.random() < 0.1:  # text-level damage
        b = bytearray(text.encode())
        for _ in range(rng.randint(1, 4)):
            b[rng.randrange(len(b))] = rng.randrange(256)
        text = b.decode("utf-8", "replace")
    return text, rng.random() < 0.05


def run_case(seed: int, i: int, payload: dict) -> str:
    import numpy as np

    from batecho._resources import SlowWarning
    from batecho.cli.app import main

    text, plots = make_input(seed, i)
    with tempfile.TemporaryDirectory(prefix="batecho-scenefuzz-") as tmp:
        path = Path(tmp) / "scene.toml"
        path.write_text(text, encoding="utf-8")
        out = Path(tmp) / "out"
        argv = ["simulate", str(path), "--out", str(out), "-q"] + ([] if plots else ["--no-plots"])
        err, std = io.StringIO(), io.StringIO()
        t0 = time.perf_counter()
        try:
            with redirect_stderr(err), redirect_stdout(std), warnings.catch_warnings():
                # a run of minutes must say so first; said, it is not waited for here
                warnings.simplefilter("error", SlowWarning)
                rc = main(argv)
        except SlowWarning:
            return "announced slow"
        except BaseException as exc:  # a traceback is what this looks for
            return f"BUG: {type(exc).__name__}: {str(exc)[:300]}"
        dt = time.perf_counter() - t0
        if dt > SLOW_S:
            return f"BUG: slow ({dt:.0f} s) without saying so"
        text_err = err.getvalue()
        lines = [ln for ln in text_err.splitlines() if ln.startswith("batecho")]
        if rc == 2:
            if len(lines) != 1 or "error:" not in lines[0] or "Traceback" in text_err:
                return f"BUG: status 2 without a one-line error: {err.getvalue()[-300:]!r}"
            return "refused"
        if rc != 0:
            return f"BUG: status {rc}: {err.getvalue()[-300:]!r}"
        npz = out / "echoes.npz"
        if npz.exists():
            with np.load(npz) as z:
                for key in ("spectrum", "impulse"):
                    if key in z and not np.isfinite(z[key]).all():
                        return f"BUG: non-finite {key} in echoes.npz"
        return "ran"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--long", action="store_true", help="5000 inputs")
    ap.add_argument("-n", type=int, help="number of inputs")
    ap.add_argument("--seed", type=int, default=36)
    ap.add_argument("--budget-s", type=float, help="stop after this many seconds")
    ap.add_argument("--case", type=int, help="with --show: the input to write")
    ap.add_argument("--show", action="store_true", help="print input --case")
    args = ap.parse_args(argv)
    if args.child:
        child_main(run_case)
        return 0
    if args.show:
        text, plots = make_input(args.seed, args.case or 0)
        print(f"# plots: {plots}\n{text}")
        return 0
    n = args.n or (5000 if args.long else 120)
    return run_campaign(
        Path(__file__),
        "scene-file fuzz",
        n,
        batch_size=40,
        timeout_s=600.0,
        seed=args.seed,
        budget_s=args.budget_s,
    )


if __name__ == "__main__":
    sys.exit(main())
