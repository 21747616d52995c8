"""The Rust flight integrator against the NumPy one it replaces (``method="python"``), and the
step-by-step, many-drone :class:`batecho.flight.QuadrotorSim`."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from batecho.flight import (
    Circle,
    Cruise,
    Gusts,
    Hover,
    Quadrotor,
    QuadrotorSim,
    QuadState,
    Waypoints,
)

G = 9.81
CENTER = np.array([1.5, -2.0])
AIRFRAMES = {"crazyflie": Quadrotor.crazyflie, "research": Quadrotor.research}
#: The agreement the Rust integrator keeps with the NumPy one over a flight (state entries in
#: SI units; rotor speeds relative to their size).
TOL = 1e-9


def _assert_same_flight(a, b, tol=TOL):
    for name in ("positions", "velocities", "attitudes", "angular_velocities"):
        np.testing.assert_allclose(
            getattr(a, name), getattr(b, name), rtol=0, atol=tol, err_msg=name
        )
    np.testing.assert_allclose(a.rotor_speeds, b.rotor_speeds, rtol=tol, atol=0)
    np.testing.assert_array_equal(a.times, b.times)


@pytest.fixture(scope="module")
def lap():
    """One 19.5 s lap of the paper's circle by the crazyflie, in gusts, both integrators."""
    quad = Quadrotor.crazyflie()
    traj = Circle(CENTER, radius=6.2, altitude=5.0, speed=2.0)
    fly = {
        m: quad.fly(traj, traj.duration, dt=1e-3, gusts=Gusts(std=0.5), rng=3, method=m)
        for m in ("rust", "python")
    }
    return traj, fly


def test_rust_flies_a_gusty_lap_within_1e_9_of_the_python_integrator(lap):
    traj, fly = lap
    assert fly["rust"].times[-1] == pytest.approx(traj.duration)
    assert traj.duration > 19.0
    _assert_same_flight(fly["rust"], fly["python"])


@pytest.mark.parametrize("method", ["rust", "python"])
def test_both_integrators_track_the_circle_within_10cm(lap, method):
    _traj, fly = lap
    assert fly[method].position_error.max() < 0.10


@pytest.mark.parametrize("method", ["rust", "python"])
@pytest.mark.parametrize("name", sorted(AIRFRAMES))
def test_both_integrators_hover_on_thrust_mg(name, method):
    quad = AIRFRAMES[name]()
    flight = quad.fly(Hover((0.0, 0.0, 1.0), yaw_deg=30.0), 1.0, method=method)
    assert flight.position_error.max() < 1e-3
    np.testing.assert_allclose(flight.thrust, quad.mass * G, rtol=1e-9)


@settings(max_examples=12, deadline=None)
@given(
    name=st.sampled_from(sorted(AIRFRAMES)),
    seed=st.integers(0, 2**31 - 1),
    offset=st.tuples(*[st.floats(-0.5, 0.5)] * 3),
    tilt=st.floats(-0.6, 0.6),
    rates=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
    plus=st.booleans(),
)
def test_rust_matches_python_from_disturbed_starts_in_gusts(name, seed, offset, tilt, rates, plus):
    """Hard cases: off the reference, tilted, spinning, rotors saturating, X or + frame."""
    quad = AIRFRAMES[name](configuration="+" if plus else "x")
    traj = Waypoints([[0, 0, 1], [1.5, 0.5, 1.5], [3, -1, 1]], speed=2.5)
    s = quad.initial_state(traj)
    c, sn = math.cos(tilt), math.sin(tilt)
    start = QuadState(
        s.position + offset,
        s.velocity,
        np.array([[1, 0, 0], [0, c, -sn], [0, sn, c]]) @ s.rotation,
        rates,
        s.rotor_speeds * 0.7,
    )
    kw = dict(initial_state=start, gusts=Gusts(std=1.5, correlation_time=0.3), rng=seed)
    a = quad.fly(traj, 0.4, dt=2e-3, method="rust", **kw)
    b = quad.fly(traj, 0.4, dt=2e-3, method="python", **kw)
    _assert_same_flight(a, b)


def test_an_unknown_method_is_refused_by_name():
    with pytest.raises(ValueError, match="method"):
        Quadrotor.crazyflie().fly(Hover(), 0.1, method="rk4")


@pytest.mark.parametrize("method", ["rust", "python"])
def test_a_dt_equal_to_the_motor_time_constant_flies_as_promised(method):
    quad = Quadrotor.crazyflie()
    flight = quad.fly(Hover((0.0, 0.0, 1.0)), 0.3, dt=quad.motor_time_constant, method=method)
    # the grid of every dt: k dt, whose steps rounding makes up to an ulp of t longer
    np.testing.assert_array_equal(flight.times, np.minimum(np.arange(21) * 0.015, 0.3))


