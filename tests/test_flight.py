"""Trajectories, the 6-DOF quadrotor with its SE(3) controller, and sonar poses along flights."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batecho.flight import Gusts, Quadrotor, QuadState, SE3Gains, SonarMount
from batecho.trajectories import (
    Circle,
    FigureEight,
    Hover,
    Line,
    Waypoints,
    circle,
    figure_eight,
    line_to,
)

G = 9.81
CENTER = np.array([1.5, -2.0])
AIRFRAMES = {"crazyflie": Quadrotor.crazyflie, "research": Quadrotor.research}


@pytest.fixture(scope="module", params=sorted(AIRFRAMES))
def circle_flight(request):
    """One lap of the paper's circle (6.2 m at 5 m) at 2 m/s, beam along the velocity."""
    quad = AIRFRAMES[request.param]()
    traj = Circle(CENTER, radius=6.2, altitude=5.0, speed=2.0)
    return quad, traj, quad.fly(traj, traj.duration, dt=1e-3)


@pytest.fixture(scope="module")
def center_looking_flight():
    """Half a lap of the circle with the beam on the centre (crazyflie)."""
    quad = Quadrotor.crazyflie()
    traj = Circle(CENTER, radius=6.2, altitude=5.0, speed=2.0, heading="center")
    return quad, traj, quad.fly(traj, traj.duration / 2, dt=1e-3)


def _angle_deg(a, b):
    a, b = np.broadcast_arrays(a, b)
    return np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1)))


# ----------------------------------------------------------------------------------- hover


@pytest.mark.parametrize("name", sorted(AIRFRAMES))
def test_trim_rotor_speed_gives_total_thrust_mg_and_no_moment(name):
    quad = AIRFRAMES[name]()
    w = np.full(4, quad.hover_rotor_speed)
    assert 4 * quad.k_f * quad.hover_rotor_speed**2 == pytest.approx(quad.mass * G, rel=1e-12)
    f, M = quad.thrust_and_moments(w)
    assert f == pytest.approx(quad.mass * G, rel=1e-12)
    np.testing.assert_allclose(M, 0.0, atol=1e-15)


@pytest.mark.parametrize("name", sorted(AIRFRAMES))
def test_hover_stays_within_1mm_over_2s_on_thrust_mg(name):
    quad = AIRFRAMES[name]()
    flight = quad.fly(Hover((0.0, 0.0, 1.0), yaw_deg=30.0), 2.0)
    assert flight.position_error.max() < 1e-3
    np.testing.assert_allclose(flight.thrust, quad.mass * G, rtol=1e-9)


def test_offset_start_converges_to_the_hover_point():
    quad = Quadrotor.crazyflie()
    s = quad.initial_state(Hover((0.0, 0.0, 1.0)))
    tilted = QuadState(
        s.position + [0.3, -0.2, 0.1],
        [0.5, 0.0, 0.0],
        [[1, 0, 0], [0, math.cos(0.4), -math.sin(0.4)], [0, math.sin(0.4), math.cos(0.4)]],
        [1.0, -1.0, 0.5],
        s.rotor_speeds,
    )
    flight = quad.fly(Hover((0.0, 0.0, 1.0)), 3.0, initial_state=tilted)
    assert flight.position_error[0] > 0.3
    assert flight.position_error[-1] < 0.01


# ------------------------------------------------------------------------------- tracking


def test_flown_circle_stays_within_10cm_of_reference_after_half_a_lap(circle_flight):
    _quad, traj, flight = circle_flight
    settled = flight.times >= traj.duration / 2
    assert flight.position_error[settled].max() < 0.10


def test_flown_circle_is_tracked_within_1cm_from_the_start(circle_flight):
    _quad, _traj, flight = circle_flight
    assert flight.position_error.max() < 0.01


def test_flight_records_the_reference_it_tracked(circle_flight):
    _quad, traj, flight = circle_flight
    np.testing.assert_allclose(flight.reference_positions, traj.position(flight.times))
    np.testing.assert_allclose(flight.times[-1], traj.duration)


