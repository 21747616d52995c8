"""Flight plans of scene files: the pulse poses of a ``[flight]`` table, kinematic or flown,
with the path and the axis an echo image is drawn along."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._resources import BYTES_PER_POSE, check_memory
from ..flight.poses import Poses
from ..flight.vehicle import BYTES_PER_STEP
from .schema import ScenefileError

__all__ = ["DEFAULT_RADIUS_M", "FlightPlan", "flight_plan"]


@dataclass
class FlightPlan:
    """Pulse poses and what to draw: ``poses``; ``pulse_times`` (p,) s or None (kinematic
    pulses placed by count); ``path_points`` (k, 3) m, the flown or planned path; ``x`` and
    ``x_label``, the echo image's axis; ``flight``, the :class:`batecho.Flight` when flown;
    ``closed`` whether the path is a loop; ``radius``, the radius (m) of a circle or figure
    eight (0 for other paths)."""

    poses: Poses
    pulse_times: np.ndarray | None
    path_points: np.ndarray
    x: np.ndarray
    x_label: str
    closed: bool
    flight: Any = None
    trajectory: Any = None
    radius: float = 0.0


#: The default radii (m) of a circle (the paper's) and of a figure eight.
DEFAULT_RADIUS_M = {"circle": 6.2, "figure_eight": 3.1}


def _check_pulses(fl: dict[str, Any], duration: float, bytes_per_pulse: float) -> None:
    """Refuse, naming the key, a pulse count whose echoes would not fit the memory limit."""
    if not np.isfinite(duration):
        return  # (the path's own checks say what is missing)
    if "pulse_rate_hz" in fl:
        key, count = "pulse_rate_hz", fl["pulse_rate_hz"] * duration + 1.0
    else:
        key, count = "n_pulses", float(fl["n_pulses"])
    check_memory(
        count * max(bytes_per_pulse, BYTES_PER_POSE),
        f"[flight] {key} = {fl[key]!r}: {count:.4g} pulses over {duration:.4g} s",
        "use fewer pulses, or split the flight into several scene files",
    )
    if fl["mode"] == "flown" and "dt" in fl:
        steps = duration / fl["dt"]
        check_memory(
            steps * BYTES_PER_STEP,
            f"[flight] dt = {fl['dt']!r}: a flight of {duration:.4g} s in {steps:.3g} steps",
            "use a larger dt or a shorter duration",
        )


def flight_plan(
    fl: dict[str, Any],
    center_xy: np.ndarray,
    forest: Any = None,
    bytes_per_pulse: float = 0.0,
) -> FlightPlan:
    """The poses of the ``[flight]`` table ``fl`` about the scene's centre ``center_xy``;
    ``forest`` (a :class:`batecho.Forest`) gives ``radius = "clear"`` its radius. The pulses
    times ``bytes_per_pulse`` (their echoes) must fit the memory limit."""
    from ..flight import kinematic, trajectories
    from ..flight.mount import SonarMount
    from ..flight.vehicle import Quadrotor

    path, mode = fl["path"], fl["mode"]
    z = fl["altitude"]
    heading = fl["heading"]
    center = np.asarray(fl.get("center", center_xy), dtype=np.float64)
    target = fl.get("target")
    head_kw: dict[str, Any] = {"heading": heading}
    if heading in ("center", "look_at") and target is not None:
        head_kw["target"] = target
    if heading == "fixed":
        head_kw["yaw_deg"] = fl["yaw_deg"]
    if path == "figure_eight" and heading in ("center", "look_at") and target is None:
        raise ScenefileError(
            '[flight] heading: "center" looks at the middle of a figure eight, which is on the '
            "path; give target = [x, y, z] (e.g. above the middle) or another heading"
        )
    if heading in ("center", "look_at") and target is None and path == "waypoints":
        head_kw["target"] = [center_xy[0], center_xy[1], z]
    mount = SonarMount(**fl["mount"]) if fl.get("mount") else None
    closed = path in ("circle", "figure_eight") or (path == "waypoints" and fl["closed"])
    default_target = np.array([center_xy[0], center_xy[1], z])
    radius = 0.0  # only circles and figure eights have one
    given = fl.get("radius", DEFAULT_RADIUS_M.get(path, 0.0))
    if given == "clear":
        if forest is None:
            raise ScenefileError('[flight] radius: "clear" needs a forest or tree scene')
        radius = forest.clear_circle_radius(
            center, DEFAULT_RADIUS_M[path], fl["min_clearance_m"], altitude=z
        )
    else:
        radius = float(given)
    if path == "circle":
        traj: trajectories.Trajectory = trajectories.Circle(
            center, radius, z, fl["speed"], start_angle_deg=fl["start_angle_deg"], **head_kw
        )
    elif path == "figure_eight":
        traj = trajectories.FigureEight(
            center, radius, z, speed=fl["speed"], start_angle_deg=fl["start_angle_deg"], **head_kw
        )
    elif path == "line":
        start = np.asarray(fl["start"], dtype=np.float64)
        tgt = np.asarray(target if target is not None else default_target, dtype=np.float64)
        length = float(np.linalg.norm(tgt - start))
        if not length > fl["stop_distance"]:
            raise ScenefileError(
                f"[flight] start: {length:.3g} m from the target, not more than "
                f"stop_distance = {fl['stop_distance']:g} m"
            )
        end = tgt - fl["stop_distance"] * (tgt - start) / length
        kw = dict(head_kw)
        if heading in ("center", "look_at"):
            kw = {"heading": "look_at", "target": tgt}
        traj = trajectories.Line(start, end, fl["speed"], **kw)
    else:
        traj = trajectories.Waypoints(fl["points"], fl["speed"], closed=fl["closed"], **head_kw)
    duration = fl.get("duration", traj.duration)
    _check_pulses(fl, duration, bytes_per_pulse)
    flight = None
    if mode == "flown":
        quad = Quadrotor.crazyflie() if fl["quadrotor"] == "crazyflie" else Quadrotor.research()
        flight = quad.fly(traj, duration, dt=fl["dt"])
    if "pulse_rate_hz" in fl:
        rate = fl["pulse_rate_hz"]
        times = flight.pulse_times(rate) if flight is not None else traj.times(rate, duration)
    else:
        n = fl["n_pulses"]
        times = (
            duration * np.arange(n) / n
            if closed
            else (np.linspace(0.0, duration, n) if n > 1 else np.zeros(1))
        )
    if flight is not None:
        poses = flight.poses(times, mount=mount)
        step = max(1, len(flight.positions) // 2000)
        path_pts = np.asarray(flight.positions[::step])
        return FlightPlan(
            poses, times, path_pts, times, "pulse time (s)", closed, flight, traj, radius
        )
    path_pts = np.asarray(traj.position(np.linspace(0.0, duration, 400)))
    if "n_pulses" in fl and path in ("circle", "line", "figure_eight"):
        # Kinematic pulses by count: the paper's equal angles (circle), equal spacing (line).
        n = fl["n_pulses"]
        if path == "circle":
            poses = kinematic.circle(
                center, radius, z, n, start_angle_deg=fl["start_angle_deg"], **head_kw
            )
            x = (fl["start_angle_deg"] + 360.0 * np.arange(n) / n) % 360.0
            xl = "angle on the circle (deg)"
        elif path == "figure_eight":
            poses = kinematic.figure_eight(
                center, radius, z, n, start_angle_deg=fl["start_angle_deg"], **head_kw
            )
            x, xl = np.arange(n, dtype=np.float64), "pulse"
        else:
            kw = {"heading": "look_at" if heading in ("center", "look_at") else heading}
            if heading == "fixed":
                kw["yaw_deg"] = fl["yaw_deg"]
            tgt = np.asarray(target if target is not None else default_target)
            poses = kinematic.line_to(fl["start"], tgt, n, stop_distance=fl["stop_distance"], **kw)
            x = np.linalg.norm(poses.positions - poses.positions[0], axis=1)
            xl = "distance flown (m)"
        if mount is not None:
            poses = mount.pose(poses.positions, poses.rotations)
        return FlightPlan(poses, None, path_pts, x, xl, closed, None, traj, radius)
    poses = traj.poses(times, mount=mount)
    return FlightPlan(poses, times, path_pts, times, "pulse time (s)", closed, None, traj, radius)
