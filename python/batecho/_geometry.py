"""Row-wise vector algebra in the Rust core's order of operations, and turns about the
vertical."""

from __future__ import annotations

import math

import numpy as np


def norms(v: np.ndarray) -> np.ndarray:
    """Row norms ``sqrt(x^2 + y^2 + z^2)``, summed in that order (the Rust core does the same)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row dot products ``ax bx + ay by + az bz`` in that order (no BLAS, no FMA)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def crosses(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row cross products, component by component as in the Rust core."""
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def rot_z(angle_deg: float) -> np.ndarray:
    """(3, 3) rotation by ``angle_deg`` degrees about +z (counter-clockwise seen from above)."""
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
