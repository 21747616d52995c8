"""How the sonar sits on the vehicle: its offset and orientation in the body frame, and the
sonar poses of body positions and attitudes."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._pickle import ReadOnlyOnLoading
from .._validate import finite, finite_scalar, readonly, real_array, vectors
from ._so3 import rot
from .poses import Poses

__all__ = ["SonarMount"]


@dataclass(frozen=True, eq=False)
class SonarMount(ReadOnlyOnLoading):
    """How the sonar sits on the body: ``offset`` (3,) m in the body frame, and an orientation
    ``R_mount = Rz(yaw) Ry(-pitch) Rx(roll)`` in the body frame (degrees; ``pitch_deg < 0``
    tilts the beam down, ``yaw_deg > 0`` turns it left). The sonar frame is
    ``R_body R_mount`` with columns (forward, left, up)."""

    offset: Any = (0.0, 0.0, 0.0)
    pitch_deg: float = 0.0
    yaw_deg: float = 0.0
    roll_deg: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "offset", readonly(vectors(self.offset, "offset")[0]))
        for name in ("pitch_deg", "yaw_deg", "roll_deg"):
            object.__setattr__(self, name, finite_scalar(getattr(self, name), name))

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) body-frame rotation of the sonar frame."""
        return (
            rot(2, math.radians(self.yaw_deg))
            @ rot(1, -math.radians(self.pitch_deg))
            @ rot(0, math.radians(self.roll_deg))
        )

    def pose(self, position: Any, R_body: Any) -> Poses:
        """Sonar poses for body positions (p, 3) or (3,) m and rotations (p, 3, 3) or (3, 3)."""
        pos = vectors(position, "position")
        R = finite(real_array(R_body, "R_body"), "R_body")
        if R.ndim == 2:
            R = R[None]
        if R.shape != (len(pos), 3, 3):
            raise ValueError(f"R_body must have shape ({len(pos)}, 3, 3), got {R.shape}")
        return Poses.from_rotations(pos + R @ self.offset, R @ self.rotation)
