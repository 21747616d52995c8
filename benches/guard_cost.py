"""What the resource guards and output checks cost per pulse, against the pulse itself, timed
side by side in one run on Ming's canonical scene (the machine is shared and noisy; only the
ratio is meaningful).

Per pulse, the guards add: the finiteness check of the pose's spectrum (M bins, re and im)
and impulse (n samples), timed here as NumPy's ``isfinite`` over arrays of those sizes (the
core's loop does the same work); and, per call, the memory estimates (a few float
operations). Direction vectors and parameters are checked once, when Leaves, Poses and Sonar
are made, not per pulse.

    python benches/guard_cost.py [--repeat 7] [--poses 16]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import batecho
from batecho._resources import check_memory, echoes_bytes_per_pulse
from batecho.echoes.canonical import canonical_leaf_box, canonical_sonar


def median_s(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--poses", type=int, default=16)
    ap.add_argument("--seed", type=int, default=2017)
    args = ap.parse_args()
    scene = batecho.Scene(canonical_leaf_box(np.random.default_rng(args.seed)))
    sonar = canonical_sonar()
    p = args.poses
    angles = np.linspace(-0.2, 0.2, p)
    poses = batecho.Poses(
        np.zeros((p, 3)), np.column_stack([np.cos(angles), np.sin(angles), np.zeros(p)])
    )
    m, n = sonar.n_bins, int(sonar.n_samples)
    re, im, y = np.ones(m), np.ones(m), np.ones(n)

    def pulses():
        batecho.simulate(scene, sonar, poses)

    def guards():
        for _ in range(p):
            assert np.isfinite(re).all() and np.isfinite(im).all() and np.isfinite(y).all()
        check_memory(p * echoes_bytes_per_pulse(m, n), "simulate", "")

    t_sim = median_s(pulses, args.repeat) / p
    t_guard = median_s(guards, args.repeat) / p
    print(f"canonical scene, {scene.n_leaves} leaves, M = {m} bins, n = {n} samples, {p} poses")
    print(f"simulate per pulse:   {t_sim * 1e6:10.1f} us")
    print(f"guards per pulse:     {t_guard * 1e6:10.1f} us")
    print(f"guards / pulse:       {t_guard / t_sim:10.2%}")


if __name__ == "__main__":
    main()
