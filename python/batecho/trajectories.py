"""Where the sonar pulses from: kinematic pulse positions and timed reference trajectories.

World frame: right-handed, z up, metres, seconds; yaw ``psi`` is the angle of the horizontal
heading from +x toward +y (radians inside, degrees only in names ending ``_deg``).

Two layers:

* kinematic pulse positions (:func:`circle`, :func:`line_to`, :func:`figure_eight`) return
  :class:`~batecho.Poses` directly, with a level sonar (up = +z unless a look-at target
  tilts the beam), as in the paper (a 6.2 m circle at 5 m altitude with N = 1, 5, 10 or 15
  pulses);
* timed trajectories (:class:`Circle`, :class:`Line`, :class:`FigureEight`,
  :class:`Waypoints`, :class:`Hover`) give position and its derivatives up to snap and a yaw
  reference; :meth:`batecho.quadrotor.Quadrotor.fly` tracks them.

Heading modes (shared by all): ``"velocity"`` points the beam along the horizontal direction
of travel; ``"center"`` / ``"look_at"`` at a point (``target``; the circle's centre at flight
altitude by default); ``"fixed"`` at a constant yaw ``yaw_deg``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.integrate import quad
from scipy.interpolate import make_interp_spline

from ._validate import finite, finite_scalar, positive_scalar, real_array, vectors
from .poses import Poses

__all__ = [
    "Circle",
    "FigureEight",
    "Hover",
    "Line",
    "Trajectory",
    "Waypoints",
    "circle",
    "figure_eight",
    "line_to",
]

_HEADINGS = {
    "velocity": "velocity",
    "center": "look_at",
    "centre": "look_at",
    "look_at": "look_at",
    "fixed": "fixed",
}
_TINY = 1e-12


# ----------------------------------------------------------------------------- validation


def _center_xy(center: Any) -> np.ndarray:
    c = real_array(center, "center").ravel()
    if c.shape not in ((2,), (3,)):
        raise ValueError(f"center must be an (x, y) or (x, y, z) vector, got shape {c.shape}")
    finite(c, "center")
    return c[:2].copy()


def _point(p: Any, name: str) -> np.ndarray:
    return vectors(p, name)[0]


def _count(n: Any, name: str = "n_points") -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {n!r}")
    if n < 1:
        raise ValueError(f"{name} must be >= 1, got {n}")
    return int(n)


def _heading(
    heading: str, target: Any, yaw_deg: Any, default_target: np.ndarray | None
) -> tuple[str, np.ndarray | None, float | None]:
    """Normalised (mode, target (3,) or None, yaw in radians or None)."""
    if not isinstance(heading, str) or heading.lower() not in _HEADINGS:
        raise ValueError(f"heading must be one of {sorted(_HEADINGS)}, got {heading!r}")
    mode = _HEADINGS[heading.lower()]
    if mode != "look_at" and target is not None:
        raise ValueError(f"target is only used with heading='look_at'/'center', not {heading!r}")
    if mode != "fixed" and yaw_deg is not None:
        raise ValueError(f"yaw_deg is only used with heading='fixed', not {heading!r}")
    if mode == "look_at":
        tgt = default_target if target is None else _point(target, "target")
        if tgt is None:
            raise ValueError("heading='look_at' needs a target=(x, y, z)")
        return mode, np.asarray(tgt, dtype=np.float64), None
    if mode == "fixed":
        if yaw_deg is None:
            raise ValueError("heading='fixed' needs yaw_deg (degrees from +x toward +y)")
        return mode, None, math.radians(finite_scalar(yaw_deg, "yaw_deg"))
    return mode, None, None


def _level_forward(yaw: np.ndarray) -> np.ndarray:
    return np.stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)], axis=-1)


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
        bad = np.hypot(fwd[:, 0], fwd[:, 1]) <= _TINY
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"pose {i}: the direction of travel {tangents[i]} has no horizontal "
                "component, so heading='velocity' is undefined; use "
                "heading='fixed' or 'look_at'"
            )
    elif mode == "look_at":
        fwd = target[None, :] - positions
        bad = np.linalg.norm(fwd, axis=1) <= _TINY
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"pose {i}: position {positions[i]} coincides with the look-at target {target}"
            )
    else:
        fwd = _level_forward(np.full(len(positions), yaw))
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
    c = _center_xy(center)
    r = positive_scalar(radius, "radius")
    z = finite_scalar(altitude, "altitude")
    n = _count(n_points)
    th = (
        math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        + 2.0 * np.pi * np.arange(n) / n
    )
    cos, sin = np.cos(th), np.sin(th)
    pos = np.stack([c[0] + r * cos, c[1] + r * sin, np.full(n, z)], axis=1)
    tan = np.stack([-sin, cos, np.zeros(n)], axis=1)
    mode, tgt, yaw = _heading(heading, target, yaw_deg, np.array([c[0], c[1], z]))
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
    a = _point(start, "start")
    b = _point(target, "target")
    n = _count(n_points)
    d = positive_scalar(stop_distance, "stop_distance", allow_zero=True)
    length = float(np.linalg.norm(b - a))
    if not length > d:
        raise ValueError(
            f"start is {length:.6g} m from the target, not more than stop_distance={d:.6g} m"
        )
    u = (b - a) / length
    s = np.linspace(0.0, length - d, n) if n > 1 else np.zeros(1)
    pos = a[None, :] + s[:, None] * u[None, :]
    mode, tgt, yaw = _heading(heading, None, yaw_deg, b)
    return _kinematic_poses(pos, np.repeat(u[None, :], n, axis=0), mode, tgt, yaw)


def _gerono(theta: np.ndarray, c: np.ndarray, r: float, z: float, order: int = 0) -> np.ndarray:
    """``order``-th theta-derivative of the Gerono lemniscate x = 2r sin th, y = r sin 2th."""
    ph = order * np.pi / 2
    x = 2.0 * r * np.sin(theta + ph) + (c[0] if order == 0 else 0.0)
    y = r * 2.0**order * np.sin(2.0 * theta + ph) + (c[1] if order == 0 else 0.0)
    zz = np.full_like(theta, z if order == 0 else 0.0)
    return np.stack([x, y, zz], axis=-1)


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
    c = _center_xy(center)
    r = positive_scalar(radius, "radius")
    z = finite_scalar(altitude, "altitude")
    n = _count(n_points)
    th = (
        math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        + 2.0 * np.pi * np.arange(n) / n
    )
    mode, tgt, yaw = _heading(heading, target, yaw_deg, np.array([c[0], c[1], z]))
    return _kinematic_poses(_gerono(th, c, r, z), _gerono(th, c, r, z, 1), mode, tgt, yaw)


# -------------------------------------------------------------------- timed trajectories


def _planar_yaw(
    d: np.ndarray, dd: np.ndarray, ddd: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Yaw of the horizontal part of a vector function and its first two time derivatives."""
    dx, dy = d[:, 0], d[:, 1]
    D = dx * dx + dy * dy
    N = dx * dd[:, 1] - dy * dd[:, 0]
    Nd = dx * ddd[:, 1] - dy * ddd[:, 0]
    Dd = 2.0 * (dx * dd[:, 0] + dy * dd[:, 1])
    ok = D > _TINY
    Ds = np.where(ok, D, 1.0)
    rate = np.where(ok, N / Ds, 0.0)
    acc = np.where(ok, (Nd * Ds - N * Dd) / (Ds * Ds), 0.0)
    return np.arctan2(dy, dx), rate, acc


