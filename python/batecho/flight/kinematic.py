"""Kinematic pulse positions: sonar poses placed directly on a circle, a straight run or a
figure eight, with a level sonar (up = +z unless a look-at target tilts the beam), as in the
paper (a 6.2 m circle at 5 m altitude with N = 1, 5, 10 or 15 pulses).

World frame: right-handed, z up, metres; heading modes as in :mod:`batecho.flight._paths`
(``"velocity"``, ``"center"`` / ``"look_at"``, ``"fixed"``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validate import finite_scalar, positive_scalar
from ._paths import TINY, center_xy, count, gerono, heading_mode, level_forward, point
from .poses import Poses

__all__ = ["circle", "figure_eight", "line_to"]


def _kinematic_poses(
    positions: np.ndarray,
    tangents: np.ndarray,
    mode: str,
    target: np.ndarray | None,
    yaw: float | None,
) -> Poses:
    """Level poses (up hint +z) at ``positions`` for a heading mode; look-at is exact in 3-D."""
    if mode == "velocity":
        fwd = tangents.copy()
        fwd[:, 2] = 0.0
        bad = np.hypot(fwd[:, 0], fwd[:, 1]) <= TINY
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"pose {i}: the direction of travel {tangents[i]} has no horizontal "
                "component, so heading='velocity' is undefined; use "
                "heading='fixed' or 'look_at'"
            )
    elif mode == "look_at":
        assert target is not None  # heading_mode gives look_at a target
        fwd = target[None, :] - positions
        bad = np.linalg.norm(fwd, axis=1) <= TINY
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"pose {i}: position {positions[i]} coincides with the look-at target {target}"
            )
    else:
        fwd = level_forward(np.full(len(positions), yaw))
    return Poses(positions, fwd, (0.0, 0.0, 1.0))


# ------------------------------------------------------------------ kinematic pulse positions


def circle(
    center: Any,
    radius: float = 6.2,
    altitude: float = 5.0,
    n_points: int = 15,
    heading: str = "velocity",
    start_angle_deg: float = 0.0,
    target: Any = None,
    yaw_deg: float | None = None,
) -> Poses:
    """``n_points`` pulse poses at equal angles ``360/n_points`` deg on a horizontal circle.

    Point ``k`` is at angle ``start_angle_deg + 360 k / n_points`` (counter-clockwise seen from
    above, from +x) around ``center`` = (x, y) (a z entry is ignored), radius ``radius`` m, at
    z = ``altitude`` m. The paper uses radius 6.2 m, altitude 5 m and N = 1, 5, 10, 15 around
    the mean tree position. ``heading="velocity"`` points the beam along the counter-clockwise
    tangent; ``"center"`` at the centre at flight altitude (or ``target``); ``"fixed"`` along
    yaw ``yaw_deg``.
    """
    c = center_xy(center)
    r = positive_scalar(radius, "radius")
    z = finite_scalar(altitude, "altitude")
    n = count(n_points)
    th = (
        math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        + 2.0 * np.pi * np.arange(n) / n
    )
    cos, sin = np.cos(th), np.sin(th)
    pos = np.stack([c[0] + r * cos, c[1] + r * sin, np.full(n, z)], axis=1)
    tan = np.stack([-sin, cos, np.zeros(n)], axis=1)
    mode, tgt, yaw = heading_mode(heading, target, yaw_deg, np.array([c[0], c[1], z]))
    return _kinematic_poses(pos, tan, mode, tgt, yaw)


def line_to(
    start: Any,
    target: Any,
    n_points: int = 10,
    stop_distance: float = 1.0,
    heading: str = "look_at",
    yaw_deg: float | None = None,
) -> Poses:
    """``n_points`` equally spaced poses on a straight run from ``start`` toward ``target``.

    The run ends ``stop_distance`` m short of ``target`` (the first pose is at ``start``, the
    last at the stop point; one point gives just ``start``). By default (``heading="look_at"``)
    the beam points at ``target`` in 3-D; ``"velocity"`` points it along the horizontal
    direction of the run (the same thing for a level run), ``"fixed"`` along ``yaw_deg``.
    """
    a = point(start, "start")
    b = point(target, "target")
    n = count(n_points)
    d = positive_scalar(stop_distance, "stop_distance", allow_zero=True)
    length = float(np.linalg.norm(b - a))
    if not length > d:
        raise ValueError(
            f"start is {length:.6g} m from the target, not more than stop_distance={d:.6g} m"
        )
    u = (b - a) / length
    s = np.linspace(0.0, length - d, n) if n > 1 else np.zeros(1)
    pos = a[None, :] + s[:, None] * u[None, :]
    mode, tgt, yaw = heading_mode(heading, None, yaw_deg, b)
    return _kinematic_poses(pos, np.repeat(u[None, :], n, axis=0), mode, tgt, yaw)


def figure_eight(
    center: Any,
    radius: float = 3.1,
    altitude: float = 5.0,
    n_points: int = 16,
    heading: str = "velocity",
    start_angle_deg: float = 0.0,
    target: Any = None,
    yaw_deg: float | None = None,
) -> Poses:
    """``n_points`` poses on a horizontal figure eight (lemniscate of Gerono).

    ``x = cx + 2 r sin(th)``, ``y = cy + r sin(2 th)``, ``z = altitude``, sampled at equal
    parameter steps ``th = start_angle_deg + 360 k / n_points`` deg (not equal arc length).
    Each lobe spans ``2r x 2r``, roughly a circle of radius ``r``; the lobes meet at the centre,
    where the right lobe (x > cx) is flown counter-clockwise and the left one clockwise.
    ``heading="center"`` looks at the centre at flight altitude, which is ON the path, so it
    fails for th = 0 or 180 deg; pass another ``target`` instead.
    """
    c = center_xy(center)
    r = positive_scalar(radius, "radius")
    z = finite_scalar(altitude, "altitude")
    n = count(n_points)
    th = (
        math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        + 2.0 * np.pi * np.arange(n) / n
    )
    mode, tgt, yaw = heading_mode(heading, target, yaw_deg, np.array([c[0], c[1], z]))
    return _kinematic_poses(gerono(th, c, r, z), gerono(th, c, r, z, 1), mode, tgt, yaw)
