"""What shading costs per pulse: a fast pulse (tol 1e-6) shaded against the same pulse unshaded.

Scene: n leaves of radius 1-3 cm in a box 1-9.5 m in front of the sonar (x), y and z in
[-2, 2] m, normals uniform on the sphere; sonar at the origin looking along +x, a 75 deg cone
lobe (every leaf counts), 1201 bins, `Shading()` (tau 0.6, branches block). The unshaded and
the shaded pulse are timed side by side in one run (least of repeats; the machine is shared
and noisy, so compare within a run only). The issue's target: shading at most doubles the time
of a fast pulse at 1e5 leaves.

The second table times two ears (``Sonar.binaural``, 2 cm apart, shaded) against the one-ear
shaded pulse, in the same scene and run: each ear's rays are cast from its own place.

    python benches/bench_shading.py [--repeat 3] [--leaves 1e4 1e5 1e6] [--ears] [--cpu]

`--cpu` times by the process's CPU time instead of the wall clock: with `RAYON_NUM_THREADS=1`
that is the one thread's cost, which waiting for a shared core does not inflate.
"""

from __future__ import annotations

import argparse
import os
import time
from functools import partial

import numpy as np

import batecho

CLOCK = time.perf_counter


def best_time(fn, repeat):
    """Least time of `repeat` calls by `CLOCK`, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = CLOCK()
        out = fn()
        best = min(best, CLOCK() - t0)
    return best, out


def leaf_box(n: int, seed: int = 1) -> batecho.Leaves:
    rng = np.random.default_rng(seed)
    centers = np.column_stack(
        [rng.uniform(1, 9.5, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)]
    )
    return batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.03, n))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--leaves", type=float, nargs="+", default=[1e4, 1e5, 1e6])
    ap.add_argument("--ears", action="store_true", help="also time two shaded ears against one")
    ap.add_argument("--cpu", action="store_true", help="time by the process's CPU time")
    args = ap.parse_args()
    if args.cpu:
        global CLOCK
        CLOCK = time.process_time
    pose = batecho.Poses([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    plain = batecho.Sonar(beamwidth_deg=50.0, lobe="cone", cone_half_angle_deg=75.0)
    shaded = plain.replace(shading=batecho.Shading())
    clock = "CPU time" if args.cpu else "wall time"
    print(f"RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', '(all cores)')}, {clock}")
    print("| leaves in the lobe | unshaded fast (ms) | shaded fast (ms) | ratio | shaded leaves |")
    print("|---|---|---|---|---|")
    for n in (int(x) for x in args.leaves):
        scene = batecho.Scene(leaf_box(n))
        t0, e0 = best_time(partial(batecho.simulate, scene, plain, pose, "fast", 1e-6), args.repeat)
        t1, e1 = best_time(
            partial(batecho.simulate, scene, shaded, pose, "fast", 1e-6), args.repeat
        )
        print(
            f"| {int(e0.n_leaves[0]):,} | {1e3 * t0:.1f} | {1e3 * t1:.1f} | {t1 / t0:.2f} "
            f"| {int(e1.n_shaded[0]):,} |"
        )
    if args.ears:
        ears = batecho.Sonar.binaural(
            0.02,
            ear_yaw_deg=0.0,
            beamwidth_deg=50.0,
            lobe="cone",
            cone_half_angle_deg=75.0,
            shading=batecho.Shading(),
        )
        print()
        print("| leaves in the lobe | one ear shaded (ms) | two ears shaded (ms) | ratio |")
        print("|---|---|---|---|")
        for n in (int(x) for x in args.leaves):
            scene = batecho.Scene(leaf_box(n))
            t1, e1 = best_time(
                partial(batecho.simulate, scene, shaded, pose, "fast", 1e-6), args.repeat
            )
            t2, _ = best_time(
                partial(batecho.simulate, scene, ears, pose, "fast", 1e-6), args.repeat
            )
            print(f"| {int(e1.n_leaves[0]):,} | {1e3 * t1:.1f} | {1e3 * t2:.1f} | {t2 / t1:.2f} |")


if __name__ == "__main__":
    main()
