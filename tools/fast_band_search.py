#!/usr/bin/env python3
"""The random search behind the fast method's wide-band rule (`band_tightening` in
rust/src/fast/plan.rs, docs/model.md §6): the error of `method="fast"` (and `"auto"`) against
the exact sum, over `tol`, by the band's ratio f_hi / f_lo.

Each case is one pose and 1-8 leaves in a cone lobe: a band with its top at 40-150 kHz and a
ratio of 1.1-12 (its bottom at least 5 kHz), fs of 250, 400 or 500 kHz, 4,000-30,000
samples, either leaf model, spreading or not, a Hann or rectangular window, air absorption
half the time; leaves at 0.3 m to the record's edge facing the sonar, edge-on or at random,
radii 2 mm - 20 cm; wood (1-4 branches) in a fifth of the cases; with `--ears`, two ears in
half the cases and shading in half. Each is run at tol 1e-3, 1e-4, 1e-6, 1e-9 and 1e-12, and
the table gives the largest relative L2 error over `tol` in each ratio bucket.

Usage: python3 tools/fast_band_search.py [--cases 3000] [--seed 11] [--ears]
"""

from __future__ import annotations

import argparse
import math
import warnings

import numpy as np

import batecho
from batecho import Atmosphere, Leaves, Poses, Sonar

TOLS = [1e-3, 1e-4, 1e-6, 1e-9, 1e-12]
BUCKETS = [1.0, 1.34, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 7.0, 13.0]


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def draw_case(rng: np.random.Generator, ears: bool):
    """A sonar, a scene and its band ratio, or None where the draw is refused (a leaf below
    `min_ka` on a low band, say)."""
    fs = float(rng.choice([250e3, 400e3, 500e3]))
    ratio = math.exp(rng.uniform(math.log(1.1), math.log(12.0)))
    f_hi = rng.uniform(40e3, min(0.45 * fs, 150e3))
    kw: dict = dict(
        fs=fs,
        n_samples=int(rng.integers(4000, 30000)),
        band_hz=(max(f_hi / ratio, 5e3), f_hi),
        leaf_model=str(rng.choice(["paper", "physical_optics"])),
        spreading=bool(rng.integers(2)),
        window=str(rng.choice(["hann", "rect"])),
        sound_speed=float(rng.uniform(330, 350)),
        lobe="cone",
        cone_half_angle_deg=float(rng.uniform(5, 80)),
    )
    if rng.integers(2):
        kw["absorption"] = Atmosphere(
            temperature_c=float(rng.uniform(-10, 40)),
            relative_humidity=float(rng.uniform(0, 100)),
        )
    if ears and rng.uniform() < 0.5:
        kw["shading"] = batecho.Shading()
    beamwidth_deg = float(rng.uniform(5, 120))
    try:
        if ears and rng.uniform() < 0.5:
            separation_m, yaw_deg = float(rng.uniform(0.01, 0.05)), float(rng.uniform(0, 30))
            sonar = Sonar.binaural(separation_m, yaw_deg, beamwidth_deg=beamwidth_deg, **kw)
        else:
            sonar = Sonar(beamwidth_deg=beamwidth_deg, **kw)
    except ValueError:
        return None
    half = math.radians(kw["cone_half_angle_deg"]) * 0.9
    centers, normals, radii = [], [], []
    for _ in range(int(rng.integers(1, 9))):
        r = math.exp(rng.uniform(math.log(0.3), math.log(sonar.record_range_m * 0.98)))
        th, ph = rng.uniform(0, half), rng.uniform(0, 2 * math.pi)
        e = np.array([math.cos(th), math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph)])
        kind = rng.integers(3)
        n = e if kind == 0 else np.cross(e, unit(rng.normal(size=3))) if kind == 1 else None
        normals.append(unit(rng.normal(size=3) if n is None else n))
        centers.append(r * e)
        radii.append(math.exp(rng.uniform(math.log(2e-3), math.log(0.2))))
    leaves = Leaves(np.array(centers), np.array(normals), np.array(radii))
    scene = batecho.Scene(leaves)
    if rng.uniform() < 0.2:
        k = int(rng.integers(1, 5))
        s = centers[0] + rng.normal(size=(k, 3)) * 0.5
        s[:, 0] = np.abs(s[:, 0]) + 0.5
        wood = batecho.Branches(s, s + rng.normal(size=(k, 3)), rng.uniform(0.01, 0.1, k))
        scene = batecho.Scene(leaves, branches=wood)
    return sonar, scene, f_hi / kw["band_hz"][0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--ears", action="store_true", help="two ears and shading, half the time")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(args.seed)
    pose = Poses([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    worst: dict = {}
    for _ in range(args.cases):
        case = draw_case(rng, args.ears)
        if case is None:
            continue
        sonar, scene, ratio = case
        try:
            exact = batecho.simulate(scene, sonar, pose, method="exact").spectrum
        except ValueError:
            continue
        norm = np.linalg.norm(exact)
        if not norm > 0:
            continue
        bucket = next(b for b in BUCKETS[1:] if ratio < b)
        for tol in TOLS:
            for method in ("fast", "auto"):
                got = batecho.simulate(scene, sonar, pose, method=method, tol=tol).spectrum
                e = float(np.linalg.norm(got - exact) / norm / tol)
                key = (method, bucket)
                worst[key] = max(worst.get(key, 0.0), e)
    print("| method | band ratio below | largest error / tol |")
    print("|---|---|---|")
    for method in ("fast", "auto"):
        for b in BUCKETS[1:]:
            if (method, b) in worst:
                print(f"| {method} | {b} | {worst[(method, b)]:.3f} |")


if __name__ == "__main__":
    main()
