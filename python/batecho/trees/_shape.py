"""The geometry of branches: polylines and their arc lengths, rotations of rows of vectors,
the rotation that carries a branch's chord to a new direction, and bounding boxes of bark and
leaf disks."""

from __future__ import annotations

import math

import numpy as np

from .._geometry import rot_z
from .leaves import Leaves


def unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rodrigues(v: np.ndarray, axis: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Rotate rows ``v`` about unit ``axis`` (one (3,) or one per row) by angles given as their
    cosines and sines (broadcast over rows)."""
    axis = np.broadcast_to(axis, v.shape)
    c = np.asarray(cos)[..., None]
    s = np.asarray(sin)[..., None]
    d = np.einsum("ij,ij->i", axis, v)[:, None]
    return v * c + np.cross(axis, v) * s + axis * d * (1.0 - c)


def transport(chord: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The rotation taking unit ``chord`` to unit ``direction``: turn the azimuth to 0, change
    the polar angle (about the horizontal axis perpendicular to it), turn to the new azimuth.
    Keeps a branch's upper side up (unlike the minimal rotation)."""

    def polar_azimuth(u: np.ndarray) -> tuple[float, float]:
        rho = math.hypot(u[0], u[1])
        polar = math.atan2(rho, u[2])
        az = math.atan2(u[1], u[0]) if rho > 1e-12 else 0.0
        return polar, az

    pc, ac = polar_azimuth(chord)
    pd, ad = polar_azimuth(direction)
    b = pd - pc
    cb, sb = math.cos(b), math.sin(b)
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    return rot_z(math.degrees(ad)) @ ry @ rot_z(-math.degrees(ac))


def arc_lengths(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def dedupe_polyline(points: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-9])
    pts = points[keep]
    if len(pts) < 2:
        raise ValueError("a branch axis needs at least two distinct points")
    return pts


def segment_of(arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(arc) - 2)


def project(points: np.ndarray, axis: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Arc length of the nearest point of the polyline ``axis`` to each of ``points``."""
    a = axis[:-1]
    d = np.diff(axis, axis=0)
    ll = np.einsum("ij,ij->i", d, d)
    best = np.full(len(points), np.inf)
    out = np.zeros(len(points))
    for j in range(len(a)):  # a few dozen segments at most
        t = np.clip((points - a[j]) @ d[j] / ll[j], 0.0, 1.0)
        q = a[j] + t[:, None] * d[j]
        dist = np.einsum("ij,ij->i", points - q, points - q)
        better = dist < best
        best[better] = dist[better]
        out[better] = arc[j] + t[better] * math.sqrt(ll[j])
    return out


def point_at(axis: np.ndarray, arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    j = segment_of(arc, s)
    d = axis[j + 1] - axis[j]
    f = (s - arc[j]) / (arc[j + 1] - arc[j])
    return axis[j] + f[:, None] * d


def bounds(vertices: np.ndarray, leaves: Leaves | None) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = [], []
    if len(vertices):
        lo.append(vertices.min(axis=0))
        hi.append(vertices.max(axis=0))
    if leaves is not None:
        nv = leaves.normals
        ext = leaves.radii[:, None] * np.sqrt(np.clip(1.0 - nv * nv, 0.0, None))
        lo.append((leaves.centers - ext).min(axis=0))
        hi.append((leaves.centers + ext).max(axis=0))
    return np.min(lo, axis=0), np.max(hi, axis=0)
