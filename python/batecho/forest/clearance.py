"""Clearance: how far pulse positions stay from a scene's solid parts, and the margin flights
keep (docs/model.md §6).

Leaves are disks; their distances come from the Rust core on the scene's BVH
(:meth:`batecho.Scene.clearance`, held to :func:`batecho.reference.clearance`). Bark is a
triangle mesh; its distances are computed here in NumPy, each point against the triangles
whose bounding boxes come nearer than the nearest leaf.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._geometry import crosses, dots
from .._resources import check_memory
from .._validate import finite_scalar, vectors

__all__ = [
    "DEFAULT_MIN_CLEARANCE_M",
    "BarkGrid",
    "ClearanceWarning",
    "SolidClearance",
    "bark_clearance",
    "check_margin",
    "clearance_part",
    "low_clearance",
    "point_triangle_distances",
    "solid_clearance",
]

#: The margin (m) a pulse position keeps from every leaf (and bark, in scene files) unless
#: told otherwise: the span of a 450-class quadrotor (0.45 m across the rotors) with a little
#: tracking error, and about where the far-field leaf model starts to hold (the Fraunhofer
#: distance ``8 a^2 / lambda`` of a 2 cm leaf at 80 kHz is 0.75 m).
DEFAULT_MIN_CLEARANCE_M = 0.5
#: Memory of a :class:`BarkGrid` per triangle filed in a cell, and per cell (bytes): the
#: filing's index arrays and the boxes kept beside each item; the cells' slice starts.
BYTES_PER_FILED = 128.0
BYTES_PER_CELL = 16.0

#: Points whose nearby triangles are gathered together in :func:`bark_clearance`.
_CHUNK = 16
#: Point-triangle pairs computed together by :meth:`BarkGrid.set_clearance`.
_PAIRS = 4096


class ClearanceWarning(UserWarning):
    """A pulse position is closer to a leaf (or bark) than the margin ``min_clearance_m``: the
    drone would fly through foliage, and that leaf's echo (``1/r^2``) dwarfs the rest."""


def check_margin(min_clearance_m: Any) -> float:
    """``min_clearance_m`` as a float >= 0 (0 switches the check off)."""
    m = finite_scalar(min_clearance_m, "min_clearance_m")
    if m < 0:
        raise ValueError(f"min_clearance_m must be >= 0 (0: no check), got {m}")
    return m


