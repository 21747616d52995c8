"""The flight integrator against an independent solution of docs/model.md §8: the same
zero-order-hold closed loop written here from the documented equations (attitude as a unit
quaternion, the mixer from the rotor positions, Lee et al.'s controller, the feed-forward body
rates by finite differences) and integrated between controller samples by
``scipy.integrate.solve_ivp`` (DOP853, rtol = atol = 1e-12); and two exact motions (free fall,
trimmed hover).

The library's RK4 shares nothing with this file but the airframe's parameters, the reference's
position, velocity, acceleration and yaw, and the starting state. At dt = 1 ms the largest
differences from the exact solution were 5e-10 m in position, 1.3e-9 m/s in velocity, 2.3e-9
in the rotation matrix, 2.4e-8 rad/s in angular velocity (just after a disturbed start) and
3e-9 relative in rotor speeds; the tolerances (TOL) are two to four times these. The error
falls 16-fold when dt halves (fourth order)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from batecho import _core
from batecho.flight import (
    Circle,
    FigureEight,
    Hover,
    Line,
    Quadrotor,
    QuadrotorSim,
    QuadState,
    Waypoints,
)
from batecho.flight.controller import flat_reference

E3 = np.array([0.0, 0.0, 1.0])

#: Tolerances of the RK4 at dt = 1 ms against the exact zero-order-hold solution: position
#: (m), velocity (m/s), rotation matrix entries, angular velocity (rad/s), rotor speeds
#: (relative).
TOL = {"p": 2e-9, "v": 5e-9, "R": 1e-8, "W": 1e-7, "w": 1e-8}


# ------------------------------------------------------------- the independent closed loop


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (w, x, y, z)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q[1], q[2], q[3], q[0]
    return Rotation.from_quat([x, y, z, w]).as_matrix()


def matrix_to_quat(R: np.ndarray) -> np.ndarray:
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


class ExactLoop:
    """docs/model.md §8 for one airframe: the rigid body, rotors, mixer and controller, held
    constant over each step of dt and integrated exactly (to 1e-12) in between."""

    def __init__(self, quad: Quadrotor):
        self.m, self.J, self.g = quad.mass, np.asarray(quad.inertia), quad.gravity
        self.k_f, self.tau = quad.k_f, quad.motor_time_constant
        self.w_lo, self.w_hi = quad.omega_min, quad.omega_max
        self.D, self.drag_ff = np.asarray(quad.drag), quad.drag_feedforward
        gains = quad.gains
        self.k_x, self.k_v = np.asarray(gains.k_x), np.asarray(gains.k_v)
        self.k_R, self.k_W = np.asarray(gains.k_R), np.asarray(gains.k_Omega)
        # rotor i at 45 + 90 i deg (X) or 90 i deg (+) from body x, spinning s_i
        deg = [45.0, 135.0, 225.0, 315.0] if quad.configuration == "x" else [0, 90, 180, 270]
        ang = np.radians(deg)
        arms = quad.arm_length * np.column_stack([np.cos(ang), np.sin(ang), np.zeros(4)])
        spin = np.array([1.0, -1.0, 1.0, -1.0])
        # (f, M) per newton of each rotor's thrust: its lift, its lever arm, its drag torque
        self.wrench = np.vstack(
            [np.ones(4), np.array([np.cross(r, E3) for r in arms]).T]
        ) + np.outer([0, 0, 0, 1], spin * quad.k_m / quad.k_f)

    def rhs(self, y: np.ndarray, w_cmd: np.ndarray, wind: np.ndarray) -> np.ndarray:
        """y = (p, v, q, W, w): 17 numbers."""
        v, q, W, w = y[3:6], y[6:10], y[10:13], y[13:17]
        R = quat_to_matrix(q / np.linalg.norm(q))
        f, *M = self.wrench @ (self.k_f * w * w)
        dv = (-self.m * self.g * E3 + f * R[:, 2] - R @ (self.D * (R.T @ (v - wind)))) / self.m
        dq = 0.5 * qmul(q, np.r_[0.0, W])
        dW = (np.asarray(M) - np.cross(W, self.J * W)) / self.J
        return np.concatenate([v, dv, dq, dW, (w_cmd - w) / self.tau])

    def rotor_command(self, y: np.ndarray, ref: dict) -> np.ndarray:
        """Lee, Leok & McClamroch (2010), z up: thrust and moments, then rotor speeds."""
        p, v, W = y[0:3], y[3:6], y[10:13]
        R = quat_to_matrix(y[6:10] / np.linalg.norm(y[6:10]))
        F = (
            -self.k_x * (p - ref["p"])
            - self.k_v * (v - ref["v"])
            + self.m * (ref["a"] + self.g * E3)
        )
        if self.drag_ff:
            F = F + R @ (self.D * (R.T @ ref["v"]))
        b3 = F / np.linalg.norm(F)
        b2 = np.cross(b3, [math.cos(ref["yaw"]), math.sin(ref["yaw"]), 0.0])
        b2 /= np.linalg.norm(b2)
        Rd = np.column_stack([np.cross(b2, b3), b2, b3])
        E = Rd.T @ R - R.T @ Rd
        e_R = 0.5 * np.array([E[2, 1], E[0, 2], E[1, 0]])
        W_d = R.T @ Rd @ ref["W"]
        M = (
            -self.k_R * e_R
            - self.k_W * (W - W_d)
            + np.cross(W, self.J * W)
            - self.J * (np.cross(W, W_d) - R.T @ Rd @ ref["dW"])
        )
        thrusts = np.linalg.solve(self.wrench, np.r_[F @ R[:, 2], M])
        thrusts = np.clip(thrusts, self.k_f * self.w_lo**2, self.k_f * self.w_hi**2)
        return np.sqrt(thrusts / self.k_f)

    def fly(self, start: np.ndarray, refs, dt: float, n: int, wind=(0.0, 0.0, 0.0)) -> np.ndarray:
        """(n + 1, 22) states (QuadState.vector's layout) every dt from ``start`` (22,)."""
        y = np.concatenate([start[0:6], matrix_to_quat(start[6:15].reshape(3, 3)), start[15:]])
        wind = np.asarray(wind, dtype=float)
        out = [start]
        for k in range(n):
            w_cmd = self.rotor_command(y, refs(k))
            y = solve_ivp(
                lambda _t, yy, w_cmd=w_cmd: self.rhs(yy, w_cmd, wind),
                (0.0, dt),
                y,
                method="DOP853",
                rtol=1e-12,
                atol=1e-12,
            ).y[:, -1]
            R = quat_to_matrix(y[6:10] / np.linalg.norm(y[6:10]))
            out.append(np.concatenate([y[0:6], R.ravel(), y[10:17]]))
        return np.array(out)


def nominal_attitude(acceleration: np.ndarray, yaw: float, g: float) -> np.ndarray:
    """The flat attitude: body z along a + g e3, body x toward the yaw in the plane."""
    b3 = acceleration + g * E3
    b3 = b3 / np.linalg.norm(b3)
    b2 = np.cross(b3, [math.cos(yaw), math.sin(yaw), 0.0])
    b2 /= np.linalg.norm(b2)
    return np.column_stack([np.cross(b2, b3), b2, b3])


def five_point(f, t: float, h: float):
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


def feedforward(traj, g: float, h: float = 2e-3):
    """The flat attitude's body rate and its rate at t, by finite differences."""

    def R(t):
        return nominal_attitude(traj.acceleration(t), float(traj.yaw(t)), g)

    def W(t):
        S = R(t).T @ five_point(R, t, h)
        return 0.5 * np.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])

    return W, lambda t: five_point(W, t, h)


