"""Rigid-body algebra for the vehicle: the hat and vee maps, a 3-vector cross product for the
integration loop, unit vectors with their time derivatives, orthonormalisation, rotations
about the body axes, and per-axis parameters."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validate import finite, readonly, real_array

#: The z axis, world up (and body up).
E3 = np.array([0.0, 0.0, 1.0])


def hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def vee(S: np.ndarray) -> np.ndarray:
    """vee of the antisymmetric part of a (..., 3, 3) matrix."""
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
        axis=-1,
    )


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors (fast path for the integration loop)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1, keepdims=True)


def unit_derivs(
    v: np.ndarray, dv: np.ndarray, ddv: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """u = v/|v| and its first two time derivatives, row-wise."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    u = v / n
    nd = dot(u, dv)
    du = (dv - u * nd) / n
    ndd = dot(du, dv) + dot(u, ddv)
    ddu = (ddv - 2.0 * du * nd - u * ndd) / n
    return u, du, ddu


def orthonormalise(R: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt


def rot(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[j, i] = s
    R[i, j] = -s
    return R


def triple(x: Any, name: str) -> np.ndarray:
    arr = real_array(x, name)
    if arr.ndim == 0:
        arr = np.full(3, float(arr))
    if arr.shape != (3,):
        raise ValueError(f"{name} must be a scalar or a 3-vector, got shape {arr.shape}")
    return readonly(finite(arr, name))