def test_a_flight_records_every_dt_and_ends_at_its_duration():
    flight = Quadrotor.crazyflie().fly(Hover((0.0, 0.0, 1.0)), 5.0, dt=1e-3)
    np.testing.assert_array_equal(flight.times, np.minimum(np.arange(5001) * 1e-3, 5.0))
    assert flight.times[-1] == 5.0


@pytest.mark.parametrize("method", ["rust", "python"])
def test_a_duration_far_below_dt_flies_one_step_of_that_duration(method):
    flight = Quadrotor.crazyflie().fly(Hover((0.0, 0.0, 1.0)), 1e-15, dt=1e-3, method=method)
    np.testing.assert_array_equal(flight.times, [0.0, 1e-15])


# ------------------------------------------------------------------------- step by step


def _heading(R):
    """The controller's yaw of an attitude: the horizontal direction in the body x-z plane."""
    b1, b3 = R[:, 0], R[:, 2]
    h = b3[2] * b1 - b1[2] * b3
    return math.atan2(h[1], h[0])


@settings(max_examples=10, deadline=None)
@given(
    velocity=st.tuples(st.floats(-2, 2), st.floats(-2, 2), st.floats(-0.5, 0.5)),
    yaw_rate=st.floats(-1.5, 1.5),
    tilt=st.floats(-0.3, 0.3),
    n_steps=st.integers(1, 80),
)
def test_a_velocity_command_flies_as_python_flies_its_cruise_reference(
    velocity, yaw_rate, tilt, n_steps
):
    quad = Quadrotor.crazyflie()
    s = quad.initial_state(Hover((1.0, -2.0, 1.5), yaw_deg=40.0))
    c, sn = math.cos(tilt), math.sin(tilt)
    start = QuadState(
        s.position,
        [0.3, 0.1, 0.0],
        np.array([[c, 0, sn], [0, 1, 0], [-sn, 0, c]]) @ s.rotation,
        [0.2, -0.1, 0.4],
        s.rotor_speeds,
    )
    sim = QuadrotorSim(quad, start)
    out = sim.step(velocity, yaw_rate, dt=1e-3, n_steps=n_steps)
    ref = Cruise(
        start.position,
        velocity,
        yaw_deg=math.degrees(_heading(start.rotation)),
        yaw_rate_deg_s=math.degrees(yaw_rate),
    )
    py = quad.fly(ref, n_steps * 1e-3, dt=1e-3, initial_state=start, method="python")
    rigid = [py.positions, py.velocities, py.attitudes.reshape(-1, 9), py.angular_velocities]
    np.testing.assert_allclose(out.vectors[0, :18], np.hstack(rigid)[-1], rtol=0, atol=TOL)
    np.testing.assert_allclose(out.rotor_speeds[0], py.rotor_speeds[-1], rtol=TOL)
    np.testing.assert_allclose(sim.path[0], py.positions[1:], rtol=0, atol=TOL)
    assert out.time == pytest.approx(n_steps * 1e-3)


def test_held_commands_reach_the_commanded_velocity():
    quad = Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))))
    for _ in range(40):
        state = sim.step([1.5, -0.5, 0.0], 0.0, dt=1e-3, n_steps=50)
    np.testing.assert_allclose(state.velocities[0], [1.5, -0.5, 0.0], atol=1e-3)
    assert sim.time == pytest.approx(2.0)


def test_each_drone_of_a_batch_flies_as_it_would_alone():
    quad = Quadrotor.research()
    starts = [quad.initial_state(Hover((i, 0.0, 2.0), yaw_deg=10.0 * i)) for i in range(6)]
    vel = np.array([[0.5 * i, 1.0, 0.1 * i] for i in range(6)])
    rates = np.linspace(-1, 1, 6)
    wind = np.array([[0.0, 0.3 * i, 0.0] for i in range(6)])
    batch = QuadrotorSim(quad, starts)
    out = batch.step(vel, rates, dt=2e-3, n_steps=25, wind=wind)
    for i in range(6):
        alone = QuadrotorSim(quad, starts[i])
        one = alone.step(vel[i], rates[i], dt=2e-3, n_steps=25, wind=wind[i])
        assert one.vectors[0].tobytes() == out.vectors[i].tobytes()
        assert alone.path[0].tobytes() == batch.path[i].tobytes()


def test_one_state_starts_every_drone_and_reset_moves_them():
    quad = Quadrotor.crazyflie()
    s = quad.initial_state(Hover((0, 0, 1)))
    sim = QuadrotorSim(quad, s, n_drones=4)
    assert sim.n_drones == 4
    np.testing.assert_array_equal(sim.state.positions, np.tile([0.0, 0.0, 1.0], (4, 1)))
    sim.step([1, 0, 0], n_steps=10)
    state = sim.reset([s, quad.initial_state(Hover((5, 5, 2)))])
    assert len(state) == 2 and sim.time == 0.0
    np.testing.assert_array_equal(state.positions[1], [5.0, 5.0, 2.0])
    assert isinstance(state.state(1), QuadState)


