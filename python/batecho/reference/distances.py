"""The reference's clearance (docs/model.md §6): the distance from points to leaf disks and
branch cylinders, in the Rust core's order of operations, and the nearest of them by testing
every one.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._geometry import dots
from .parts import _parts


def point_disk_distance(
    p: np.ndarray, c: np.ndarray, n: np.ndarray, a: np.ndarray | float
) -> np.ndarray:
    """Distance from points ``p`` to disks (centre ``c``, unit normal ``n``, radius ``a``),
    broadcast row by row (``(..., 3)`` arrays).

    ``d = p - c``, height ``h = d . n``, in-plane part ``q = d - h n`` of length ``rho``: the
    nearest disk point is ``c + q`` if ``rho <= a`` (distance ``|h|``), else the rim point
    ``c + a q / rho`` (distance ``sqrt(h^2 + (rho - a)^2)``). Written in the Rust core's order
    of operations (no FMA), so both give the same bits.
    """
    d = p - c
    h = d[..., 0] * n[..., 0] + d[..., 1] * n[..., 1] + d[..., 2] * n[..., 2]
    q = d - h[..., None] * n
    rho = np.sqrt(q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    t = rho - a
    return np.where(rho <= a, np.abs(h), np.sqrt(h * h + t * t))


def point_cylinder_distance(
    p: np.ndarray, a: np.ndarray, u: np.ndarray, length: np.ndarray | float, r: np.ndarray | float
) -> np.ndarray:
    """Distance from points ``p`` to solid capped cylinders (axis from ``a`` along the unit
    ``u`` for ``length``, radius ``r``; 0 inside), broadcast row by row.

    ``d = p - a``, axial ``s = d . u``, distance from the axis ``rho = |d - s u|``; the axial
    excess ``e = max(-s, s - length, 0)`` and radial ``t = max(rho - r, 0)`` give
    ``sqrt(e^2 + t^2)``. Written in the Rust core's order of operations."""
    d = p - a
    s = d[..., 0] * u[..., 0] + d[..., 1] * u[..., 1] + d[..., 2] * u[..., 2]
    q = d - s[..., None] * u
    rho = np.sqrt(q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    e = np.maximum(np.maximum(-s, s - length), 0.0)
    t = np.maximum(rho - r, 0.0)
    return np.sqrt(e * e + t * t)


def _nearest(dist_fn, n: int, pts: np.ndarray, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the least of ``dist_fn(points (m,1,3)) -> (m, n)`` and its first index."""
    dist = np.full(len(pts), np.inf)
    index = np.zeros(len(pts), dtype=np.int64)
    step = max(1, chunk // max(n, 1))
    for s in range(0, len(pts), step):
        d = dist_fn(pts[s : s + step, None, :])
        k = np.argmin(d, axis=1)  # the first of equal minima: the smallest index
        dist[s : s + step] = d[np.arange(len(k)), k]
        index[s : s + step] = k
    return dist, index


def clearance(scene: Any, points: Any, chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Per point (n, 3), the distance (m) to the nearest leaf disk or branch cylinder of
    ``scene`` and its index: the leaf's (the smallest among equally near leaves), or
    ``-1 - j`` for branch ``j`` (a leaf first at equal distance), by testing every one."""
    leaves, branches = _parts(scene)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    dist = np.full(len(pts), np.inf)
    index = np.zeros(len(pts), dtype=np.int64)
    if leaves is not None:
        c, nv, a = leaves.centers, leaves.normals, leaves.radii
        dist, index = _nearest(
            lambda q: point_disk_distance(q, c[None], nv[None], a[None]), len(c), pts, chunk
        )
    if branches is not None:
        st = branches.starts
        d = branches.ends - st
        length = np.sqrt(dots(d, d))
        u = d / length[:, None]
        r = branches.radii
        wd, wi = _nearest(
            lambda q: point_cylinder_distance(q, st[None], u[None], length[None], r[None]),
            len(r),
            pts,
            chunk,
        )
        wood = wd < dist
        dist = np.where(wood, wd, dist)
        index = np.where(wood, -1 - wi, index)
    return dist, index
