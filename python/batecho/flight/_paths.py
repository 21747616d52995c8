"""What the pulse paths and trajectories share: heading modes, the checks of centres,
points and counts, and the lemniscate of Gerono.

World frame: right-handed, z up, metres; yaw ``psi`` is the angle of the horizontal heading from
+x toward +y (radians inside, degrees only in names ending ``_deg``). Heading modes:
``"velocity"`` points the beam along the horizontal direction of travel; ``"center"`` /
``"look_at"`` at a point (``target``); ``"fixed"`` at a constant yaw ``yaw_deg``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._resources import BYTES_PER_POSE, check_memory
from .._validate import finite, finite_scalar, integer, real_array, vectors

HEADINGS = {
    "velocity": "velocity",
    "center": "look_at",
    "centre": "look_at",
    "look_at": "look_at",
    "fixed": "fixed",
}
TINY = 1e-12


def center_xy(center: Any) -> np.ndarray:
    c = real_array(center, "center").ravel()
    if c.shape not in ((2,), (3,)):
        raise ValueError(f"center must be an (x, y) or (x, y, z) vector, got shape {c.shape}")
    finite(c, "center")
    return c[:2].copy()


def point(p: Any, name: str) -> np.ndarray:
    return vectors(p, name)[0]


def count(n: Any, name: str = "n_points") -> int:
    """A number of poses: an integer >= 1 whose poses fit in memory."""
    k = integer(n, name, 1, wrong_type=TypeError)
    check_memory(k * BYTES_PER_POSE, f"{name} = {k} poses", f"ask for fewer {name}")
    return k


def heading_mode(
    heading: str, target: Any, yaw_deg: Any, default_target: np.ndarray | None
) -> tuple[str, np.ndarray | None, float | None]:
    """Normalised (mode, target (3,) or None, yaw in radians or None)."""
    if not isinstance(heading, str) or heading.lower() not in HEADINGS:
        raise ValueError(f"heading must be one of {sorted(HEADINGS)}, got {heading!r}")
    mode = HEADINGS[heading.lower()]
    if mode != "look_at" and target is not None:
        raise ValueError(f"target is only used with heading='look_at'/'center', not {heading!r}")
    if mode != "fixed" and yaw_deg is not None:
        raise ValueError(f"yaw_deg is only used with heading='fixed', not {heading!r}")
    if mode == "look_at":
        tgt = default_target if target is None else point(target, "target")
        if tgt is None:
            raise ValueError("heading='look_at' needs a target=(x, y, z)")
        return mode, np.asarray(tgt, dtype=np.float64), None
    if mode == "fixed":
        if yaw_deg is None:
            raise ValueError("heading='fixed' needs yaw_deg (degrees from +x toward +y)")
        return mode, None, math.radians(finite_scalar(yaw_deg, "yaw_deg"))
    return mode, None, None


def level_forward(yaw: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], axis=-1)


def gerono(theta: np.ndarray, c: np.ndarray, r: float, z: float, order: int = 0) -> np.ndarray:
    """``order``-th theta-derivative of the Gerono lemniscate x = 2r sin th, y = r sin 2th."""
    ph = order * np.pi / 2
    x = 2.0 * r * np.sin(theta + ph) + (c[0] if order == 0 else 0.0)
    y = r * 2.0**order * np.sin(2.0 * theta + ph) + (c[1] if order == 0 else 0.0)
    zz = np.full_like(theta, z if order == 0 else 0.0)
    return np.stack([x, y, zz], axis=-1)