def test_flying_twice_with_the_same_seed_gives_identical_arrays():
    quad = Quadrotor.crazyflie()
    traj = Waypoints([[0, 0, 1], [2, 0, 1.5], [2, 2, 1]], speed=1.5)
    a = quad.fly(traj, 1.0, dt=2e-3, gusts=Gusts(std=1.0), rng=np.random.default_rng(7))
    b = quad.fly(traj, 1.0, dt=2e-3, gusts=Gusts(std=1.0), rng=np.random.default_rng(7))
    for name in (
        "times",
        "positions",
        "velocities",
        "attitudes",
        "angular_velocities",
        "rotor_speeds",
        "thrust",
        "wind",
    ):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert np.abs(a.wind).max() > 0


def test_scipy_integrator_agrees_with_rk4():
    quad = Quadrotor.crazyflie()
    traj = Circle(CENTER, speed=2.0)
    a = quad.fly(traj, 0.3, dt=1e-3)
    b = quad.fly(traj, 0.3, dt=1e-3, method="scipy")
    np.testing.assert_allclose(a.positions, b.positions, atol=1e-4)
    np.testing.assert_allclose(a.attitudes, b.attitudes, atol=1e-3)


# ------------------------------------------------------------------------ kinematic poses


@pytest.mark.parametrize("n", [1, 5, 10, 15])
def test_kinematic_circle_points_are_360_over_n_degrees_apart(n):
    poses = circle(CENTER, radius=6.2, altitude=5.0, n_points=n)
    d = poses.positions - np.array([*CENTER, 5.0])
    np.testing.assert_allclose(np.hypot(d[:, 0], d[:, 1]), 6.2, rtol=1e-14)
    np.testing.assert_allclose(poses.positions[:, 2], 5.0)
    ang = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    np.testing.assert_allclose(
        np.mod(ang - 360.0 * np.arange(n) / n + 180.0, 360.0) - 180.0, 0.0, atol=1e-12
    )


def test_velocity_heading_points_along_the_counterclockwise_tangent():
    poses = circle(CENTER, n_points=15, heading="velocity")
    radial = poses.positions[:, :2] - CENTER
    tangent = np.stack([-radial[:, 1], radial[:, 0], np.zeros(15)], axis=1)
    assert _angle_deg(poses.forward, tangent).max() < 1e-9
    np.testing.assert_allclose(poses.up, np.tile([0.0, 0.0, 1.0], (15, 1)), atol=1e-15)


def test_look_at_heading_points_at_the_target():
    target = np.array([0.0, 1.0, 2.0])
    poses = circle(CENTER, n_points=10, heading="look_at", target=target)
    assert _angle_deg(poses.forward, target - poses.positions).max() < 1e-9
    centre = circle(CENTER, n_points=10, heading="center")
    assert _angle_deg(centre.forward, np.array([*CENTER, 5.0]) - centre.positions).max() < 1e-9


def test_fixed_heading_points_along_the_given_yaw():
    poses = circle(CENTER, n_points=5, heading="fixed", yaw_deg=-60.0)
    psi = math.radians(-60.0)
    np.testing.assert_allclose(
        poses.forward, np.tile([math.cos(psi), math.sin(psi), 0.0], (5, 1)), atol=1e-15
    )


def test_line_to_stops_short_of_the_target_and_looks_at_it():
    start, target = np.array([0.0, 0.0, 2.0]), np.array([8.0, 6.0, 3.0])
    poses = line_to(start, target, n_points=10, stop_distance=1.0)
    steps = np.linalg.norm(np.diff(poses.positions, axis=0), axis=1)
    np.testing.assert_allclose(steps, steps[0], rtol=1e-12)
    np.testing.assert_allclose(poses.positions[0], start)
    assert np.linalg.norm(target - poses.positions[-1]) == pytest.approx(1.0, rel=1e-12)
    assert _angle_deg(poses.forward, target - poses.positions).max() < 1e-9


def test_figure_eight_points_lie_on_the_gerono_lemniscate():
    r = 3.1
    poses = figure_eight(CENTER, radius=r, altitude=4.0, n_points=24, start_angle_deg=7.0)
    x, y = (poses.positions[:, :2] - CENTER).T
    np.testing.assert_allclose(y**2, x**2 * (1.0 - x**2 / (4 * r * r)), atol=1e-12)
    np.testing.assert_allclose(poses.forward[:, 2], 0.0, atol=1e-15)


