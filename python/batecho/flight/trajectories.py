"""Timed reference trajectories: :class:`Circle`, :class:`Line`, :class:`FigureEight`,
:class:`Waypoints` and :class:`Hover` give position and its derivatives up to snap and a yaw
reference; :meth:`batecho.flight.vehicle.Quadrotor.fly` tracks them.

World frame: right-handed, z up, metres, seconds; yaw ``psi`` is the angle of the horizontal
heading from +x toward +y (radians inside, degrees only in names ending ``_deg``). Heading
modes (shared by all): ``"velocity"`` points the beam along the horizontal direction of
travel; ``"center"`` / ``"look_at"`` at a point (``target``; the circle's centre at flight
altitude by default; where the vehicle is right below or above it, as at the end of a
look-at :class:`Line`, along the direction of travel); ``"fixed"`` at a constant yaw
``yaw_deg``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._resources import BYTES_PER_POSE, check_memory
from .._validate import finite, finite_scalar, flag, positive_scalar, real_array, vectors
from ._paths import TINY, center_xy, gerono, heading_mode, point
from .poses import Poses

__all__ = ["Circle", "Cruise", "FigureEight", "Hover", "Line", "Trajectory", "Waypoints"]


def _planar_yaw(
    d: np.ndarray, dd: np.ndarray, ddd: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Yaw of the horizontal part of a vector function and its first two time derivatives."""
    dx, dy = d[:, 0], d[:, 1]
    D = dx * dx + dy * dy
    N = dx * dd[:, 1] - dy * dd[:, 0]
    Nd = dx * ddd[:, 1] - dy * ddd[:, 0]
    Dd = 2.0 * (dx * dd[:, 0] + dy * dd[:, 1])
    ok = D > TINY
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
        self.heading, self.target, self._yaw = heading_mode(
            heading, target, yaw_deg, default_target
        )

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
            assert self.target is not None  # set with heading "look_at"
            out = _planar_yaw(self.target[None, :] - p, -v, -a)
            d = self.target[None, :2] - p[:, :2]
            here = np.einsum("ij,ij->i", d, d) <= TINY
            if here.any():  # at the target (a Line's end): the heading of travel there
                travel = _planar_yaw(*self._travel_direction(tt[here]))
                for o, o_here in zip(out, travel, strict=True):
                    o[here] = o_here
        else:
            out = _planar_yaw(*self._travel_direction(tt))
        yaw, rate, acc = out
        if arr.ndim == 0:
            return float(yaw[0]), float(rate[0]), float(acc[0])
        return yaw.reshape(arr.shape), rate.reshape(arr.shape), acc.reshape(arr.shape)

    def yaw(self, t: Any) -> Any:
        """Yaw reference (rad, from +x toward +y) following the heading mode."""
        return self.yaw_derivatives(t)[0]

    def times(self, rate_hz: float, duration: float | None = None) -> np.ndarray:
        """Times 0, 1/rate_hz, ... up to ``duration`` (s; default ``self.duration``)."""
        rate = positive_scalar(rate_hz, "rate_hz")
        dur = self.duration if duration is None else positive_scalar(duration, "duration")
        if not math.isfinite(dur):
            raise ValueError("this trajectory has no finite duration; pass duration=")
        k = math.floor(dur * rate + 1e-9) + 1
        check_memory(
            k * BYTES_PER_POSE,
            f"times at rate_hz = {rate:g} over {dur:g} s ({k:.3g} of them, as poses)",
            "use a lower rate or a shorter duration",
        )
        return np.arange(k) / rate

    def poses(self, t: Any, mount: Any = None) -> Poses:
        """Kinematic sonar poses at times ``t``: the body level (yaw from the heading mode,
        up = +z) and the sonar ``mount`` (a :class:`batecho.flight.mount.SonarMount`) applied.
        The attitude a real vehicle needs to fly the path is ignored (compare
        :meth:`batecho.flight.record.Flight.poses`)."""
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
        self.point = point(position, "position")
        self._set_heading("fixed", None, yaw_deg, None)

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        out = np.zeros((len(t), 3))
        if order == 0:
            out[:] = self.point
        return out


