"""A scene: leaves plus the BVH over their centres (built once in Rust, reused per pose), and
branches as cylinder segments."""

from __future__ import annotations

import math
from typing import Any, Literal, overload

import numpy as np

from .. import _core
from .._resources import check_copies
from .._validate import flag, vectors
from ..trees.branches import Branches
from ..trees.leaves import Leaves, as_leaves

_NO_POINTS = np.zeros((0, 3))
_NO_RADII = np.zeros(0)


class Scene:
    """Leaves and branches ready for echo simulation. Builds the obvhs BVH once (GIL
    released).

    ``Scene(leaves)``, ``Scene(leaves, branches=Branches(...))``, ``Scene(None,
    branches=...)`` (wood alone), or ``Scene.from_arrays(centers, normals, radii)``. Without
    branches, only leaves echo (the paper's model); branches echo as rigid cylinders in
    physical optics (docs/model.md §9).
    """

    __slots__ = ("_branches", "_core", "_leaves")

    def __init__(self, leaves: Any, branches: Branches | None = None):
        if branches is not None and not isinstance(branches, Branches):
            raise TypeError(
                f"branches must be None or batecho.Branches, got {type(branches).__name__}"
            )
        if leaves is None and branches is None:
            raise ValueError("a Scene needs leaves, branches, or both; got neither")
        self._leaves = None if leaves is None else as_leaves(leaves)
        self._branches = branches
        lv, br = self._leaves, branches
        self._core = _core.Scene(
            _NO_POINTS if lv is None else lv.centers,
            _NO_POINTS if lv is None else lv.normals,
            _NO_RADII if lv is None else lv.radii,
            None if br is None else br.starts,
            None if br is None else br.ends,
            None if br is None else br.radii,
        )

    def __reduce__(self) -> tuple[Any, ...]:
        # Pickled as its leaves and branches; the BVHs are built again on loading.
        return (type(self), (self._leaves, self._branches))

    @classmethod
    def from_arrays(cls, centers: Any, normals: Any, radii: Any) -> Scene:
        return cls(Leaves(centers, normals, radii))

    @property
    def leaves(self) -> Leaves | None:
        """The leaves (None in a scene of branches alone)."""
        return self._leaves

    @property
    def branches(self) -> Branches | None:
        """The branch segments (None in a scene of leaves alone)."""
        return self._branches

    @property
    def n_leaves(self) -> int:
        return 0 if self._leaves is None else len(self._leaves)

    @property
    def n_branches(self) -> int:
        return 0 if self._branches is None else len(self._branches)

    def __len__(self) -> int:
        return self.n_leaves

    @overload
    def clearance(self, points: Any, return_index: Literal[False] = False) -> np.ndarray: ...
    @overload
    def clearance(
        self, points: Any, return_index: Literal[True]
    ) -> tuple[np.ndarray, np.ndarray]: ...
    def clearance(self, points: Any, return_index: bool = False) -> Any:
        """Distance (m) from each point to the nearest leaf disk or branch cylinder.

        ``points``: (n, 3) or one (3,) point, m (finite). Returns (n,) float64 distances, the
        exact point-to-disk and point-to-capped-cylinder distances (docs/model.md §6)
        minimised over the leaves and branches on their BVHs, points in parallel (Rust, GIL
        released); with ``return_index=True`` also the (n,) int64 index of that leaf (the
        smallest among equally near leaves), or ``-1 - j`` for branch ``j`` (a leaf first at
        equal distance; :func:`~batecho.forest.clearance.clearance_part` names either). Zero
        for a point on a leaf or in a branch.
        """
        check_copies(points=points)
        return_index = flag(return_index, "return_index")
        pts = vectors(points, "points")
        dist, idx = self._core.clearance(pts)
        return (dist, idx) if return_index else dist

    def min_clearance(self, points: Any, upper_m: float = np.inf) -> float:
        """The smallest distance (m) from any of ``points`` ((n, 3) or (3,), finite) to a leaf
        disk or branch cylinder, or ``upper_m`` (>= 0, may be ``inf``) if none is nearer:
        exactly ``min(upper_m, clearance(points).min())``, found by walking the points in
        turn on the BVHs, each walk skipping what lies beyond the least distance found so far
        (a path's clearance at the cost of a few nearest-leaf queries)."""
        check_copies(points=points)
        pts = vectors(points, "points")
        try:
            upper = float(upper_m)
        except (TypeError, ValueError):
            raise TypeError(f"upper_m must be a number (m), got {upper_m!r}") from None
        if math.isnan(upper) or upper < 0:
            raise ValueError(f"upper_m must be >= 0 (m), got {upper_m!r}")
        if not len(pts):
            return upper
        return float(self._core.min_clearance(pts, upper))

    @property
    def build_time_s(self) -> float:
        """Seconds the BVH build took."""
        return self._core.build_time_s

    def __repr__(self) -> str:
        wood = f", n_branches={self.n_branches}" if self._branches is not None else ""
        return f"Scene(n_leaves={self.n_leaves}{wood}, bvh_nodes={self._core.n_nodes})"


def as_scene(obj: Any) -> Scene:
    """A Scene from a Scene, Leaves, or anything with ``.scene()`` or ``.leaves`` (leaves
    only: a forest's or tree's branches join through ``.scene(branches=True)``)."""
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