def test_timed_yaw_follows_the_heading_mode():
    t = np.linspace(0.0, 10.0, 37)
    vel = Circle(CENTER, speed=2.0)
    v = vel.velocity(t)
    np.testing.assert_allclose(np.cos(vel.yaw(t)), v[:, 0] / 2.0, atol=1e-12)
    np.testing.assert_allclose(np.sin(vel.yaw(t)), v[:, 1] / 2.0, atol=1e-12)
    look = Circle(CENTER, speed=2.0, heading="center")
    d = np.array([*CENTER]) - look.position(t)[:, :2]
    np.testing.assert_allclose(look.yaw(t), np.arctan2(d[:, 1], d[:, 0]), atol=1e-12)
    fixed = Circle(CENTER, speed=2.0, heading="fixed", yaw_deg=45.0)
    np.testing.assert_allclose(fixed.yaw(t), math.pi / 4)


def test_pulse_times_too_many_for_memory_are_refused_by_name(circle_flight):
    _quad, _traj, flight = circle_flight
    with pytest.raises(MemoryError, match="rate_hz = 1e"):
        flight.pulse_times(1e12)


@pytest.mark.parametrize(
    "call",
    [
        lambda: circle(CENTER, n_points=10**11),
        lambda: line_to([0, 0, 1], [5, 0, 1], n_points=10**11),
        lambda: figure_eight(CENTER, n_points=10**11),
        lambda: Circle(CENTER).times(rate_hz=1e12),
    ],
    ids=["circle", "line_to", "figure_eight", "times"],
)
def test_pulse_counts_too_many_for_memory_are_refused_by_name(call):
    with pytest.raises(MemoryError, match="batecho's memory limit"):
        call()


# ---------------------------------------------------------------- attitude tilts the sonar


def test_flown_circle_banks_the_sonar_toward_the_centre(circle_flight):
    _quad, traj, flight = circle_flight
    t = flight.pulse_times(5.0)
    flown = flight.poses(t)
    level = traj.poses(t)
    bank = math.degrees(math.atan(2.0**2 / (6.2 * G)))  # 3.76 deg
    tilt = _angle_deg(flown.up, level.up)
    assert tilt.min() > bank - 0.5
    inward = np.array([*CENTER, 5.0]) - flown.positions
    inward[:, 2] = 0.0
    assert (np.sum(flown.up * inward, axis=1) > 0).all()


def test_drag_pitches_the_velocity_aligned_beam_down(circle_flight):
    quad, _traj, flight = circle_flight
    fwd = flight.poses(flight.pulse_times(5.0, start=1.0)).forward
    expected = -np.sin(np.arctan(quad.drag[0] * 2.0 / (quad.mass * G)))
    np.testing.assert_allclose(fwd[:, 2], expected, rtol=0.05)


def test_center_looking_flight_points_the_beam_below_the_horizon(center_looking_flight):
    _quad, traj, flight = center_looking_flight
    poses = flight.poses(flight.pulse_times(10.0))
    bank = math.atan(2.0**2 / (6.2 * G))
    np.testing.assert_allclose(poses.forward[:, 2], -math.sin(bank), rtol=0.05)
    level = traj.poses(flight.pulse_times(10.0))
    np.testing.assert_allclose(level.forward[:, 2], 0.0, atol=1e-15)


def test_mount_pitch_minus_10_deg_tilts_the_beam_10_deg_down_at_hover():
    quad = Quadrotor.crazyflie()
    flight = quad.fly(Hover((0.0, 0.0, 1.0), yaw_deg=90.0), 0.5)
    poses = flight.poses(flight.pulse_times(20.0), mount=SonarMount(pitch_deg=-10.0))
    elevation = np.degrees(np.arcsin(poses.forward[:, 2]))
    np.testing.assert_allclose(elevation, -10.0, atol=1e-9)
    np.testing.assert_allclose(
        poses.forward[:, :2] / math.cos(math.radians(10.0)),
        np.tile([0.0, 1.0], (len(poses), 1)),
        atol=1e-9,
    )


