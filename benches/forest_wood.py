"""How much of a flight's echo comes from wood, and how much shading changes it, in the paper's
forest.

Forest: `Forest.paper_example(seed, variants=3)` with its trees' woody skeletons
(`forest.scene(branches=True)`); the paper's kinematic circle (15 pulses, 6.2 m around the
forest's mean position widened to clear every crown by 0.5 m, 5 m up, facing the centre);
`Sonar(beamwidth_deg=30, too_close="skip")`; fast method, tol 1e-6. Three runs of the same
pulses: leaves alone (the paper's model), leaves and wood, and leaves and wood with `Shading()`
(tau 0.6, branches block). Prints the wood's share of the echo energy (per flight and per
pulse), the leaves' energy lost to shading, the relative change of the echo that shading
makes, and the times; writes the three echo images and the scene to OUT.

    python benches/forest_wood.py [--seed 1] [--out forest-wood]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import batecho
from batecho import plotting


def energy(x: np.ndarray, axis=None) -> np.ndarray:
    return np.sum(np.abs(x) ** 2, axis=axis)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("forest-wood"))
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    forest = batecho.Forest.paper_example(np.random.default_rng(args.seed), variants=3)
    leaves_only = forest.scene()
    wooded = forest.scene(branches=True)
    assert wooded.branches is not None
    cx, cy = forest.mean_position
    radius = forest.clear_circle_radius((cx, cy), 6.2, altitude=5.0)
    poses = batecho.circle((cx, cy), radius=radius, altitude=5.0, n_points=15, heading="center")
    sonar = batecho.Sonar(beamwidth_deg=30, too_close="skip")
    runs = {}
    for name, scene, so in (
        ("leaves", leaves_only, sonar),
        ("leaves+wood", wooded, sonar),
        ("leaves+wood, shaded", wooded, sonar.replace(shading=batecho.Shading())),
    ):
        t0 = time.perf_counter()
        runs[name] = batecho.simulate(scene, so, poses, method="fast", tol=1e-6)
        runs[name + " time"] = time.perf_counter() - t0
    n_leaves = len(wooded.leaves) if wooded.leaves is not None else 0
    n_wood = len(wooded.branches)
    print(f"forest: {len(forest)} trees, {n_leaves:,} leaves, {n_wood:,} branch segments")
    e_leaf, e_wood, e_shade = runs["leaves"], runs["leaves+wood"], runs["leaves+wood, shaded"]
    assert e_wood.wood_spectrum is not None and e_shade.wood_spectrum is not None
    share = energy(e_wood.wood_spectrum) / energy(e_wood.spectrum)
    per_pulse = energy(e_wood.wood_spectrum, axis=1) / np.maximum(
        energy(e_wood.spectrum, axis=1), 1e-300
    )
    print(f"wood's share of the flight's echo energy, unshaded: {share:.3%}")
    lo, mid, hi = per_pulse.min(), np.median(per_pulse), per_pulse.max()
    print(f"  per pulse: min {lo:.3%}, median {mid:.3%}, max {hi:.3%}")
    leaf_part = e_shade.spectrum - e_shade.wood_spectrum
    print(f"wood's share, shaded: {energy(e_shade.wood_spectrum) / energy(e_shade.spectrum):.3%}")
    print(
        f"leaves' echo energy kept under shading: {energy(leaf_part) / energy(e_leaf.spectrum):.1%}"
    )
    kept = energy(e_shade.wood_spectrum) / energy(e_wood.wood_spectrum)
    print(f"wood's echo energy kept under shading: {kept:.1%}")
    change = np.linalg.norm(e_shade.spectrum - e_wood.spectrum) / np.linalg.norm(e_wood.spectrum)
    print(f"relative change of the echo (L2, spectra) that shading makes: {change:.2f}")
    print(
        f"shaded leaves per pulse: median {int(np.median(e_shade.n_shaded)):,} of "
        f"{int(np.median(e_shade.n_leaves)):,} counting"
    )
    for name in ("leaves", "leaves+wood", "leaves+wood, shaded"):
        print(f"time, {name}: {runs[name + ' time']:.2f} s for {len(poses)} pulses")
    args.out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, 3, figsize=(15, 4), constrained_layout=True, sharey=True)
    angle = np.degrees(np.arange(len(poses)) * 2 * np.pi / len(poses))
    for ax, name in zip(axes, ("leaves", "leaves+wood", "leaves+wood, shaded"), strict=True):
        plotting.plot_echo_image(
            runs[name],
            ax=ax,
            x=angle,
            xlabel="angle on the circle (deg)",
            title=name,
            max_range_m=10.0,
        )
    fig.savefig(args.out / "echo_images.png", dpi=120)
    fig = plotting.plot_scene_3d(wooded, poses=poses, sonar=sonar, lobe_poses=[0])
    fig.savefig(args.out / "scene.png", dpi=120)
    print(f"pictures: {args.out / 'echo_images.png'}, {args.out / 'scene.png'}")


if __name__ == "__main__":
    main()