def trajectory_refs(traj, g: float, dt: float):
    W, dW = feedforward(traj, g)

    def refs(k):
        t = k * dt
        p, v, a = traj.position(t), traj.velocity(t), traj.acceleration(t)
        return {"p": p, "v": v, "a": a, "yaw": float(traj.yaw(t)), "W": W(t), "dW": dW(t)}

    return refs


def heading(R: np.ndarray) -> float:
    """The yaw a velocity command starts from (docs/model.md §8): of b3_z b1 - b1_z b3."""
    h = R[2, 2] * R[:, 0] - R[2, 0] * R[:, 2]
    return math.atan2(h[1], h[0])


def cruise_refs(start: QuadState, velocity, yaw_rate: float, dt: float):
    """A held velocity-and-yaw-rate command: level, body rate (0, 0, r), no acceleration."""
    p0, v, psi0 = np.asarray(start.position), np.asarray(velocity, float), heading(start.rotation)

    def refs(k):
        s = k * dt
        return {
            "p": p0 + v * s,
            "v": v,
            "a": np.zeros(3),
            "yaw": psi0 + yaw_rate * s,
            "W": np.array([0.0, 0.0, yaw_rate]),
            "dW": np.zeros(3),
        }

    return refs


def disturbed_start(quad: Quadrotor) -> QuadState:
    """Hovering at 40 deg yaw, then pitched 0.2 rad, moving and spinning."""
    s = quad.initial_state(Hover((1.0, -2.0, 1.5), yaw_deg=40.0))
    c, sn = math.cos(0.2), math.sin(0.2)
    tilt = np.array([[c, 0.0, sn], [0.0, 1.0, 0.0], [-sn, 0.0, c]])
    return QuadState(
        s.position, [0.3, 0.1, 0.0], tilt @ s.rotation, [0.2, -0.1, 0.4], s.rotor_speeds
    )


