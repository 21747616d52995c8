"""The geometric SE(3) tracking controller of Lee, Leok & McClamroch (2010), "Geometric
tracking control of a quadrotor UAV on SE(3)", IEEE CDC, rewritten for z up: its gains, the
reference states by differential flatness, the desired attitude, and the control law.

Its feed-forward angular velocity and acceleration come from the reference by differential
flatness (jerk, snap, yaw rate and yaw acceleration), and the known body drag at the reference
velocity is fed forward too (``drag_feedforward``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._geometry import crosses
from .._validate import positive_scalar
from ._so3 import E3, cross3, triple, unit_derivs, vee
from .trajectories import Trajectory

__all__ = ["SE3Gains", "desired_attitude", "flat_reference", "se3_control"]


@dataclass(frozen=True, eq=False)
class SE3Gains:
    """Gains of the geometric controller: position ``k_x`` (N/m), velocity ``k_v`` (N s/m),
    attitude ``k_R`` (N m/rad) and angular rate ``k_Omega`` (N m s/rad), each a scalar or a
    per-axis 3-vector (world axes for k_x, k_v; body axes for k_R, k_Omega)."""

    k_x: Any
    k_v: Any
    k_R: Any
    k_Omega: Any

    def __post_init__(self):
        for name in ("k_x", "k_v", "k_R", "k_Omega"):
            v = triple(getattr(self, name), name)
            if not (v > 0).all():
                raise ValueError(f"{name} must be > 0, got {v}")
            object.__setattr__(self, name, v)

    @classmethod
    def from_bandwidth(
        cls,
        mass: float,
        inertia: Any,
        position_rad_s: float,
        attitude_rad_s: float,
        position_damping: float = 1.0,
        attitude_damping: float = 0.9,
    ) -> SE3Gains:
        """Gains placing the linearised position and attitude loops at natural frequencies
        ``position_rad_s`` and ``attitude_rad_s`` (rad/s) with the given damping ratios:
        ``k_x = m wp^2``, ``k_v = 2 zp m wp``, ``k_R = J wa^2``, ``k_Omega = 2 za J wa``."""
        m = positive_scalar(mass, "mass")
        J = triple(inertia, "inertia")
        wp = positive_scalar(position_rad_s, "position_rad_s")
        wa = positive_scalar(attitude_rad_s, "attitude_rad_s")
        zp = positive_scalar(position_damping, "position_damping")
        za = positive_scalar(attitude_damping, "attitude_damping")
        return cls(m * wp * wp, 2.0 * zp * m * wp, J * wa * wa, 2.0 * za * J * wa)


def flat_reference(traj: Trajectory, t: np.ndarray, g: float) -> dict[str, np.ndarray]:
    """Reference states by differential flatness at times ``t`` (n,): position, velocity,
    acceleration, yaw, nominal attitude R_ref, its body angular velocity and acceleration,
    and the nominal specific thrust |a + g e3| (m/s^2)."""
    p, v, a, j, s = (traj._derivative(t, k) for k in range(5))
    psi, dpsi, ddpsi = (np.atleast_1d(x) for x in traj.yaw_derivatives(t))
    F = a + g * E3
    b3, db3, ddb3 = unit_derivs(F, j, s)
    c, sn, z = np.cos(psi), np.sin(psi), np.zeros_like(psi)
    b1d = np.stack([c, sn, z], axis=-1)
    perp = np.stack([-sn, c, z], axis=-1)
    db1d = dpsi[:, None] * perp
    ddb1d = ddpsi[:, None] * perp - (dpsi * dpsi)[:, None] * b1d
    w = crosses(b3, b1d)
    dw = crosses(db3, b1d) + crosses(b3, db1d)
    ddw = crosses(ddb3, b1d) + 2.0 * crosses(db3, db1d) + crosses(b3, ddb1d)
    b2, db2, ddb2 = unit_derivs(w, dw, ddw)
    b1 = crosses(b2, b3)
    db1 = crosses(db2, b3) + crosses(b2, db3)
    ddb1 = crosses(ddb2, b3) + 2.0 * crosses(db2, db3) + crosses(b2, ddb3)
    R = np.stack([b1, b2, b3], axis=-1)
    dR = np.stack([db1, db2, db3], axis=-1)
    ddR = np.stack([ddb1, ddb2, ddb3], axis=-1)
    Rt = np.swapaxes(R, -1, -2)
    W = Rt @ dR
    Om = vee(W)
    dOm = vee(Rt @ ddR - W @ W)
    return {
        "p": p,
        "v": v,
        "a": a,
        "yaw": psi,
        "R": R,
        "Omega": Om,
        "dOmega": dOm,
        "thrust": np.linalg.norm(F, axis=-1),
    }


def desired_attitude(F: np.ndarray, psi: float) -> np.ndarray:
    """Lee et al.'s R_d: b3 along the thrust vector F, b1 the projection of the heading
    (cos psi, sin psi, 0) onto the plane normal to b3."""
    n = float(np.linalg.norm(F))
    b3 = F / n if n > 1e-12 else E3
    b2 = cross3(b3, np.array([math.cos(psi), math.sin(psi), 0.0]))
    b2 /= np.linalg.norm(b2)
    return np.column_stack([cross3(b2, b3), b2, b3])


def se3_control(
    gains: SE3Gains,
    mass: float,
    gravity: float,
    inertia: np.ndarray,
    drag: np.ndarray,
    drag_feedforward: bool,
    y: np.ndarray,
    ref: dict[str, np.ndarray],
    k: int,
) -> tuple[float, np.ndarray]:
    """Lee et al. (2010) SE(3) control of state ``y`` (the 22-vector of
    :meth:`~batecho.flight.vehicle.QuadState.vector`) at reference sample ``k``: the total
    thrust (N) and the body moments (N m)."""
    gn = gains
    R = y[6:15].reshape(3, 3)
    Om = y[15:18]
    J = inertia
    ex = y[0:3] - ref["p"][k]
    ev = y[3:6] - ref["v"][k]
    F = -gn.k_x * ex - gn.k_v * ev + mass * (ref["a"][k] + gravity * E3)
    if drag_feedforward:
        F = F + R @ (drag * (ref["v"][k] @ R))
    f = float(F @ R[:, 2])
    Rd = desired_attitude(F, ref["yaw"][k])
    RtRd = R.T @ Rd
    eR = 0.5 * vee(RtRd.T - RtRd)
    Omd = RtRd @ ref["Omega"][k]
    eOm = Om - Omd
    M = (
        -gn.k_R * eR
        - gn.k_Omega * eOm
        + cross3(Om, J * Om)
        - J * (cross3(Om, Omd) - RtRd @ ref["dOmega"][k])
    )
    return f, M