def test_mount_offset_rotates_with_the_body():
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # yaw 90 deg
    poses = SonarMount(offset=(0.1, 0.0, -0.02), yaw_deg=90.0).pose([1.0, 2.0, 3.0], R)
    np.testing.assert_allclose(poses.positions[0], [1.0, 2.1, 2.98], atol=1e-15)
    np.testing.assert_allclose(poses.forward[0], [-1.0, 0.0, 0.0], atol=1e-15)


def test_flight_poses_at_sample_times_reproduce_the_recorded_states(circle_flight):
    _quad, _traj, flight = circle_flight
    idx = np.arange(0, len(flight), 997)
    poses = flight.poses(flight.times[idx])
    np.testing.assert_allclose(poses.positions, flight.positions[idx], atol=1e-12)
    np.testing.assert_allclose(poses.rotations, flight.attitudes[idx], atol=1e-9)


def test_pulse_times_are_evenly_spaced_at_the_rate(circle_flight):
    _quad, _traj, flight = circle_flight
    t = flight.pulse_times(40.0)
    np.testing.assert_allclose(np.diff(t), 1.0 / 40.0, rtol=1e-9)
    assert t[0] == flight.times[0] and t[-1] <= flight.times[-1] < t[-1] + 1.0 / 40.0


# ----------------------------------------------------------------- timed trajectories

TIMED = {
    "circle": Circle(CENTER, radius=6.2, altitude=5.0, speed=2.0),
    "circle_cw": Circle(CENTER, radius=2.0, altitude=3.0, speed=1.5, clockwise=True),
    "line": Line([0.0, 0.0, 1.0], [10.0, 4.0, 3.0], speed=2.0),
    "figure_eight": FigureEight(CENTER, radius=3.1, altitude=5.0, period=20.0),
    "waypoints": Waypoints([[0, 0, 1], [3, 0, 1.5], [3, 3, 2], [0, 4, 1]], speed=2.0),
    "closed": Waypoints([[0, 0, 1], [3, 0, 1.5], [3, 3, 2], [0, 4, 1]], speed=2.0, closed=True),
}


@pytest.mark.parametrize("name", sorted(TIMED))
@settings(max_examples=40, deadline=None)
@given(frac=st.floats(0.001, 0.999))
def test_timed_derivatives_match_finite_differences_of_position(name, frac):
    traj = TIMED[name]
    t, h = frac * traj.duration, 1e-4
    for lower, upper in [
        ("position", "velocity"),
        ("velocity", "acceleration"),
        ("acceleration", "jerk"),
    ]:
        f = getattr(traj, lower)
        fd = (f(t + h) - f(t - h)) / (2 * h)
        exact = getattr(traj, upper)(t)
        np.testing.assert_allclose(
            fd,
            exact,
            atol=1e-5 * (1 + np.abs(exact).max()),
            err_msg=f"{name}: d/dt {lower} != {upper} at t={t}",
        )


@pytest.mark.parametrize("name", sorted(TIMED))
def test_timed_derivatives_are_vectorised_over_time(name):
    traj = TIMED[name]
    t = np.linspace(0.0, traj.duration, 7)
    for method in ("position", "velocity", "acceleration", "jerk", "snap"):
        arr = getattr(traj, method)(t)
        assert arr.shape == (7, 3)
        np.testing.assert_array_equal(arr[3], getattr(traj, method)(float(t[3])))


def test_circle_moves_at_its_speed_on_its_radius():
    traj = TIMED["circle"]
    t = np.linspace(0.0, traj.duration, 50)
    np.testing.assert_allclose(np.linalg.norm(traj.velocity(t), axis=1), 2.0)
    np.testing.assert_allclose(np.linalg.norm(traj.acceleration(t), axis=1), 4.0 / 6.2)
    np.testing.assert_allclose(traj.position(traj.duration), traj.position(0.0), atol=1e-12)