class Trajectory:
    """A timed reference: position (m), its derivatives, and a yaw (rad) for the heading mode.

    Subclasses implement ``_derivative(t, order)`` for orders 0 (position) to 4 (snap),
    returning (n, 3) arrays in the world frame for a 1-D array of times ``t`` (s). Public
    methods take a scalar (-> (3,)) or an array of times (-> (len(t), 3)).
    """

    heading: str = "velocity"
    target: np.ndarray | None = None
    _yaw: float | None = None
    duration: float = math.inf

    def _set_heading(
        self, heading: str, target: Any, yaw_deg: Any, default_target: np.ndarray | None
    ) -> None:
        self.heading, self.target, self._yaw = _heading(heading, target, yaw_deg, default_target)

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def _eval(self, t: Any, order: int) -> np.ndarray:
        arr = finite(real_array(t, "t"), "t")
        out = self._derivative(np.atleast_1d(arr).ravel(), order)
        return out[0] if arr.ndim == 0 else out.reshape(arr.shape + (3,))

    def position(self, t: Any) -> np.ndarray:
        """Position (m) at time(s) ``t`` (s)."""
        return self._eval(t, 0)

    def velocity(self, t: Any) -> np.ndarray:
        """Velocity (m/s)."""
        return self._eval(t, 1)

    def acceleration(self, t: Any) -> np.ndarray:
        """Acceleration (m/s^2)."""
        return self._eval(t, 2)

    def jerk(self, t: Any) -> np.ndarray:
        """Jerk (m/s^3)."""
        return self._eval(t, 3)

    def snap(self, t: Any) -> np.ndarray:
        """Snap (m/s^4)."""
        return self._eval(t, 4)

    def _travel_direction(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(d, d', d'') whose horizontal part gives the velocity heading; where the vehicle is
        at rest the first non-vanishing higher derivative gives the direction."""
        v, a, j, s = (self._derivative(t, k) for k in (1, 2, 3, 4))
        d, dd, ddd = v.copy(), a.copy(), j.copy()
        for cand in (a, j, s):
            still = np.hypot(d[:, 0], d[:, 1]) <= 1e-9
            if not still.any():
                break
            d[still] = cand[still]
            dd[still] = 0.0
            ddd[still] = 0.0
        return d, dd, ddd

    def yaw_derivatives(self, t: Any) -> tuple[Any, Any, Any]:
        """(yaw rad in (-pi, pi], yaw rate rad/s, yaw acceleration rad/s^2) at ``t``."""
        arr = finite(real_array(t, "t"), "t")
        tt = np.atleast_1d(arr).ravel()
        if self.heading == "fixed":
            out = (np.full(tt.shape, self._yaw), np.zeros(tt.shape), np.zeros(tt.shape))
        elif self.heading == "look_at":
            p, v, a = (self._derivative(tt, k) for k in (0, 1, 2))
            out = _planar_yaw(self.target[None, :] - p, -v, -a)
        else:
            out = _planar_yaw(*self._travel_direction(tt))
        if arr.ndim == 0:
            return tuple(float(o[0]) for o in out)
        return tuple(o.reshape(arr.shape) for o in out)

    def yaw(self, t: Any) -> Any:
        """Yaw reference (rad, from +x toward +y) following the heading mode."""
        return self.yaw_derivatives(t)[0]

    def times(self, rate_hz: float, duration: float | None = None) -> np.ndarray:
        """Times 0, 1/rate_hz, ... up to ``duration`` (s; default ``self.duration``)."""
        rate = positive_scalar(rate_hz, "rate_hz")
        dur = self.duration if duration is None else positive_scalar(duration, "duration")
        if not math.isfinite(dur):
            raise ValueError("this trajectory has no finite duration; pass duration=")
        return np.arange(math.floor(dur * rate + 1e-9) + 1) / rate

    def poses(self, t: Any, mount: Any = None) -> Poses:
        """Kinematic sonar poses at times ``t``: the body level (yaw from the heading mode,
        up = +z) and the sonar ``mount`` (a :class:`batecho.quadrotor.SonarMount`) applied.
        The attitude a real vehicle needs to fly the path is ignored (compare
        :meth:`batecho.quadrotor.Flight.poses`)."""
        tt = np.atleast_1d(finite(real_array(t, "t"), "t")).ravel()
        yaw = np.atleast_1d(self.yaw(tt))
        R = np.zeros((len(tt), 3, 3))
        R[:, 0, 0] = R[:, 1, 1] = np.cos(yaw)
        R[:, 1, 0] = np.sin(yaw)
        R[:, 0, 1] = -np.sin(yaw)
        R[:, 2, 2] = 1.0
        pos = self._derivative(tt, 0)
        if mount is None:
            return Poses.from_rotations(pos, R)
        return mount.pose(pos, R)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(duration={self.duration:.6g} s, heading={self.heading!r})"


class Hover(Trajectory):
    """Hold ``position`` (m) at a fixed yaw ``yaw_deg`` for ever."""

    def __init__(self, position: Any = (0.0, 0.0, 1.0), yaw_deg: float = 0.0):
        self.point = _point(position, "position")
        self._set_heading("fixed", None, yaw_deg, None)

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        out = np.zeros((len(t), 3))
        if order == 0:
            out[:] = self.point
        return out


class Circle(Trajectory):
    """Constant-speed horizontal circle, analytic to all orders.

    ``p(t) = c + r (cos th, sin th, 0) + (0, 0, altitude)`` with ``th = th0 + w t`` and
    ``w = speed / radius`` (negative if ``clockwise``). It starts at full speed at t = 0 and
    repeats; ``duration`` is one lap (s). Centripetal acceleration ``speed^2 / radius``.
    """

    def __init__(
        self,
        center: Any,
        radius: float = 6.2,
        altitude: float = 5.0,
        speed: float = 2.0,
        *,
        start_angle_deg: float = 0.0,
        clockwise: bool = False,
        heading: str = "velocity",
        target: Any = None,
        yaw_deg: float | None = None,
    ):
        self.center = _center_xy(center)
        self.radius = positive_scalar(radius, "radius")
        self.altitude = finite_scalar(altitude, "altitude")
        self.speed = positive_scalar(speed, "speed")
        self.theta0 = math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        self.omega = (-1.0 if clockwise else 1.0) * self.speed / self.radius
        self.duration = 2.0 * math.pi / abs(self.omega)
        self._set_heading(heading, target, yaw_deg, np.array([*self.center, self.altitude]))

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        th = self.theta0 + self.omega * t + order * np.pi / 2
        k = self.radius * self.omega**order
        out = np.stack([k * np.cos(th), k * np.sin(th), np.zeros_like(th)], axis=-1)
        if order == 0:
            out += np.array([*self.center, self.altitude])
        return out


class FigureEight(Trajectory):
    """Horizontal figure eight (lemniscate of Gerono) flown at a constant angular rate.

    ``x = cx + 2 r sin(w t + th0)``, ``y = cy + r sin(2 (w t + th0))``, ``z = altitude``; each
    lobe spans ``2r x 2r``. Give ``period`` (s per eight) or ``speed`` (mean speed, m/s; the
    period is then the curve length over ``speed``; default 2 m/s). The speed varies along the
    path, between about 0.7 and 1.4 times ``2 r w``.
    """

    def __init__(
        self,
        center: Any,
        radius: float = 3.1,
        altitude: float = 5.0,
        speed: float | None = None,
        period: float | None = None,
        *,
        start_angle_deg: float = 0.0,
        heading: str = "velocity",
        target: Any = None,
        yaw_deg: float | None = None,
    ):
        self.center = _center_xy(center)
        self.radius = positive_scalar(radius, "radius")
        self.altitude = finite_scalar(altitude, "altitude")
        self.theta0 = math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        if speed is not None and period is not None:
            raise ValueError("give speed or period, not both")
        length = (
            self.radius
            * quad(
                lambda th: 2.0 * math.hypot(math.cos(th), math.cos(2 * th)),
                0.0,
                2.0 * math.pi,
                limit=200,
            )[0]
        )
        self.length = length
        if period is None:
            period = length / positive_scalar(2.0 if speed is None else speed, "speed")
        self.duration = positive_scalar(period, "period")
        self.speed = length / self.duration
        self.omega = 2.0 * math.pi / self.duration
        self._set_heading(heading, target, yaw_deg, np.array([*self.center, self.altitude]))

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        th = self.theta0 + self.omega * t
        return _gerono(th, self.center, self.radius, self.altitude, order) * (self.omega**order)


def _ramp(u: np.ndarray, order: int) -> np.ndarray:
    """Integral (order 0) and derivatives of the quintic smoothstep speed profile
    ``sigma(u) = 10u^3 - 15u^4 + 6u^5`` (order 1 is sigma itself)."""
    if order == 0:
        return u**4 * (2.5 - 3.0 * u + u * u)
    if order == 1:
        return u**3 * (10.0 - 15.0 * u + 6.0 * u * u)
    if order == 2:
        return 30.0 * u * u * (1.0 - u) ** 2
    if order == 3:
        return 60.0 * u - 180.0 * u * u + 120.0 * u**3
    return 60.0 - 360.0 * u + 360.0 * u * u


class Line(Trajectory):
    """Straight flight from ``start`` to ``end`` (m) at cruise ``speed`` (m/s), rest to rest.

    The speed rises from 0 to ``speed`` over ``ramp_time`` s along a quintic smoothstep
    (``v = speed (10u^3 - 15u^4 + 6u^5)``, ``u = t / ramp_time``) and falls symmetrically at
    the end, so velocity, acceleration and jerk are continuous and the peak acceleration is
    ``1.875 speed / ramp_time`` (snap jumps at the ramp ends but stays finite). The default
    ramp gives a 1 m/s^2 peak. ``ramp_time=0`` flies at constant speed throughout (velocity
    steps at both ends, acceleration zero). If the line is too short to reach ``speed`` the
    cruise speed is lowered to ``length / ramp_time``. Before t = 0 and after ``duration``
    the position holds at the ends.
    """

    def __init__(
        self,
        start: Any,
        end: Any,
        speed: float = 1.0,
        *,
        ramp_time: float | None = None,
        heading: str = "velocity",
        target: Any = None,
        yaw_deg: float | None = None,
    ):
        self.start = _point(start, "start")
        self.end = _point(end, "end")
        self.speed = positive_scalar(speed, "speed")
        self.length = float(np.linalg.norm(self.end - self.start))
        if not self.length > 0:
            raise ValueError("start and end coincide; use Hover for a stationary reference")
        self.direction = (self.end - self.start) / self.length
        tr = (
            1.875 * self.speed / 1.0
            if ramp_time is None
            else positive_scalar(ramp_time, "ramp_time", allow_zero=True)
        )
        if self.speed * tr > self.length:
            self.speed = self.length / tr
        self.ramp_time = tr
        self.cruise_time = (self.length - self.speed * tr) / self.speed
        self.duration = 2.0 * tr + self.cruise_time
        self._set_heading(heading, target, yaw_deg, self.end)
        if self.heading == "velocity" and math.hypot(*self.direction[:2]) <= _TINY:
            raise ValueError(
                "a vertical Line has no horizontal direction of travel; use "
                "heading='fixed' or 'look_at'"
            )

    def _s(self, t: np.ndarray, order: int) -> np.ndarray:
        v, tr, T, L = self.speed, self.ramp_time, self.duration, self.length
        if tr == 0.0:
            inside = (t >= 0.0) & (t <= T)
            if order == 0:
                return np.clip(v * t, 0.0, L)
            return np.where(inside, v, 0.0) if order == 1 else np.zeros_like(t)
        s = np.zeros_like(t)
        a = (t >= 0.0) & (t < tr)
        b = (t >= tr) & (t <= tr + self.cruise_time)
        c = (t > tr + self.cruise_time) & (t <= T)
        scale = v * tr ** (1 - order)
        s[a] = scale * _ramp(t[a] / tr, order)
        s[c] = (-1.0) ** (order + 1) * scale * _ramp((T - t[c]) / tr, order)
        if order == 0:
            s[b] = 0.5 * v * tr + v * (t[b] - tr)
            s[c] += L
            s[t > T] = L
        elif order == 1:
            s[b] = v
        return s

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        out = self._s(t, order)[:, None] * self.direction[None, :]
        if order == 0:
            out += self.start
        return out

    def _travel_direction(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        d = np.repeat(self.direction[None, :], len(t), axis=0)
        return d, np.zeros_like(d), np.zeros_like(d)


class Waypoints(Trajectory):
    """A smooth path through ``points`` (k, 3) m: a quintic B-spline in time.

    Knot times start from the chord lengths (a centripetal-free, arc-length-like
    parameterisation), with the first and last segments given double time; the spline
    (``scipy.interpolate.make_interp_spline``, k = 5) starts and ends at rest (velocity and
    acceleration zero) unless ``closed``, in which case the path returns to the first point
    and is periodic. The time axis is then scaled so that the fastest point of the path moves
    at ``speed`` m/s. Position is C4, so snap is continuous. Outside ``[0, duration]`` an open
    path holds its end points; a closed one repeats.
    """

    def __init__(
        self,
        points: Any,
        speed: float = 2.0,
        *,
        closed: bool = False,
        heading: str = "velocity",
        target: Any = None,
        yaw_deg: float | None = None,
    ):
        pts = vectors(points, "points", allow_single=False)
        if len(pts) < 2:
            raise ValueError(f"Waypoints needs at least 2 points, got {len(pts)}")
        self.speed = positive_scalar(speed, "speed")
        self.closed = bool(closed)
        if self.closed:
            if len(pts) < 3:
                raise ValueError("a closed Waypoints path needs at least 3 points")
            if not np.allclose(pts[0], pts[-1]):
                pts = np.vstack([pts, pts[:1]])
        chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if not (chords > 0).all():
            i = int(np.argmax(~(chords > 0)))
            raise ValueError(f"waypoints {i} and {i + 1} coincide")
        self.points = pts
        seg = chords.copy()
        if not self.closed:
            seg[0] *= 2.0
            seg[-1] *= 2.0
        u = np.concatenate([[0.0], np.cumsum(seg)])
        if self.closed:
            bc: Any = "periodic"
        else:
            z = np.zeros(3)
            bc = ([(1, z), (2, z)], [(1, z), (2, z)])
        spl = make_interp_spline(u, pts, k=5, bc_type=bc)
        uu = np.linspace(0.0, u[-1], 200 * len(pts) + 1)
        vmax = float(np.linalg.norm(spl(uu, 1), axis=1).max())
        scale = vmax / self.speed  # seconds per unit of u
        self.knot_times = u * scale
        self.duration = float(self.knot_times[-1])
        self._spline = make_interp_spline(self.knot_times, pts, k=5, bc_type=bc)
        self._set_heading(heading, target, yaw_deg, None)

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        T = self.duration
        if self.closed:
            return self._spline(np.mod(t, T), order)
        tc = np.clip(t, 0.0, T)
        out = self._spline(tc, order)
        if order > 0:
            out[(t < 0.0) | (t > T)] = 0.0
        return out
