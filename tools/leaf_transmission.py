#!/usr/bin/env python3
"""The default leaf transmission of shading (docs/model.md §10), recomputed.

A leaf's lamina passes about 1 % of the sound pressure at 70 kHz (the mass law), so a crossed
leaf is taken as an opaque disk, and what reaches a point behind it is what diffraction brings
round it. By Fresnel-Kirchhoff diffraction (Born & Wolf, *Principles of Optics*, §8.3), the field
at a point whose ray from the source crosses an opaque disk of radius ``a`` at offset ``rho``
from the disk's centre is

    U / U0 = 1 - (j / (lambda d)) * integral_disk exp(-j pi |x - rho|^2 / (lambda d)) dA,

with ``d = d1 d2 / (d1 + d2)`` for a disk ``d1`` from the source and ``d2`` before the point.
This script averages ``|U / U0|`` over rays that cross the disk (``rho`` uniform over its area)
and prints it for leaf radii and distances typical of one crown.

Usage: python3 tools/leaf_transmission.py [--f-khz 70]
"""

from __future__ import annotations

import argparse

import numpy as np


def field_behind_disk(a: float, d1: float, d2: float, rho: float, lam: float, n: int = 400):
    """U / U0 at offset ``rho`` from the centre of an opaque disk (midpoint rule in polar
    coordinates over the disk)."""
    d = d1 * d2 / (d1 + d2)
    r = (np.arange(n) + 0.5) / n * a
    th = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * np.pi
    R, T = np.meshgrid(r, th)
    x, y = R * np.cos(T) - rho, R * np.sin(T)
    area = (a / n) * (2 * np.pi / (2 * n))
    integral = np.sum(np.exp(-1j * np.pi * (x * x + y * y) / (lam * d)) * R) * area
    return 1.0 - 1j / (lam * d) * integral


def mean_transmission(a: float, d1: float, d2: float, lam: float, n_rays: int = 40) -> float:
    """The mean of |U / U0| over rays that cross the disk uniformly."""
    rho = a * np.sqrt((np.arange(n_rays) + 0.5) / n_rays)
    return float(np.mean([abs(field_behind_disk(a, d1, d2, q, lam)) for q in rho]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--f-khz", type=float, default=70.0)
    ap.add_argument("--sound-speed", type=float, default=340.0)
    args = ap.parse_args()
    lam = args.sound_speed / (args.f_khz * 1e3)
    print(f"mean |U/U0| behind an opaque disk at {args.f_khz:g} kHz (lambda = {lam * 1e3:.2f} mm)")
    print("radius_m  d1_m  d2_m  first_Fresnel_zone_m  mean_transmission")
    for a in (0.02, 0.025, 0.03):
        for d1, d2 in ((1.0, 0.05), (1.0, 0.2), (2.0, 0.5), (3.0, 1.0), (2.0, 2.0)):
            zone = np.sqrt(lam * d1 * d2 / (d1 + d2))
            t = mean_transmission(a, d1, d2, lam)
            print(f"{a:8.3f}  {d1:4.1f}  {d2:4.2f}  {zone:20.3f}  {t:17.2f}")


if __name__ == "__main__":
    main()
