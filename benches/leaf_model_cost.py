"""What each leaf model costs per pulse: physical optics against the paper fit, exact and fast.

Scene: 20,000 leaves of one radius (2 mm, 5 mm, 2 cm), centres uniform in x in [1, 9.5],
y, z in [-2, 2] m, normals uniform on the sphere; sonar at the origin looking along +x, 50 deg
beam, a 75 deg cone (every leaf counts), 1201 bins. Both models and both methods are timed in
one run (min of repeats; the machine is shared and noisy, so compare within a run only).

    python benches/leaf_model_cost.py [--repeat 3] [--leaves 20000]
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np

import batecho


def best_time(fn, repeat):
    """Least wall time of `repeat` calls, and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--leaves", type=int, default=20_000)
    args = ap.parse_args()
    rng = np.random.default_rng(1)
    n = args.leaves
    centers = np.column_stack(
        [rng.uniform(1, 9.5, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)]
    )
    normals = rng.normal(size=(n, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    poses = batecho.Poses(positions=[[0, 0, 0]], forward=[[1, 0, 0]], up=[[0, 0, 1]])
    print("| radius | model | exact (ms) | ns per term per core | fast, tol 1e-6 (ms) | error |")
    print("|---|---|---|---|---|---|")
    for radius in (0.002, 0.005, 0.02):
        leaves = batecho.Leaves(centers=centers, normals=normals, radii=np.full(n, radius))
        scene = batecho.Scene(leaves)
        for model in ("physical_optics", "paper"):
            sonar = batecho.Sonar(
                beamwidth_deg=50,
                lobe="cone",
                cone_half_angle_deg=75,
                leaf_model=model,
                min_ka=0.01,
            )
            run = functools.partial(batecho.simulate, scene, sonar, poses)
            t_exact, exact = best_time(functools.partial(run, method="exact"), args.repeat)
            t_fast, fast = best_time(functools.partial(run, method="fast", tol=1e-6), args.repeat)
            err = np.linalg.norm(fast.spectrum - exact.spectrum) / np.linalg.norm(exact.spectrum)
            per_term = 2e9 * t_exact / (n * sonar.n_bins)
            print(
                f"| {radius * 1e3:g} mm | {model} | {1e3 * t_exact:.1f} | {per_term:.1f} "
                f"| {1e3 * t_fast:.1f} | {err:.1e} |"
            )


if __name__ == "__main__":
    main()
