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
from .._validate import finite_scalar, vectors

__all__ = [
    "DEFAULT_MIN_CLEARANCE_M",
    "ClearanceWarning",
    "SolidClearance",
    "bark_clearance",
    "check_margin",
    "low_clearance",
    "point_triangle_distances",
    "solid_clearance",
]

#: The margin (m) a pulse position keeps from every leaf (and bark, in scene files) unless
#: told otherwise: the span of a 450-class quadrotor (0.45 m across the rotors) with a little
#: tracking error, and about where the far-field leaf model starts to hold (the Fraunhofer
#: distance ``8 a^2 / lambda`` of a 2 cm leaf at 80 kHz is 0.75 m).
DEFAULT_MIN_CLEARANCE_M = 0.5

#: Points whose nearby triangles are gathered together in :func:`bark_clearance`.
_CHUNK = 16


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
    """Distances from the point ``p`` (3,) to the segments ``a b`` (m, 3)."""
    ab = b - a
    ll = dots(ab, ab)
    t = np.divide(dots(p - a, ab), ll, out=np.zeros_like(ll), where=ll > 0)
    t = np.clip(t, 0.0, 1.0)
    e = p - (a + t[:, None] * ab)
    return np.sqrt(dots(e, e))


def point_triangle_distances(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Distances (m) from the point ``p`` (3,) to the triangles ``tri`` (m, 3, 3).

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
        inside &= dots(crosses(v - u, p - u), n) >= 0
    plane = np.abs(dots(p - a, n)) / np.sqrt(np.where(nn > 0, nn, 1.0))
    edges = np.minimum(
        np.minimum(_segment_distances(p, a, b), _segment_distances(p, b, c)),
        _segment_distances(p, c, a),
    )
    return np.where(inside, plane, edges)


def bark_clearance(
    vertices: Any, faces: Any, points: Any, upper: Any = None
) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the distance (m) to the nearest bark triangle and its index (-1 if none
    within ``upper``).

    ``upper`` (n,) m, optional: only triangles nearer than this count (their boxes are tested
    first), e.g. the nearest leaf's distance; a point with none gets ``inf``.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    pts = vectors(points, "points")
    n = len(pts)
    up = np.full(n, np.inf) if upper is None else np.asarray(upper, dtype=np.float64)
    dist = np.full(n, np.inf)
    index = np.full(n, -1, dtype=np.int64)
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


@dataclass(frozen=True)
class SolidClearance:
    """Distances (m) from each point to the nearest leaf (``leaf``, index ``leaf_index``) and
    to the nearest bark triangle (``bark``, ``inf`` without bark or when a leaf is nearer)."""

    leaf: np.ndarray
    leaf_index: np.ndarray
    bark: np.ndarray

    @property
    def distance(self) -> np.ndarray:
        """(n,) the nearer of the two, m."""
        return np.minimum(self.leaf, self.bark)

    def part(self, i: int) -> str:
        """What point ``i`` is nearest to: ``"leaf <index>"`` or ``"bark"``."""
        if self.bark[i] < self.leaf[i]:
            return "bark"
        return f"leaf {int(self.leaf_index[i])}"


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
    if arrays is None:
        barkd = np.full(len(pts), np.inf)
    else:
        barkd = bark_clearance(arrays[0], arrays[1], pts, upper=leaf)[0]
    return SolidClearance(leaf, idx, barkd)