def test_line_starts_and_ends_at_rest_with_bounded_acceleration():
    traj = TIMED["line"]
    t = np.linspace(-1.0, traj.duration + 1.0, 4001)
    np.testing.assert_allclose(traj.position(traj.duration), [10.0, 4.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(traj.velocity(np.array([0.0, traj.duration])), 0.0, atol=1e-12)
    assert np.linalg.norm(traj.velocity(t), axis=1).max() == pytest.approx(2.0)
    assert np.linalg.norm(traj.acceleration(t), axis=1).max() <= 1.0 + 1e-9


def test_a_line_too_short_for_its_speed_keeps_the_default_1_m_s2_peak_acceleration():
    traj = Line([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], speed=100.0)
    t = np.linspace(0.0, traj.duration, 4001)
    assert np.linalg.norm(traj.acceleration(t), axis=1).max() == pytest.approx(1.0, rel=1e-3)
    np.testing.assert_allclose(traj.position(traj.duration), [1.0, 0.0, 1.0], atol=1e-12)


def test_a_look_at_line_keeps_its_heading_on_arrival_at_the_target():
    traj = Line([0.0, 0.0, 1.0], [3.0, 3.0, 1.0], heading="look_at")
    t = np.array([0.0, traj.duration, traj.duration + 1.0])
    np.testing.assert_allclose(traj.yaw(t), math.pi / 4, atol=1e-12)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Line([-1e300, 0.0, 0.0], [1e300, 0.0, 0.0]),
        lambda: Waypoints([[0.0, 0.0, 0.0], [1e300, 0.0, 0.0], [0.0, 1e300, 0.0]]),
    ],
    ids=["line", "waypoints"],
)
def test_points_whose_distance_overflows_float64_are_refused_by_name(make):
    # (a Line called itself vertical, Waypoints raised scipy's "must not contain infs")
    with pytest.raises(ValueError, match="too far apart"):
        make()


@pytest.mark.parametrize(
    "radius, speed", [(6.2, 1e300), (1e300, 1e-300)], ids=["overflows", "underflows"]
)
def test_a_circle_whose_angular_rate_cannot_be_flown_in_float64_is_refused_by_name(radius, speed):
    # (speed/radius underflowing raised ZeroDivisionError; its snap overflowing, OverflowError
    # in fly)
    with pytest.raises(ValueError, match="speed / radius"):
        Circle((0.0, 0.0), radius=radius, speed=speed)


@pytest.mark.parametrize("closed", [False, True], ids=["open", "closed"])
@pytest.mark.parametrize("speed", [1e300, 1e-300], ids=["overflows", "underflows"])
def test_waypoints_whose_speed_cannot_be_flown_in_float64_are_refused_by_name(speed, closed):
    # (scipy's "must not contain infs or NaNs", or LinAlgError "Colocation matrix is singular")
    points = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 1.0, 1.0]]
    shown = re.escape(f"speed={speed:g} m/s")
    with pytest.raises(ValueError, match=f"{shown} over waypoints .* too small or large"):
        Waypoints(points, speed=speed, closed=closed)


def test_waypoints_too_close_for_float64_at_their_coordinates_are_refused_by_name():
    # (1e-20 m steps at z = 1 m: the fit's rounding set the speed, and the duration came out
    # 5e4 times too long, silently)
    points = [[0.0, 0.0, 1.0], [1e-20, 0.0, 1.0], [1e-20, 1e-20, 1.0]]
    with pytest.raises(ValueError, match="waypoints 0 and 1 are 1e-20 m apart, below 1e-12"):
        Waypoints(points)


def test_a_step_too_short_for_the_paths_length_is_refused_by_name():
    # (SciPy's "Expect x to not have duplicates": the step was lost in the sum of the others)
    square = [[0, 0, 1], [4, 0, 1], [4, 4, 1], [0, 4, 1.0], [1e-15, 0.0, 1.0]]
    with pytest.raises(ValueError, match="waypoints 4 and 5 are 1e-15 m apart"):
        Waypoints(square, closed=True)


def test_waypoints_pass_through_the_points_at_peak_speed():
    traj = TIMED["waypoints"]
    np.testing.assert_allclose(traj.position(traj.knot_times), traj.points, atol=1e-9)
    t = np.linspace(0.0, traj.duration, 4001)
    assert np.linalg.norm(traj.velocity(t), axis=1).max() == pytest.approx(2.0, rel=1e-3)


