"""Two ears against one: the cost of a whole pulse (``batecho.simulate``, lobe query and
spectrum) heard by one ear, by two ears and by the emitter itself (monostatic), by the exact
and the fast method, at 1e4 and 1e5 leaves in the lobe, timed side by side in one run (the
machine is shared and noisy; only the ratios are meaningful).

Scene: leaves uniform in x in [1, 9.5], y, z in [-2, 2] m, radius N(2, 0.2) cm, random
normals; a 75-degree cone, so that every leaf counts. Ears 2 cm apart, turned 30 degrees
outward, 40-degree beams.

    python benches/bench_ears.py [--repeat 5] [--tol 1e-6]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import batecho
from batecho import Beam, Leaves, Poses, Receiver, Sonar


def box(n: int, rng: np.random.Generator) -> Leaves:
    centers = np.column_stack(
        [rng.uniform(1.0, 9.5, n), rng.uniform(-2.0, 2.0, n), rng.uniform(-2.0, 2.0, n)]
    )
    return Leaves(centers, rng.normal(size=(n, 3)), 0.02 + 0.002 * rng.normal(size=n))


def median_time(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--tol", type=float, default=1e-6, help="the fast method's tol")
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    args = ap.parse_args()
    base = dict(lobe="cone", cone_half_angle_deg=75.0)
    ear = Beam(beamwidth_deg=40.0)
    sonars = {
        "monostatic": Sonar(**base),
        "one ear": Sonar(receivers=(Receiver((0.0, 0.01, 0.0), ear),), **base),
        "two ears": Sonar.binaural(0.02, 30.0, ear_beam=ear, **base),
    }
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    print(
        f"{'leaves':>8} {'method':>6} " + " ".join(f"{k:>12}" for k in sonars) + "   2 ears/1 ear"
    )
    for n in args.sizes:
        scene = batecho.Scene(box(n, np.random.default_rng(7)))
        for method in ("exact", "fast"):
            t = {}
            for name, sonar in sonars.items():
                e = batecho.simulate(scene, sonar, pose, method=method, tol=args.tol)
                assert int(np.min(e.n_leaves)) == n

                def run(s=sonar, sc=scene, m=method):
                    batecho.simulate(sc, s, pose, method=m, tol=args.tol)

                t[name] = median_time(run, args.repeat)
            row = " ".join(f"{t[k] * 1e3:10.1f}ms" for k in sonars)
            print(f"{n:8d} {method:>6} {row}   {t['two ears'] / t['one ear']:.2f}")


if __name__ == "__main__":
    main()