def fly_command(quad: Quadrotor, start: QuadState, dt: float, duration: float, wind):
    """The library's and the exact states (n + 1, 22) of a held velocity command."""
    velocity, yaw_rate, n = [1.5, -0.5, 0.3], 0.8, round(duration / dt)
    sim = QuadrotorSim(quad, start)
    sim.step(velocity, yaw_rate, dt=dt, n_steps=n, wind=wind)
    exact = ExactLoop(quad).fly(
        start.vector(), cruise_refs(start, velocity, yaw_rate, dt), dt, n, wind
    )
    return sim, exact


def assert_within(got: np.ndarray, exact: np.ndarray, tol: dict) -> None:
    """Compare (k, 22) states part by part."""
    parts = {"p": (0, 3), "v": (3, 6), "R": (6, 15), "W": (15, 18)}
    for name, (a, b) in parts.items():
        err = np.abs(got[:, a:b] - exact[:, a:b]).max()
        assert err <= tol[name], f"{name}: {err:.3g} > {tol[name]:.3g}"
    err = np.abs(got[:, 18:] / exact[:, 18:] - 1.0).max()
    assert err <= tol["w"], f"rotor speeds: {err:.3g} > {tol['w']:.3g}"


# --------------------------------------------------------------------------------- tests


def test_a_velocity_command_in_wind_flies_as_the_exact_zero_order_hold_loop():
    quad = Quadrotor.crazyflie()
    sim, exact = fly_command(quad, disturbed_start(quad), 1e-3, 0.3, [1.0, -0.5, 0.2])
    np.testing.assert_allclose(sim.path[0], exact[1:, 0:3], rtol=0, atol=TOL["p"])
    assert_within(sim.state.vectors, exact[-1:], TOL)


@pytest.mark.parametrize(
    ("airframe", "traj"),
    [
        ("crazyflie", Circle((1.5, -2.0), radius=2.0, altitude=3.0, speed=2.0)),
        ("research_plus", FigureEight((0.0, 0.0), radius=2.0, altitude=3.0, period=8.0)),
    ],
)
def test_a_flown_trajectory_is_the_exact_zero_order_hold_loop_at_every_sample(airframe, traj):
    quad = (
        Quadrotor.crazyflie() if airframe == "crazyflie" else Quadrotor.research(configuration="+")
    )
    dt, n = 1e-3, 400
    flight = quad.fly(traj, n * dt, dt=dt)
    got = np.column_stack(
        [
            flight.positions,
            flight.velocities,
            flight.attitudes.reshape(-1, 9),
            flight.angular_velocities,
            flight.rotor_speeds,
        ]
    )
    exact = ExactLoop(quad).fly(got[0], trajectory_refs(traj, quad.gravity, dt), dt, n)
    assert_within(got, exact, TOL)