@pytest.mark.parametrize(
    "origin, gap", [((0.0, 0.0, 0.0), 1e-9), ((5e5, 4e6, 0.0), 3.0)], ids=["near", "utm"]
)
def test_a_closed_path_ending_near_its_first_point_is_continuous_where_it_repeats(origin, gap):
    square = np.array([[0, 0, 1], [4, 0, 1], [4, 4, 1], [0, 4, 1.0]]) + origin
    traj = Waypoints(np.vstack([square, square[:1] + [gap, 0.0, 0.0]]), closed=True)
    T = traj.duration
    np.testing.assert_allclose(traj.position(T - 1e-9), traj.position(T + 1e-9), atol=1e-6)
    np.testing.assert_allclose(
        traj.position(traj.knot_times[-2]), square[0] + [gap, 0, 0], rtol=0, atol=1e-6
    )


# ---------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: Quadrotor.crazyflie().fly(Hover(), 1.0, dt=0.0), "dt"),
        (lambda: Quadrotor.crazyflie().fly(Hover(), 1.0, dt=-1e-3), "dt"),
        (lambda: Quadrotor.crazyflie().fly(Hover(), 0.0), "duration"),
        (lambda: Quadrotor.crazyflie().fly(Hover(), -2.0), "duration"),
        (lambda: Circle(CENTER, speed=0.0), "speed"),
        (lambda: Line([0, 0, 1], [1, 0, 1], speed=-1.0), "speed"),
        (lambda: Waypoints([[0, 0, 1], [1, 0, 1]], speed=0.0), "speed"),
        (lambda: FigureEight(CENTER, speed=0.0), "speed"),
        (lambda: Circle(CENTER, radius=0.0), "radius"),
        (lambda: circle(CENTER, radius=-6.2), "radius"),
        (lambda: figure_eight(CENTER, radius=0.0), "radius"),
        (lambda: circle([np.nan, 0.0]), "center"),
        (lambda: Circle([0.0, np.nan, 5.0]), "center"),
        (lambda: circle(CENTER, n_points=0), "n_points"),
        (lambda: circle(CENTER, heading="sideways"), "heading"),
        (lambda: circle(CENTER, heading="fixed"), "yaw_deg"),
        (lambda: line_to([0, 0, 1], [0.5, 0, 1], stop_distance=1.0), "stop_distance"),
        (lambda: Waypoints([[0, 0, 1], [0, 0, 1]]), "coincide"),
        (lambda: Line([0, 0, 1], [0, 0, 5], heading="look_at"), "target"),
        (lambda: Quadrotor.crazyflie(mass=-1.0), "mass"),
        (lambda: SE3Gains(1.0, 1.0, 0.0, 1.0), "k_R"),
        (lambda: Quadrotor.crazyflie(omega_max=100.0), "hover"),
    ],
)
def test_bad_input_raises_value_error_naming_the_problem(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_pulse_times_outside_the_flight_are_rejected():
    flight = Quadrotor.crazyflie().fly(Hover(), 0.1)
    with pytest.raises(ValueError, match="within the flight"):
        flight.poses([0.05, 0.2])


@pytest.mark.parametrize(
    "kwargs, word",
    [({"ramp_time": 1e-300}, "ramp_time"), ({"speed": 1e-300}, "default ramp")],
    ids=["ramp_time", "default-ramp"],
)
def test_a_line_whose_speed_ramp_is_too_short_for_float64_is_refused_by_name(kwargs, word):
    # (it was taken, and its snap, or Quadrotor.fly, raised OverflowError (34, 'Numerical
    # result out of range'))
    with pytest.raises(ValueError, match=word):
        Line([0.0, 0.0, 1.0], [1.0, 0.0, 1.0], **kwargs)


@pytest.mark.parametrize(
    "kwargs",
    [{"period": 1e-300}, {"speed": 1e300}, {"speed": 1e-310}],
    ids=["short-period", "fast", "slow"],
)
def test_a_figure_eight_whose_period_cannot_be_flown_in_float64_is_refused_by_name(kwargs):
    # (a short period was taken and its snap raised OverflowError (34, 'Numerical result out
    # of range'); a tiny speed was refused as "period must be finite and > 0, got inf")
    with pytest.raises(ValueError, match=r"the period .* too short or long for float64"):
        FigureEight((0.0, 0.0), **kwargs)
