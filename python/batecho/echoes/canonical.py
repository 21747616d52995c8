"""Ready-made scenes: Ming et al.'s canonical leaf box (the echo engine's benchmark scene)."""

from __future__ import annotations

import numpy as np

from .._resources import BYTES_PER_LEAF, check_memory
from .._validate import finite_scalar, positive_scalar
from ..flight.poses import Poses
from ..sonar.sonar import Sonar
from ..trees.leaves import Leaves

#: Box of the canonical scene, metres: x in [1, 10], y and z in [-2, 2].
CANONICAL_BOX = ((1.0, 10.0), (-2.0, 2.0), (-2.0, 2.0))


def canonical_leaf_box(
    rng: np.random.Generator,
    density_per_m3: float = 25.0,
    box=CANONICAL_BOX,
    radius_mean_m: float = 0.02,
    radius_sd_m: float = 0.002,
    normal_angle_mean_deg: float = 85.0,
    normal_angle_sd_deg: float = 5.0,
) -> Leaves:
    """Leaves uniform in ``box`` at ``density_per_m3`` (the count is density x volume, rounded);
    radius Normal(2 cm, 0.2 cm) truncated positive; each normal at Normal(85 deg, 5 deg) from the
    x axis (the sonar's axis) with a uniform azimuth around it."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError("rng must be a numpy.random.Generator (np.random.default_rng(seed))")
    density = positive_scalar(density_per_m3, "density_per_m3")
    radius_mean_m = positive_scalar(radius_mean_m, "radius_mean_m", unit="m")
    # (+ 0.0 turns -0.0 into 0.0, which NumPy's normal takes as a scale)
    radius_sd_m = positive_scalar(radius_sd_m, "radius_sd_m", allow_zero=True, unit="m") + 0.0
    normal_angle_mean_deg = finite_scalar(normal_angle_mean_deg, "normal_angle_mean_deg")
    normal_angle_sd_deg = (
        positive_scalar(normal_angle_sd_deg, "normal_angle_sd_deg", allow_zero=True) + 0.0
    )
    (x0, x1), (y0, y1), (z0, z1) = box
    for axis, lo, hi in (("x", x0, x1), ("y", y0, y1), ("z", z0, z1)):
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(f"box: the {axis} range must be finite with lo < hi, got [{lo}, {hi}]")
    volume = (x1 - x0) * (y1 - y0) * (z1 - z0)
    check_memory(
        density * volume * BYTES_PER_LEAF,
        f"a leaf box of {density * volume:.3g} leaves (density_per_m3 = {density:g} in "
        f"{volume:.3g} m^3)",
        "lower density_per_m3 or shrink the box",
    )
    n = round(density * volume)
    if n < 1:
        raise ValueError(
            f"the box holds no leaf at density_per_m3 = {density:g} (volume {volume:.3g} m^3)"
        )
    centers = np.column_stack(
        [rng.uniform(x0, x1, n), rng.uniform(y0, y1, n), rng.uniform(z0, z1, n)]
    )
    radii = rng.normal(radius_mean_m, radius_sd_m, n)
    while (bad := radii <= 0).any():
        radii[bad] = rng.normal(radius_mean_m, radius_sd_m, bad.sum())
    theta = np.radians(rng.normal(normal_angle_mean_deg, normal_angle_sd_deg, n))
    phi = rng.uniform(0.0, 2.0 * np.pi, n)
    normals = np.column_stack(
        [np.cos(theta), np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi)]
    )
    return Leaves(centers, normals, radii)


def canonical_sonar(**kwargs) -> Sonar:
    """The canonical scene's sonar: the model's defaults (docs/model.md) with a 30 degree beam."""
    kwargs.setdefault("beamwidth_deg", 30.0)
    return Sonar(**kwargs)


def canonical_pose() -> Poses:
    """The sonar at the origin looking along +x, z up."""
    return Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


__all__ = ["CANONICAL_BOX", "canonical_leaf_box", "canonical_pose", "canonical_sonar"]
