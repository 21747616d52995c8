"""What a wide band costs the fast method: one pulse over N leaves on 20-100 kHz (f_hi / f_lo
= 5, where the fast sum works at tol / 100), fast at each tol and exact, in one run.

Scene: N leaves of radius 1-3 cm in a box 1-9.5 m in front of the sonar, y and z in [-2, 2] m,
normals uniform on the sphere; a 75 deg cone lobe (every leaf counts). Times are the least of
`--repeat` calls, by the process's CPU time (run with RAYON_NUM_THREADS=1 for one thread's
cost).

    RAYON_NUM_THREADS=1 python benches/bench_wide_band.py [--leaves 1e5] [--tol 1e-3 1e-6]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import batecho


def best_cpu_ms(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return 1e3 * best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--leaves", type=float, default=1e5)
    ap.add_argument("--tol", type=float, nargs="+", default=[1e-3, 1e-6])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    n = int(args.leaves)
    rng = np.random.default_rng(1)
    centers = np.c_[rng.uniform(1, 9.5, n), rng.uniform(-2, 2, (n, 2))]
    leaves = batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.03, n))
    pose = batecho.Poses([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    sonar = batecho.Sonar(
        beamwidth_deg=50.0, lobe="cone", cone_half_angle_deg=75.0, band_hz=(20e3, 100e3)
    )
    exact = batecho.simulate(leaves, sonar, pose, "exact")
    print(f"{n:,} leaves, 20-100 kHz ({exact.spectrum.shape[1]} bins), CPU time")
    print("| method | ms | relative L2 error |")
    print("|---|---|---|")
    for tol in args.tol:
        run = lambda tol=tol: batecho.simulate(leaves, sonar, pose, "fast", tol)
        err = np.linalg.norm(run().spectrum - exact.spectrum) / np.linalg.norm(exact.spectrum)
        print(f"| fast {tol:g} | {best_cpu_ms(run, args.repeat):.1f} | {err:.1e} |")
    t = best_cpu_ms(lambda: batecho.simulate(leaves, sonar, pose, "exact"), 1)
    print(f"| exact | {t:.1f} | 0 |")


if __name__ == "__main__":
    main()
