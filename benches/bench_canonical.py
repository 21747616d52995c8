"""End-to-end benchmark on Ming's canonical scene: batecho.simulate against the NumPy reference,
timed side by side in one run (the machine is shared and noisy; only the ratio is meaningful).

Scene: leaves uniform in x in [1, 10], y, z in [-2, 2] m at 25 leaves/m^3; radius N(2, 0.2) cm;
normal at N(85, 5) deg from the x axis, uniform azimuth. Sonar at the origin looking along +x,
30 deg beam, the model's defaults (docs/model.md).

    python benches/bench_canonical.py [--repeat 5] [--seed 2017]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import batecho
from batecho import reference
from batecho.echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar
from batecho.paper import machine_info


def warm_median(fn, n):
    """Median wall time of n back-to-back calls after one warm-up call."""
    out = fn()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return out, statistics.median(times)


def machine() -> str:
    """The machine a figure was measured on, as one line (from batecho.paper.machine_info):
    CPU model with x86 family/model, vector instructions, logical CPUs, threads, date (UTC)
    and batecho's version. The lent machine changes between sessions, and figures from
    different CPUs do not compare."""
    m = machine_info()
    cpu = m["cpu"]
    if m["cpu_family_model"]:
        family, _, model = m["cpu_family_model"].partition("/")
        cpu += f" (family {family}, model {model})"
    threads = os.environ.get("RAYON_NUM_THREADS", str(m["usable_cpus"]))
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return (
        f"{cpu}, {m['vector_isa'] or 'no AVX2'}, {m['cpu_count']} logical CPUs, "
        f"{threads} threads; {when}; batecho {m['batecho']}"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seed", type=int, default=2017)
    args = ap.parse_args()
    leaves = canonical_leaf_box(np.random.default_rng(args.seed))
    sonar, pose = canonical_sonar(), canonical_pose()
    scene = batecho.Scene(leaves)
    # Alternate rounds: a warm batch of each, so that machine load hits both alike.
    rust_t, ref_t = [], []
    for _ in range(args.repeat):
        fast, t = warm_median(lambda: batecho.simulate(scene, sonar, pose), 20)
        rust_t.append(t)
        slow, t = warm_median(lambda: reference.simulate(leaves, sonar, pose), 2)
        ref_t.append(t)
    err = np.linalg.norm(fast.spectrum - slow.spectrum) / np.linalg.norm(slow.spectrum)
    m = int(fast.n_leaves[0])
    print(f"machine: {machine()}")
    print(
        f"canonical scene: {len(leaves)} leaves, {m} in the lobe, {sonar.n_bins} bins, "
        f"threads={os.environ.get('RAYON_NUM_THREADS', os.cpu_count())}"
    )
    med_rust, med_ref = statistics.median(rust_t), statistics.median(ref_t)
    print(
        f"batecho.simulate   : {med_rust * 1e3:8.2f} ms per pulse (median of {args.repeat} warm "
        f"batches; {med_rust / (m * sonar.n_bins) * 1e9:.2f} ns per (leaf, bin) of wall time)"
    )
    print(f"reference.simulate : {med_ref * 1e3:8.2f} ms per pulse")
    ratios = [r / f for r, f in zip(ref_t, rust_t, strict=True)]
    print(
        f"speed-up: {med_ref / med_rust:.1f}x  (range over rounds: "
        f"{min(ratios):.1f}x .. {max(ratios):.1f}x)"
    )
    print(f"relative L2 error of the spectrum: {err:.2e}")


if __name__ == "__main__":
    main()