class Cruise(Trajectory):
    """Level flight at a constant ``velocity`` (m/s, world) from ``start`` (m), turning at a
    constant ``yaw_rate_deg_s`` from ``yaw_deg``: ``p(t) = start + velocity t``,
    ``yaw(t) = yaw_deg + yaw_rate_deg_s t`` (in radians inside). It is the reference of one
    velocity-and-yaw-rate command of :class:`batecho.flight.sim.QuadrotorSim`."""

    def __init__(
        self,
        start: Any,
        velocity: Any,
        yaw_deg: float = 0.0,
        yaw_rate_deg_s: float = 0.0,
    ):
        self.start = point(start, "start")
        self.cruise_velocity = point(velocity, "velocity")
        self.yaw0 = math.radians(finite_scalar(yaw_deg, "yaw_deg"))
        self.yaw_rate = math.radians(finite_scalar(yaw_rate_deg_s, "yaw_rate_deg_s"))
        self._set_heading("fixed", None, yaw_deg, None)

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        out = np.zeros((len(t), 3))
        if order == 0:
            out[:] = self.start + t[:, None] * self.cruise_velocity
        elif order == 1:
            out[:] = self.cruise_velocity
        return out

    def yaw_derivatives(self, t: Any) -> tuple[Any, Any, Any]:
        arr = finite(real_array(t, "t"), "t")
        yaw = self.yaw0 + self.yaw_rate * arr
        rate, acc = np.full(arr.shape, self.yaw_rate), np.zeros(arr.shape)
        if arr.ndim == 0:
            return float(yaw), float(rate), 0.0
        return yaw, rate, acc


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
        self.center = center_xy(center)
        self.radius = positive_scalar(radius, "radius")
        self.altitude = finite_scalar(altitude, "altitude")
        self.speed = positive_scalar(speed, "speed")
        self.theta0 = math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        w = self.speed / self.radius
        with np.errstate(over="ignore", divide="ignore"):
            lap, snap = 2.0 * np.pi / np.float64(w), self.radius * np.float64(w) ** 4
        if not (np.isfinite(lap) and np.isfinite(snap)):
            raise ValueError(
                f"the angular rate speed / radius = {self.speed:g} m/s / {self.radius:g} m "
                f"= {w:.3g} rad/s is too small or large for float64 (a lap's duration or the "
                "path's snap overflows); use an ordinary speed and radius"
            )
        self.omega = (-1.0 if flag(clockwise, "clockwise") else 1.0) * w
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
        self.center = center_xy(center)
        self.radius = positive_scalar(radius, "radius")
        self.altitude = finite_scalar(altitude, "altitude")
        self.theta0 = math.radians(finite_scalar(start_angle_deg, "start_angle_deg"))
        if speed is not None and period is not None:
            raise ValueError("give speed or period, not both")
        from scipy.integrate import quad

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
            v = positive_scalar(2.0 if speed is None else speed, "speed")
            with np.errstate(over="ignore"):
                period = float(np.float64(length) / v)
            given = f"length {length:g} m / speed {v:g} m/s"
        else:
            period = positive_scalar(period, "period")
            given = "period"
        with np.errstate(over="ignore", divide="ignore"):
            w = 2.0 * np.pi / np.float64(period)
            snap = 16.0 * self.radius * w**4  # (y's snap, the larger)
        if not (np.isfinite(period) and period > 0 and np.isfinite(snap)):
            raise ValueError(
                f"the period {period:g} s ({given}) of a figure eight of radius "
                f"{self.radius:g} m is too short or long for float64 (the period or the "
                "path's snap, 16 radius (2 pi / period)^4, overflows); use an ordinary "
                "radius, speed or period"
            )
        self.duration = period
        self.speed = length / self.duration
        self.omega = 2.0 * math.pi / self.duration
        self._set_heading(heading, target, yaw_deg, np.array([*self.center, self.altitude]))

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        th = self.theta0 + self.omega * t
        return gerono(th, self.center, self.radius, self.altitude, order) * (self.omega**order)


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
    cruise speed is lowered: to ``length / ramp_time`` for a given ``ramp_time``, and with the
    default ramp to ``sqrt(length / 1.875)``, whose ramp keeps the 1 m/s^2 peak. Before t = 0
    and after ``duration`` the position holds at the ends.
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
        self.start = point(start, "start")
        self.end = point(end, "end")
        self.speed = positive_scalar(speed, "speed")
        with np.errstate(over="ignore"):
            self.length = float(np.linalg.norm(self.end - self.start))
        if not math.isfinite(self.length):
            raise ValueError(
                f"start {self.start} and end {self.end} are too far apart: their distance "
                "overflows float64"
            )
        if not self.length > 0:
            raise ValueError("start and end coincide; use Hover for a stationary reference")
        self.direction = (self.end - self.start) / self.length
        tr = (
            1.875 * self.speed / 1.0
            if ramp_time is None
            else positive_scalar(ramp_time, "ramp_time", allow_zero=True)
        )
        if self.speed * tr > self.length:
            if ramp_time is None:  # the fastest speed whose own 1 m/s^2 ramp fits the line
                self.speed = math.sqrt(self.length / 1.875)
                tr = 1.875 * self.speed
            else:
                self.speed = self.length / tr
        if tr > 0.0:  # (the ramp's snap peaks at 60 speed / ramp_time^3)
            with np.errstate(over="ignore"):
                snap = 60.0 * self.speed * np.float64(tr) ** -3
            if not np.isfinite(snap):
                ramp, fix = (
                    ("ramp_time", "a longer ramp_time, or ramp_time=0 for no ramp")
                    if ramp_time is not None
                    else ("the default ramp, 1.875 speed", "a higher speed or a ramp_time")
                )
                raise ValueError(
                    f"the speed ramp of {tr:g} s ({ramp}; speed {self.speed:g} m/s) is too "
                    f"short for float64: the path's jerk and snap overflow; use {fix}"
                )
        self.ramp_time = tr
        self.cruise_time = (self.length - self.speed * tr) / self.speed
        self.duration = 2.0 * tr + self.cruise_time
        self._set_heading(heading, target, yaw_deg, self.end)
        vertical = math.hypot(*self.direction[:2]) <= TINY
        if vertical and self.heading == "velocity":
            raise ValueError(
                "a vertical Line has no horizontal direction of travel; use "
                "heading='fixed', or 'look_at' with a target off the line"
            )
        if vertical and self.target is not None:
            off = math.hypot(*(self.target[:2] - self.start[:2]))
            if off * off <= TINY:  # as where look-at yaw is undefined
                raise ValueError(
                    f"the look-at target {self.target} is right above or below this vertical "
                    "Line, so its heading is undefined all the way; use heading='fixed' or a "
                    "target off the line"
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


#: The shortest step between waypoints, relative to the larger of the largest coordinate and
#: the path's length (the fit's rounding is about 1e-16 of them: at 1e-12 its speed is off by
#: about 1e-8, at 1e-14 by 3e-4, and shorter steps merge knots).
WAYPOINT_RESOLUTION = 1e-12


class Waypoints(Trajectory):
    """A smooth path through ``points`` (k, 3) m: a quintic B-spline in time.

    Knot times start from the chord lengths (a centripetal-free, arc-length-like
    parameterisation), with the first and last segments given double time; the spline
    (``scipy.interpolate.make_interp_spline``, k = 5) starts and ends at rest (velocity and
    acceleration zero) unless ``closed``, in which case the path returns to the first point
    and is periodic (a last point equal to the first is that return; one merely near it is a
    waypoint of its own). The time axis is then scaled so that the fastest point of the path moves
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
        self.closed = flag(closed, "closed")
        if self.closed:
            if len(pts) < 3:
                raise ValueError("a closed Waypoints path needs at least 3 points")
            if not np.array_equal(pts[0], pts[-1]):  # a last point merely near is a waypoint
                pts = np.vstack([pts, pts[:1]])
        with np.errstate(over="ignore"):
            chords = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if not np.isfinite(chords).all():
            i = int(np.argmax(~np.isfinite(chords)))
            raise ValueError(
                f"waypoints {i} and {i + 1} are too far apart: their distance overflows float64"
            )
        if not (chords > 0).all():
            i = int(np.argmax(~(chords > 0)))
            raise ValueError(f"waypoints {i} and {i + 1} coincide")
        extent = max(float(np.abs(pts).max()), float(chords.sum()))
        if not (chords >= WAYPOINT_RESOLUTION * extent).all():
            i = int(np.argmax(~(chords >= WAYPOINT_RESOLUTION * extent)))
            raise ValueError(
                f"waypoints {i} and {i + 1} are {chords[i]:.3g} m apart, below "
                f"{WAYPOINT_RESOLUTION:g} of the path's size ({extent:.3g} m, its largest "
                "coordinate or its length): too close for float64 to fit a path through them"
            )
        self.points = pts
        seg = chords.copy()
        if not self.closed:
            seg[0] *= 2.0
            seg[-1] *= 2.0
        u = np.concatenate([[0.0], np.cumsum(seg)])
        from scipy.interpolate import make_interp_spline

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
        self._spline = self._time_spline(pts, bc, float(chords.sum()))
        self._set_heading(heading, target, yaw_deg, None)

    def _time_spline(self, pts: np.ndarray, bc: Any, length: float) -> Any:
        """The path's spline in time through ``pts`` at :attr:`knot_times`; ValueError naming
        the speed (and the waypoints' ``length``, m) where float64 cannot hold it (knot times
        that overflow or run together, or derivatives that overflow)."""
        from scipy.interpolate import make_interp_spline

        t = self.knot_times
        problem = (
            f"speed={self.speed:g} m/s over waypoints {length:.3g} m apart in all is too small "
            "or large for float64 (the path's duration or its derivatives overflow); use an "
            "ordinary speed"
        )
        if not (np.isfinite(t).all() and (np.diff(t) > 0).all()):
            raise ValueError(problem)
        try:
            with np.errstate(all="ignore"):
                spl = make_interp_spline(t, pts, k=5, bc_type=bc)
        except (ValueError, np.linalg.LinAlgError):
            raise ValueError(problem) from None
        with np.errstate(over="ignore", invalid="ignore"):
            if not all(np.isfinite(spl(t, order)).all() for order in range(5)):
                raise ValueError(problem)
        return spl

    def _derivative(self, t: np.ndarray, order: int) -> np.ndarray:
        T = self.duration
        if self.closed:
            return self._spline(np.mod(t, T), order)
        tc = np.clip(t, 0.0, T)
        out = self._spline(tc, order)
        if order > 0:
            out[(t < 0.0) | (t > T)] = 0.0
        return out
