"""What the clearance check costs a pulse: ``batecho.simulate`` with its check (one nearest-leaf
query per pose on the BVH, the default ``min_clearance_m = 0.5``) against the same call with
``min_clearance_m=0``, and the query alone, timed side by side in one run (the machine is shared
and noisy; only the ratios are meaningful).

Scenes: the flight of ``examples/flight.toml`` (three trees, 43 775 leaves, 195 pulses of a
flown circle) and Ming's canonical leaf box (3600 leaves, one pulse: the cheapest pulse there
is, so the check's largest share).

    python benches/bench_clearance.py [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import batecho
from batecho.echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar
from batecho.scenefile import SceneFile, setup_scenefile

EXAMPLE = Path(__file__).parents[1] / "examples" / "flight.toml"


def medians(fns: dict, n: int) -> dict:
    """Median wall time (s) of each function, the functions called in turn ``n`` times after
    one warm-up round (interleaved, so that the machine's load falls on all alike)."""
    for fn in fns.values():
        fn()
    times: dict = {k: [] for k in fns}
    for _ in range(n):
        for k, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - t0)
    return {k: statistics.median(v) for k, v in times.items()}


def report(name: str, scene, sonar, poses, repeat: int) -> None:
    pts = poses.positions
    t = medians(
        {
            "checked": lambda: batecho.simulate(scene, sonar, poses),
            "unchecked": lambda: batecho.simulate(scene, sonar, poses, min_clearance_m=0),
            "query": lambda: scene.clearance(pts),
        },
        repeat,
    )
    p = len(poses)
    ratio = t["checked"] / t["unchecked"]
    print(
        f"{name}: {scene.n_leaves:,} leaves, {p} pulse(s); simulate "
        f"{t['unchecked'] / p * 1e3:.3f} ms/pulse without the check, "
        f"{t['checked'] / p * 1e3:.3f} ms/pulse with it (ratio {ratio:.3f}); "
        f"the query alone {t['query'] / p * 1e6:.1f} us/pulse = "
        f"{100 * t['query'] / t['unchecked']:.2f} % of a pulse"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    from bench_canonical import machine

    print(machine())
    st = setup_scenefile(SceneFile.from_path(EXAMPLE))
    report("examples/flight.toml", st.scene, st.sonar, st.plan.poses, args.repeat)
    import numpy as np

    box = batecho.Scene(canonical_leaf_box(np.random.default_rng(2017)))
    report("canonical leaf box", box, canonical_sonar(), canonical_pose(), 5 * args.repeat)


if __name__ == "__main__":
    main()