def test_the_caller_s_arrays_are_not_modified_and_states_are_read_only():
    quad = Quadrotor.crazyflie()
    rows = np.tile(quad.initial_state(Hover((0, 0, 1))).vector(), (2, 1))
    before = rows.copy()
    vel = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    sim = QuadrotorSim(quad, rows)
    state = sim.step(vel, dt=1e-3, n_steps=5)
    np.testing.assert_array_equal(rows, before)
    np.testing.assert_array_equal(vel, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError):
        state.vectors[0, 0] = 1.0


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda sim: sim.step([np.nan, 0, 0]), "velocity"),
        (lambda sim: sim.step([[1, 0, 0]] * 3), "velocity"),
        (lambda sim: sim.step([1, 0, 0], [0.1, 0.2, 0.3]), "yaw_rate"),
        (lambda sim: sim.step([1, 0, 0], dt=0.0), "dt"),
        (lambda sim: sim.step([1, 0, 0], dt=0.05), "motor time constant"),
        (lambda sim: sim.step([1, 0, 0], n_steps=0), "n_steps"),
        (lambda sim: sim.step([1, 0, 0], n_steps=2.5), "n_steps"),
        (lambda sim: sim.step([1, 0, 0], wind=[0, np.inf, 0]), "wind"),
        (lambda sim: sim.reset(np.zeros((2, 21))), "22"),
        (lambda sim: sim.reset(np.zeros((2, 22))), "rotation"),
        (lambda sim: sim.reset(sim.state.vectors, time=np.nan), "time"),
    ],
)
def test_bad_commands_raise_value_error_naming_the_problem(call, match):
    quad = Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))), n_drones=2)
    before = sim.state.vectors.copy()
    with pytest.raises(ValueError, match=match):
        call(sim)
    np.testing.assert_array_equal(sim.state.vectors, before)


def test_a_step_dt_beyond_the_motor_time_constant_is_named_in_a_few_digits():
    # (the core's message wrote dt = 1e300 out in 301 digits)
    quad = Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))))
    with pytest.raises(ValueError, match=r"dt=1e\+300 s exceeds the motor time constant") as e:
        sim.step([0.0, 0.0, 0.0], dt=1e300)
    assert len(str(e.value)) < 200


def test_a_step_whose_path_cannot_fit_in_memory_is_refused_before_it_starts():
    quad = Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))))
    before = sim.state.vectors.copy()
    with pytest.raises(MemoryError, match="n_steps = 1000000000000"):
        sim.step([0.0, 0.0, 0.0], n_steps=10**12)
    np.testing.assert_array_equal(sim.state.vectors, before)


def test_a_simulation_of_too_many_drones_for_memory_is_refused_by_name():
    quad = Quadrotor.crazyflie()
    with pytest.raises(MemoryError, match="n_drones = 100000000"):
        QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))), n_drones=10**8)


def test_n_drones_that_disagrees_with_the_states_given_is_refused():
    quad = Quadrotor.crazyflie()
    states = [quad.initial_state(Hover((i, 0, 1))) for i in range(3)]
    with pytest.raises(ValueError, match="n_drones"):
        QuadrotorSim(quad, states, n_drones=5)


def test_a_fractional_number_of_drones_is_refused():
    quad = Quadrotor.crazyflie()
    with pytest.raises(ValueError, match="n_drones"):
        QuadrotorSim(quad, quad.initial_state(Hover((0, 0, 1))), n_drones=2.5)


SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    from batecho.flight import Hover, Quadrotor, QuadrotorSim
    quad = Quadrotor.crazyflie()
    sim = QuadrotorSim(quad, [quad.initial_state(Hover((i, 0, 1))) for i in range(16)])
    rng = np.random.default_rng(0)
    for _ in range(5):
        sim.step(rng.uniform(-2, 2, (16, 3)), rng.uniform(-1, 1, 16), n_steps=20,
                 wind=rng.normal(size=(16, 3)))
    np.save(sys.argv[1], np.concatenate([sim.state.vectors.ravel(), sim.path.ravel()]))
    """
)


def test_a_batch_is_bit_identical_with_one_and_two_threads(tmp_path):
    out = []
    for threads in (1, 2):
        path = tmp_path / f"{threads}.npy"
        env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
        subprocess.run([sys.executable, "-c", SCRIPT, str(path)], env=env, check=True)
        out.append(np.load(path))
    assert out[0].tobytes() == out[1].tobytes()
