"""Scene factories: one per ``scene.kind``, each turning a spec and a random generator into a
:class:`BuiltScene` (the leaves' BVH, the scene's centre and bounds, and its labels).

To add a kind: write ``build(spec, rng) -> BuiltScene`` and ``labels(spec) -> names`` (the
scalar labels ``build`` returns, in order) and register them in :data:`SCENE_KINDS`. The
spec's ``[scene.<kind>]`` table holds its parameters.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.special import ndtr, ndtri

from ..forest.forest import Forest
from ..forest.scene import Scene
from ..trees.leaves import Leaves
from .spec import DatasetSpec, Dist

__all__ = ["SCENE_KINDS", "BuiltScene", "SceneKind", "draw_leaf_shapes"]


@dataclass(frozen=True)
class BuiltScene:
    """A scene ready to simulate, with what a sample needs to place poses and label itself.

    ``center`` (3,) m: what flights circle and aim at. ``bounds`` ((3,), (3,)) m: where random
    poses go. ``labels``: scalar labels (drawn parameters and realised statistics).
    """

    scene: Scene
    center: np.ndarray
    bounds: tuple[np.ndarray, np.ndarray]
    labels: dict[str, float]


@dataclass(frozen=True)
class SceneKind:
    """A scene factory: ``build(spec, rng)`` and the names of the labels it reports."""

    name: str
    build: Callable[[DatasetSpec, np.random.Generator], BuiltScene]
    labels: Callable[[DatasetSpec], tuple[str, ...]]


# ------------------------------------------------------------------------ shared parts

_LEAF_PARAMS = (
    "radius_mean_m",
    "radius_sd_m",
    "normal_elevation_mean_deg",
    "normal_elevation_sd_deg",
)
_REALISED = ("n_leaves_scene", "leaf_density_per_m3", "mean_leaf_radius_m", "mean_leaf_tilt_deg")


def draw_leaf_shapes(
    spec: DatasetSpec, rng: np.random.Generator, n: int
) -> tuple[np.ndarray, np.ndarray, dict[str, float]]:
    """Radii (n,) m and unit normals (n, 3) of ``n`` leaves per ``spec.leaves``, and the four
    drawn distribution parameters. Radii: Normal(mean, sd) truncated below at ``radius_min_m``
    (by inverting the CDF, no rejection loop)."""
    lv = spec.leaves
    params = {name: getattr(lv, name).draw(rng) for name in _LEAF_PARAMS}
    mean, sd = params["radius_mean_m"], params["radius_sd_m"]
    if sd == 0.0:
        radii = np.full(n, mean)
    else:
        a = (lv.radius_min_m - mean) / sd
        v = 1.0 - rng.random(n)  # (0, 1]
        radii = mean - sd * ndtri(v * ndtr(-a))  # Z > a with Z ~ N(0, 1)
        radii = np.maximum(radii, lv.radius_min_m)
    el = np.radians(
        rng.normal(params["normal_elevation_mean_deg"], params["normal_elevation_sd_deg"], n)
    )
    az = rng.uniform(0.0, 2.0 * np.pi, n)
    normals = np.column_stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return radii, normals, params


def _realised(leaves: Leaves, volume_m3: float) -> dict[str, float]:
    tilt = np.degrees(np.arcsin(np.clip(np.abs(leaves.normals[:, 2]), 0.0, 1.0)))
    return {
        "n_leaves_scene": float(len(leaves)),
        "leaf_density_per_m3": len(leaves) / volume_m3,
        "mean_leaf_radius_m": float(leaves.radii.mean()),
        "mean_leaf_tilt_deg": float(tilt.mean()),
    }


# --------------------------------------------------------------------------- leaf box


def _leaf_box(spec: DatasetSpec, rng: np.random.Generator) -> BuiltScene:
    box = np.asarray(spec.scene.leaf_box.box_m, dtype=np.float64)
    lo, hi = box[:, 0], box[:, 1]
    volume = float(np.prod(hi - lo))
    density = spec.scene.leaf_box.density_per_m3.draw(rng)
    n = max(1, round(density * volume))
    centers = rng.uniform(lo, hi, (n, 3))
    radii, normals, params = draw_leaf_shapes(spec, rng, n)
    leaves = Leaves(centers, normals, radii)
    labels = {"density_per_m3": density, **params, **_realised(leaves, volume)}
    return BuiltScene(Scene(leaves), (lo + hi) / 2.0, (lo.copy(), hi.copy()), labels)


def _leaf_box_labels(spec: DatasetSpec) -> tuple[str, ...]:
    return ("density_per_m3", *_LEAF_PARAMS, *_REALISED)


# ----------------------------------------------------------------------------- forest


def _forest_intensity(spec: DatasetSpec, scale: float) -> Any:
    from ..forest.ipp import SquaredExponentialMixture, UniformIntensity, paper_intensity

    if spec.scene.forest.intensity == "homogeneous":
        return UniformIntensity(scale)
    p = paper_intensity()
    return SquaredExponentialMixture(p.centers, p.length_scales, p.weights * scale)


def _forest(spec: DatasetSpec, rng: np.random.Generator) -> BuiltScene:
    """A forest from ``batecho.forest.Forest.from_ipp``; uses ``Forest.scene()``,
    ``.n_trees``, ``.mean_position`` ((2,) or (3,) m) and ``.bounds()`` ((3,), (3,) m)."""
    fs = spec.scene.forest
    scale = fs.intensity_scale.draw(rng)
    scale_sd = fs.scale_sd.draw(rng)
    tree_params = {k: v.draw(rng) if isinstance(v, Dist) else v for k, v in fs.tree_params.items()}
    intensity = _forest_intensity(spec, scale)
    for _ in range(_MAX_FOREST_TRIES):
        forest = Forest.from_ipp(
            intensity,
            fs.window_m,
            rng,
            tree_params=tree_params,
            variants=fs.variants,
            scale_sd=scale_sd,
        )
        if forest.n_trees > 0:
            break
    else:
        raise ValueError(
            f"{_MAX_FOREST_TRIES} forests in a row had no tree: raise "
            "scene.forest.intensity_scale or enlarge scene.forest.window_m"
        )
    leaves = forest.scene().leaves
    assert leaves is not None  # (a forest's scene always holds its leaves)
    labels: dict[str, float] = {
        "intensity_scale": scale,
        "scale_sd": scale_sd,
        **{f"tree_{k}": float(tree_params[k]) for k in fs.random_tree_params()},
        "n_trees": float(forest.n_trees),
    }
    if fs.redraw_leaves:
        radii, normals, params = draw_leaf_shapes(spec, rng, len(leaves))
        leaves = Leaves(leaves.centers, normals, radii)
        labels.update(params)
    lo, hi = (np.asarray(b, dtype=np.float64).reshape(3) for b in forest.bounds())
    volume = float(np.prod(np.maximum(hi - lo, 1e-9)))
    labels.update(_realised(leaves, volume))
    center = np.asarray(forest.mean_position, dtype=np.float64).reshape(-1)
    if center.shape == (2,):
        center = np.array([center[0], center[1], 0.0])
    if fs.redraw_leaves:
        scene = Scene(leaves, branches=forest.branches if fs.branches else None)
    else:
        scene = forest.scene(branches=fs.branches)
    return BuiltScene(scene, center, (lo, hi), labels)


def _forest_labels(spec: DatasetSpec) -> tuple[str, ...]:
    fs = spec.scene.forest
    leaf = _LEAF_PARAMS if fs.redraw_leaves else ()
    tree = tuple(f"tree_{k}" for k in fs.random_tree_params())
    return ("intensity_scale", "scale_sd", *tree, "n_trees", *leaf, *_REALISED)


_MAX_FOREST_TRIES = 100


#: The scene kinds, by ``scene.kind``.
SCENE_KINDS: dict[str, SceneKind] = {
    "leaf_box": SceneKind("leaf_box", _leaf_box, _leaf_box_labels),
    "forest": SceneKind("forest", _forest, _forest_labels),
}


def build_scene(spec: DatasetSpec, rng: np.random.Generator) -> BuiltScene:
    """The scene of ``spec.scene.kind`` drawn with ``rng``."""
    return SCENE_KINDS[spec.scene.kind].build(spec, rng)


def scene_label_names(spec: DatasetSpec) -> tuple[str, ...]:
    return SCENE_KINDS[spec.scene.kind].labels(spec)


def scene_label_info(name: str) -> tuple[str, str]:
    """(units, description) of a scene label."""
    if name.startswith("tree_"):
        return ("1", f"tree parameter {name[5:]} drawn (batecho.grow_tree)")
    return SCENE_LABEL_INFO.get(name, ("1", name))


#: Units and descriptions of the scene labels.
SCENE_LABEL_INFO: dict[str, tuple[str, str]] = {
    "density_per_m3": ("m-3", "leaf density drawn for the leaf box"),
    "intensity_scale": ("1", "forest intensity scale drawn (paper: factor; homogeneous: m-2)"),
    "n_trees": ("1", "number of trees in the forest"),
    "scale_sd": ("1", "sd of the log tree size factor drawn"),
    "radius_mean_m": ("m", "mean of the leaf radius distribution drawn"),
    "radius_sd_m": ("m", "standard deviation of the leaf radius distribution drawn"),
    "normal_elevation_mean_deg": ("degree", "mean leaf normal elevation drawn"),
    "normal_elevation_sd_deg": ("degree", "sd of the leaf normal elevation drawn"),
    "n_leaves_scene": ("1", "number of leaves in the scene"),
    "leaf_density_per_m3": ("m-3", "leaves per m^3 of the scene's bounding box (realised)"),
    "mean_leaf_radius_m": ("m", "mean leaf radius in the scene (realised)"),
    "mean_leaf_tilt_deg": (
        "degree",
        "mean |elevation| of the leaf normals (realised; 90 = horizontal leaves)",
    ),
}
