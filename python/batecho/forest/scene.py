"""A scene: leaves plus the BVH over their centres (built once in Rust, reused per pose)."""

from __future__ import annotations

from typing import Any, Literal, overload

import numpy as np

from .. import _core
from .._validate import vectors
from ..trees.leaves import Leaves, as_leaves


class Scene:
    """Leaves ready for echo simulation. Builds the obvhs BVH once (GIL released).

    ``Scene(leaves)`` or ``Scene.from_arrays(centers, normals, radii)``.
    """

    __slots__ = ("_core", "_leaves")

    def __init__(self, leaves: Any):
        self._leaves = as_leaves(leaves)
        lv = self._leaves
        self._core = _core.Scene(lv.centers, lv.normals, lv.radii)

    @classmethod
    def from_arrays(cls, centers: Any, normals: Any, radii: Any) -> Scene:
        return cls(Leaves(centers, normals, radii))

    @property
    def leaves(self) -> Leaves:
        return self._leaves

    @property
    def n_leaves(self) -> int:
        return len(self._leaves)

    def __len__(self) -> int:
        return len(self._leaves)

    @overload
    def clearance(self, points: Any, return_index: Literal[False] = False) -> np.ndarray: ...
    @overload
    def clearance(
        self, points: Any, return_index: Literal[True]
    ) -> tuple[np.ndarray, np.ndarray]: ...
    def clearance(self, points: Any, return_index: bool = False) -> Any:
        """Distance (m) from each point to the nearest leaf disk.

        ``points``: (n, 3) or one (3,) point, m (finite). Returns (n,) float64 distances, the
        exact point-to-disk distance (docs/model.md §6) minimised over the leaves on the BVH,
        points in parallel (Rust, GIL released); with ``return_index=True`` also the (n,)
        int64 index of that leaf (the smallest among equally near leaves). Zero for a point on
        a leaf.
        """
        pts = vectors(points, "points")
        dist, idx = self._core.clearance(pts)
        return (dist, idx) if return_index else dist

    @property
    def build_time_s(self) -> float:
        """Seconds the BVH build took."""
        return self._core.build_time_s

    def __repr__(self) -> str:
        return f"Scene(n_leaves={self.n_leaves}, bvh_nodes={self._core.n_nodes})"


def as_scene(obj: Any) -> Scene:
    """A Scene from a Scene, Leaves, or anything with ``.scene()`` or ``.leaves``."""
    if isinstance(obj, Scene):
        return obj
    if isinstance(obj, Leaves):
        return Scene(obj)
    make = getattr(obj, "scene", None)
    if callable(make):
        sc = make()
        if isinstance(sc, Scene):
            return sc
    return Scene(as_leaves(obj))


__all__ = ["Scene", "as_scene"]