def _segment_distances(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances from the point ``p`` (3,) to the segments ``a b`` (m, 3); points (k, 1, 3)
    give (k, m)."""
    ab = b - a
    ll = dots(ab, ab)
    along = dots(p - a, ab)
    t = np.divide(along, ll, out=np.zeros_like(along), where=ll > 0)
    t = np.clip(t, 0.0, 1.0)
    e = p - (a + t[..., None] * ab)
    return np.sqrt(dots(e, e))


def point_triangle_distances(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distances (m) from the point ``p`` (3,) to the triangles ``tri`` (m, 3, 3); points
    (k, 1, 3) give (k, m), each row what its point alone gives.

    The distance to the triangle's plane where ``p`` projects inside the triangle (the three
    edge tests ``((v_{k+1} - v_k) x (p - v_k)) . n >= 0`` with ``n = (b - a) x (c - a)``),
    else the distance to the nearest of its three edges; a degenerate triangle (``n = 0``) is
    its edges.
    """
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = crosses(b - a, c - a)
    nn = dots(n, n)
    inside = nn > 0
    for u, v in ((a, b), (b, c), (c, a)):
        inside = inside & (dots(crosses(v - u, p - u), n) >= 0)
    plane = np.abs(dots(p - a, n)) / np.sqrt(np.where(nn > 0, nn, 1.0))
    edges = np.minimum(
        np.minimum(_segment_distances(p, a, b), _segment_distances(p, b, c)),
        _segment_distances(p, c, a),
    )
    return np.where(inside, plane, edges)


class BarkGrid:
    """Bark triangles filed by the horizontal grid cells (``cell_m`` square) their bounding
    boxes overlap, so that a point's nearest triangle is found among the few near it: every
    triangle within ``r`` of a point has its box within ``r`` of it, hence in a cell that the
    square ``p +- r`` overlaps (:meth:`nearest` widens ``r`` until the nearest is inside)."""

    def __init__(self, vertices: Any, faces: Any, cell_m: float = 0.5):
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
        self.tri = v[f] if len(f) else np.zeros((0, 3, 3))
        self.lo, self.hi = self.tri.min(axis=1), self.tri.max(axis=1)
        self.cell_m = float(cell_m)
        if not len(f):
            self.origin, self.shape = np.zeros(2), (0, 0)
            self.items, self.starts = np.zeros(0, np.int64), np.zeros(1, np.int64)
            self.items_lo = self.items_hi = np.zeros((0, 3))
            return
        self.origin = self.lo[:, :2].min(axis=0)
        i0 = np.floor((self.lo[:, :2] - self.origin) / cell_m).astype(np.int64)
        i1 = np.floor((self.hi[:, :2] - self.origin) / cell_m).astype(np.int64)
        nx, ny = int(i1[:, 0].max()) + 1, int(i1[:, 1].max()) + 1
        self.shape = (nx, ny)
        wx, wy = i1[:, 0] - i0[:, 0] + 1, i1[:, 1] - i0[:, 1] + 1
        filed = float(np.sum(wx.astype(np.float64) * wy))
        check_memory(
            filed * BYTES_PER_FILED + float(nx) * ny * BYTES_PER_CELL,
            f"a bark grid of {nx} x {ny} cells of {cell_m:g} m with {filed:.3g} triangle entries "
            f"(bark spanning {nx * cell_m:.3g} m x {ny * cell_m:.3g} m)",
            "use bark of ordinary size (a huge triangle, such as a ground plane, fills every "
            "cell it covers)",
        )
        counts = wx * wy
        owner = np.repeat(np.arange(len(f)), counts)
        k = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
        cx = i0[owner, 0] + k % wx[owner]
        cy = i0[owner, 1] + k // wx[owner]
        cell = cx * ny + cy
        order = np.argsort(cell, kind="stable")
        self.items = owner[order]
        self.starts = np.searchsorted(cell[order], np.arange(nx * ny + 1))
        # each filed item's box beside it, so that a search reads whole slices in cell order
        self.items_lo, self.items_hi = self.lo[self.items], self.hi[self.items]

    def __len__(self) -> int:
        return len(self.tri)

    def _filed(self, lo: np.ndarray, hi: np.ndarray) -> list[slice]:
        """The slices of the filed items (``items``, ``items_lo``, ``items_hi``) of the cells the
        box ``lo``..``hi`` (x, y) overlaps, one per column of cells (a triangle filed in several
        of them comes more than once)."""
        nx, ny = self.shape
        a = np.floor((np.asarray(lo[:2]) - self.origin) / self.cell_m).astype(np.int64)
        b = np.floor((np.asarray(hi[:2]) - self.origin) / self.cell_m).astype(np.int64)
        x0, y0 = max(int(a[0]), 0), max(int(a[1]), 0)
        x1, y1 = min(int(b[0]), nx - 1), min(int(b[1]), ny - 1)
        if x0 > x1 or y0 > y1:
            return []
        return [
            slice(int(self.starts[x * ny + y0]), int(self.starts[x * ny + y1 + 1]))
            for x in range(x0, x1 + 1)
        ]

    def candidates(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Indices of the triangles filed in the cells the box ``lo``..``hi`` (x, y) overlaps."""
        parts = [self.items[s] for s in self._filed(lo, hi)]
        return _distinct(np.concatenate(parts) if parts else np.zeros(0, np.int64))

    def nearest(self, p: np.ndarray, upper: float) -> tuple[float, int]:
        """The distance (m) from ``p`` (3,) to the nearest triangle and its index, or
        ``(inf, -1)`` if none is within ``upper``."""
        if not len(self.tri):
            return np.inf, -1
        r = self.cell_m
        while True:
            reach = min(r, upper)
            cand = self.candidates(p - reach, p + reach)
            gap = np.maximum(np.maximum(self.lo[cand] - p, p - self.hi[cand]), 0.0)
            near = cand[dots(gap, gap) <= reach * reach]
            if near.size:
                d = point_triangle_distances(p, self.tri[near])
                k = int(np.argmin(d))
                if d[k] <= reach:
                    return float(d[k]), int(near[k])
            if reach >= upper:
                return np.inf, -1
            r *= 2.0

    def set_clearance(self, points: np.ndarray, upper: float) -> float:
        """The distance (m) from the nearest of ``points`` (n, 3) to the nearest triangle, or
        ``inf`` if none is within ``upper`` (finite): the triangles searched are those whose
        boxes come within ``upper`` of the points' box."""
        if not len(self.tri) or not len(points):
            return np.inf
        a, b = points.min(axis=0), points.max(axis=0)
        cols = self._filed(a - upper, b + upper)
        if not cols:
            return np.inf
        lo = np.concatenate([self.items_lo[s] for s in cols])
        hi = np.concatenate([self.items_hi[s] for s in cols])
        gap = np.maximum(np.maximum(lo - b, a - hi), 0.0)
        within = dots(gap, gap) <= upper * upper
        if not within.any():
            return np.inf
        near = _distinct(np.concatenate([self.items[s] for s in cols])[within])
        # points in blocks against every near triangle at once (blocks of about _PAIRS pairs
        # stay in cache); the operations of each pair are those of point_triangle_distances
        tri = self.tri[near]
        step = max(1, _PAIRS // len(tri))
        best = min(
            float(point_triangle_distances(points[i : i + step, None, :], tri).min())
            for i in range(0, len(points), step)
        )
        return best if best <= upper else np.inf


def _distinct(indices: np.ndarray) -> np.ndarray:
    """The distinct values of ``indices`` (1-d), ascending: as numpy.unique gives them, by
    sorting, which is ten times faster than its hashing at the sizes of a grid search."""
    s = np.sort(indices)
    keep = np.empty(len(s), dtype=bool)
    keep[:1] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def bark_clearance(
    vertices: Any, faces: Any, points: Any, upper: Any = None, grid: BarkGrid | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the distance (m) to the nearest bark triangle and its index (-1 if none
    within ``upper``).

    ``upper`` (n,) m, optional: only triangles nearer than this count (their boxes are tested
    first), e.g. the nearest leaf's distance; a point with none gets ``inf``. ``grid``: the
    :class:`BarkGrid` of these triangles, if built already (then ``vertices`` and ``faces``
    are not read): each point searches only the cells near it.
    """
    pts = vectors(points, "points")
    n = len(pts)
    up = np.full(n, np.inf) if upper is None else np.asarray(upper, dtype=np.float64)
    dist = np.full(n, np.inf)
    index = np.full(n, -1, dtype=np.int64)
    if grid is not None:
        for i in range(n):
            dist[i], index[i] = grid.nearest(pts[i], float(up[i]))
        return dist, index
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return dist, index
    tri = v[f]
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    for start in range(0, n, _CHUNK):
        # the triangles near a chunk of points (its box widened by its largest bound) first
        sel = slice(start, start + _CHUNK)
        reach = float(up[sel].max())
        clo, chi = pts[sel].min(axis=0) - reach, pts[sel].max(axis=0) + reach
        cand = np.flatnonzero(np.all((hi >= clo) & (lo <= chi), axis=1))
        for i in range(start, min(start + _CHUNK, n)):
            p = pts[i]
            gap = np.maximum(np.maximum(lo[cand] - p, p - hi[cand]), 0.0)
            near = cand[dots(gap, gap) <= up[i] * up[i]]
            if near.size:
                d = point_triangle_distances(p, tri[near])
                k = int(np.argmin(d))
                if d[k] <= up[i]:
                    dist[i], index[i] = d[k], near[k]
    return dist, index


def clearance_part(index: Any) -> str:
    """``"leaf i"`` or ``"branch j"`` for an index from :meth:`Scene.clearance` (``-1 - j``
    for branch ``j``)."""
    i = int(index)
    return f"leaf {i}" if i >= 0 else f"branch {-1 - i}"


@dataclass(frozen=True)
class SolidClearance:
    """Distances (m) from each point to the nearest leaf or branch (``leaf``, index
    ``leaf_index``, ``-1 - j`` for branch ``j``) and to the nearest bark triangle (``bark``,
    ``inf`` without bark or when a leaf or branch is nearer)."""

    leaf: np.ndarray
    leaf_index: np.ndarray
    bark: np.ndarray

    @property
    def distance(self) -> np.ndarray:
        """(n,) the nearer of the two, m."""
        return np.minimum(self.leaf, self.bark)

    def part(self, i: int) -> str:
        """What point ``i`` is nearest to: ``"leaf <index>"``, ``"branch <index>"`` or
        ``"bark"``."""
        if self.bark[i] < self.leaf[i]:
            return "bark"
        return clearance_part(self.leaf_index[i])


def low_clearance(
    distance: np.ndarray,
    part: Any,
    positions: np.ndarray,
    margin: float,
    noun: str = "pose",
) -> str | None:
    """A message naming the nearest of the points closer than ``margin`` to the scene (its
    index, position, distance and ``part(i)``, what it is nearest to) and how many are; None
    if every point keeps the margin."""
    close = np.flatnonzero(distance < margin)
    if not close.size:
        return None
    i = int(close[np.argmin(distance[close])])
    x, y, z = (float(v) for v in positions[i])
    return (
        f"{noun} {i} at ({x:.2f}, {y:.2f}, {z:.2f}) m is {float(distance[i]):.3g} m from "
        f"{part(i)}, closer than min_clearance_m = {margin:g} m ({close.size} of "
        f"{len(distance)} {noun}s are): the drone would fly through the foliage, and the "
        "nearest echoes (1/r^2) would dwarf the rest"
    )


def _bark_arrays(obj: Any) -> tuple[np.ndarray, np.ndarray] | None:
    if callable(getattr(obj, "bark", None)):  # a Forest
        v, f = obj.bark()[:2]
        return v, f
    v, f = getattr(obj, "bark_vertices", None), getattr(obj, "bark_faces", None)
    if v is None or f is None or not len(f):
        return None
    return np.asarray(v, dtype=np.float64), np.asarray(f, dtype=np.int64)


def solid_clearance(
    obj: Any, points: Any, *, bark: bool = True, scene: Any = None
) -> SolidClearance:
    """The clearance of ``points`` (n, 3) from the leaves of ``obj`` (a Scene, Leaves, Tree,
    Forest or Mesh) and, with ``bark``, from its bark where it has one. ``scene``: the
    :class:`~batecho.Scene` of ``obj``'s leaves, if built already."""
    from .scene import as_scene

    pts = vectors(points, "points")
    leaf, idx = as_scene(obj if scene is None else scene).clearance(pts, return_index=True)
    arrays = _bark_arrays(obj) if bark else None
    grid = getattr(obj, "bark_grid", None) if bark else None
    if callable(grid):  # a Forest keeps its bark filed by cells
        barkd = bark_clearance(None, None, pts, upper=leaf, grid=grid())[0]
    elif arrays is None:
        barkd = np.full(len(pts), np.inf)
    else:
        barkd = bark_clearance(arrays[0], arrays[1], pts, upper=leaf)[0]
    return SolidClearance(leaf, idx, barkd)