def test_the_rk4_error_falls_about_sixteenfold_when_dt_halves():
    quad = Quadrotor.crazyflie()
    start = disturbed_start(quad)
    errors = []
    for dt in (4e-3, 2e-3):
        sim, exact = fly_command(quad, start, dt, 0.2, [0.0, 0.0, 0.0])
        errors.append(np.abs(sim.path[0] - exact[1:, 0:3]).max())
    assert 12.0 < errors[0] / errors[1] < 22.0, errors


@pytest.mark.parametrize(
    ("traj", "times"),
    [
        (Circle((1.5, -2.0), radius=2.0, altitude=3.0, speed=2.0), np.linspace(0.1, 3.0, 7)),
        (FigureEight((0.0, 0.0), radius=2.0, altitude=3.0, period=8.0), np.linspace(0.1, 7, 7)),
        (Waypoints([[0, 0, 1], [3, 0, 1.5], [3, 3, 2]], speed=2.0), np.linspace(0.3, 3.0, 7)),
        # (away from the ramp's ends at 0 and 2.49 s, where the snap jumps)
        (Line([0, 0, 1], [3, 1, 2], speed=2.0), np.linspace(0.1, 2.3, 7)),
    ],
)
def test_the_feedforward_body_rates_are_the_derivatives_of_the_flat_attitude(traj, times):
    ref = flat_reference(traj, times, 9.81)
    W, dW = feedforward(traj, 9.81)
    for k, t in enumerate(times):
        np.testing.assert_allclose(ref["Omega"][k], W(t), rtol=0, atol=1e-9)
        np.testing.assert_allclose(ref["dOmega"][k], dW(t), rtol=0, atol=1e-6)


@pytest.mark.parametrize("airframe", ["crazyflie", "research"])
def test_with_no_thrust_commanded_the_body_falls_half_g_t_squared(airframe):
    # A reference in free fall (a = -g e3) asks the controller for no force at all; the
    # state starts on it, level, rotors stopped. (Through the core: no Trajectory can be in
    # free fall, as its flat attitude needs a + g e3 != 0.)
    quad = getattr(Quadrotor, airframe)(drag=0.0)
    t = np.arange(1001) * 1e-3
    g = quad.gravity
    p0 = np.array([1.0, 2.0, 50.0])
    fall = p0 - 0.5 * g * np.outer(t * t, E3)
    rows = np.zeros((len(t), 3))
    start = np.concatenate([p0, np.zeros(3), np.eye(3).ravel(), np.zeros(3), np.zeros(4)])
    Y = _core.fly(
        quad._airframe,
        start,
        fall,
        -g * np.outer(t, E3),
        np.tile(-g * E3, (len(t), 1)),
        np.zeros(len(t)),
        rows,
        rows,
        rows,
        t,
    )
    np.testing.assert_allclose(Y[:, 0:3], fall, rtol=0, atol=1e-12)
    np.testing.assert_allclose(Y[:, 3:6], -g * np.outer(t, E3), rtol=0, atol=1e-12)
    np.testing.assert_allclose(Y[:, 6:15], np.tile(np.eye(3).ravel(), (len(t), 1)), atol=1e-15)


@pytest.mark.parametrize("airframe", ["crazyflie", "research"])
def test_a_trimmed_hover_is_a_fixed_point_to_rounding(airframe):
    quad = getattr(Quadrotor, airframe)()
    flight = quad.fly(Hover((0.0, 0.0, 1.0), yaw_deg=30.0), 5.0)
    np.testing.assert_allclose(
        flight.positions, np.tile([0.0, 0.0, 1.0], (len(flight), 1)), atol=1e-12
    )
    np.testing.assert_allclose(flight.velocities, 0.0, atol=1e-12)
    np.testing.assert_allclose(flight.angular_velocities, 0.0, atol=1e-12)
