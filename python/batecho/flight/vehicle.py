"""A 6-DOF quadrotor: its physical parameters, state, rotor mixer and dynamics, wind gusts, and
the integration of a flight under the SE(3) controller of :mod:`batecho.flight.controller`.

Model (Bouabdallah-style rigid body with rotor dynamics). World frame: z up, metres,
seconds. Body frame: x forward, y left, z up (the sonar's forward/left/up when the mount is
neutral). State: position p, velocity v (world), rotation R (body -> world), angular velocity
W (body), rotor speeds w_i (rad/s)::

    p' = v
    m v' = -m g e3 + f R e3 - R D R^T (v - wind)        f = sum k_f w_i^2
    R' = R hat(W)
    J W' = M - W x J W                                   M from rotor positions and k_m w_i^2
    w_i' = (clip(w_cmd,i, w_min, w_max) - w_i) / tau_m

``D`` is a diagonal linear body drag (N s/m). Rotors (``configuration="x"``) sit at 45, 135,
225 and 315 deg from body x (front-left, rear-left, rear-right, front-right); ``"+"`` at 0,
90, 180, 270 deg. Rotor i's reaction torque about body z is ``s_i k_m w_i^2`` with
``s = (+1, -1, +1, -1)``.

Control: the thrust and moments of the SE(3) controller (Lee, Leok & McClamroch 2010, in
:mod:`~batecho.flight.controller`) are allocated to rotor speeds by inverting the mixer
matrix, with each rotor's thrust clipped to its range.

Integration: fixed-step classical RK4 with the controller sampled once per step (zero-order
hold, like a flight controller running at 1/dt) and R re-orthonormalised after every step
(its polar factor). With a fixed dt (and the same ``rng`` seed when gusts are on) a flight
is deterministic. ``method="rust"`` (the default) steps in the Rust core (``rust/src/flight``)
on reference samples computed here; ``"python"`` is the same loop in NumPy, the reference
the Rust core is held to (polar factor by SVD); ``"scipy"`` integrates the continuous closed
loop with ``scipy.integrate.solve_ivp`` (DOP853) instead, as a cross-check.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import _core
from .._pickle import MadeAgainOnLoading, ReadOnlyOnLoading
from .._resources import SlowWarning, check_memory
from .._validate import finite, flag, positive_scalar, readonly, real_array, vectors
from ._so3 import E3, cross3, hat, orthonormalise, triple
from .controller import SE3Gains, desired_attitude, flat_reference, se3_control
from .record import Flight
from .trajectories import Trajectory

#: A flight of more steps than this says first that it will run for minutes in NumPy (the RK4
#: loop takes a few hundred microseconds a step; the Rust one, a few microseconds).
SLOW_STEPS = 200_000

#: Memory per recorded step of a flight (bytes): the state, the reference, the commands, the
#: wind and the integrator's temporaries.
BYTES_PER_STEP = 1000.0

__all__ = ["FLY_METHODS", "GRAVITY", "Gusts", "QuadState", "Quadrotor"]

GRAVITY = 9.81

#: The integrators of :meth:`Quadrotor.fly`; the first is the default.
FLY_METHODS = ("rust", "python", "scipy")


@dataclass(frozen=True, eq=False)
class Gusts:
    """Wind as process noise: each world axis an Ornstein-Uhlenbeck velocity (m/s) about
    ``mean`` with standard deviation ``std`` and correlation time ``correlation_time`` (s),
    drawn once per step (exact discretisation) and held over it. It pushes the vehicle only
    through the body drag ``Quadrotor.drag``."""

    std: float = 1.0
    correlation_time: float = 2.0
    mean: Any = (0.0, 0.0, 0.0)

    def __post_init__(self):
        object.__setattr__(self, "std", positive_scalar(self.std, "std", allow_zero=True))
        object.__setattr__(
            self, "correlation_time", positive_scalar(self.correlation_time, "correlation_time")
        )
        object.__setattr__(self, "mean", triple(self.mean, "mean"))

    def sample(self, n: int, dt: float, rng: np.random.Generator) -> np.ndarray:
        """(n, 3) wind velocities at steps ``dt`` apart, starting from the stationary law."""
        phi = math.exp(-dt / self.correlation_time)
        q = self.std * math.sqrt(1.0 - phi * phi)
        z = rng.standard_normal((n, 3))
        w = np.empty((n, 3))
        w[0] = self.std * z[0]
        for k in range(1, n):
            w[k] = phi * w[k - 1] + q * z[k]
        return w + self.mean


@dataclass(frozen=True, eq=False)
class QuadState(ReadOnlyOnLoading):
    """A rigid-body state: ``position`` (3,) m and ``velocity`` (3,) m/s in the world frame,
    ``rotation`` (3, 3) body -> world, ``angular_velocity`` (3,) rad/s in the body frame,
    ``rotor_speeds`` (4,) rad/s."""

    position: Any
    velocity: Any
    rotation: Any
    angular_velocity: Any
    rotor_speeds: Any

    def __post_init__(self):
        for name in ("position", "velocity", "angular_velocity"):
            object.__setattr__(self, name, readonly(vectors(getattr(self, name), name)[0]))
        R = finite(real_array(self.rotation, "rotation"), "rotation")
        if (
            R.shape != (3, 3)
            or not np.allclose(R.T @ R, np.eye(3), atol=1e-6)
            or np.linalg.det(R) <= 0
        ):
            raise ValueError("rotation must be a 3x3 rotation matrix (orthonormal, det +1)")
        object.__setattr__(self, "rotation", readonly(orthonormalise(R)))
        w = finite(real_array(self.rotor_speeds, "rotor_speeds"), "rotor_speeds")
        if w.shape != (4,):
            raise ValueError(f"rotor_speeds must have shape (4,), got {w.shape}")
        object.__setattr__(self, "rotor_speeds", readonly(w))

    def vector(self) -> np.ndarray:
        """The 22-vector (p, v, R row-major, W, rotor speeds) integrated by ``fly``."""
        return np.concatenate(
            [
                self.position,
                self.velocity,
                self.rotation.ravel(),
                self.angular_velocity,
                self.rotor_speeds,
            ]
        )


@dataclass(frozen=True, eq=False)
class Quadrotor(MadeAgainOnLoading):
    """Physical parameters of a quadrotor and its controller gains.

    ``mass`` kg; ``inertia`` (Jxx, Jyy, Jzz) kg m^2 (diagonal); ``arm_length`` m (centre to
    rotor axis); ``k_f`` N/(rad/s)^2 (rotor thrust ``k_f w^2``); ``k_m`` N m/(rad/s)^2 (drag
    torque ``k_m w^2``); ``motor_time_constant`` s; ``omega_min``/``omega_max`` rad/s;
    ``drag`` (3,) N s/m linear body-frame drag; ``configuration`` "x" or "+"; ``gains``
    (default: position loop at 4 rad/s, attitude loop at 25 rad/s);
    ``drag_feedforward`` adds the model drag at the reference velocity to the thrust vector.
    """

    mass: float
    inertia: Any
    arm_length: float
    k_f: float
    k_m: float
    motor_time_constant: float
    omega_min: float = 0.0
    omega_max: float = math.inf
    drag: Any = (0.0, 0.0, 0.0)
    configuration: str = "x"
    gains: SE3Gains | None = None
    drag_feedforward: bool = True
    gravity: float = GRAVITY
    _mixer: np.ndarray = field(init=False, repr=False, compare=False)
    _mixer_inv: np.ndarray = field(init=False, repr=False, compare=False)
    _airframe: _core.Airframe = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        for name in ("mass", "arm_length", "k_f", "k_m", "motor_time_constant", "gravity"):
            object.__setattr__(self, name, positive_scalar(getattr(self, name), name))
        J = triple(self.inertia, "inertia")
        if not (J > 0).all():
            raise ValueError(f"inertia must be > 0, got {J}")
        object.__setattr__(self, "inertia", J)
        object.__setattr__(
            self, "drag_feedforward", flag(self.drag_feedforward, "drag_feedforward")
        )
        d = triple(self.drag, "drag")
        if (d < 0).any():
            raise ValueError(f"drag must be >= 0, got {d}")
        object.__setattr__(self, "drag", d)
        lo = positive_scalar(self.omega_min, "omega_min", allow_zero=True)
        hi = float(self.omega_max)
        if not hi > lo:
            raise ValueError(f"omega_max ({hi}) must exceed omega_min ({lo})")
        object.__setattr__(self, "omega_min", lo)
        object.__setattr__(self, "omega_max", hi)
        if self.configuration not in ("x", "+"):
            raise ValueError(f"configuration must be 'x' or '+', got {self.configuration!r}")
        if self.gains is None:
            object.__setattr__(self, "gains", SE3Gains.from_bandwidth(self.mass, J, 4.0, 25.0))
        elif not isinstance(self.gains, SE3Gains):
            raise TypeError("gains must be an SE3Gains")
        ang = np.deg2rad(
            [45.0, 135.0, 225.0, 315.0] if self.configuration == "x" else [0.0, 90.0, 180.0, 270.0]
        )
        x, y = self.arm_length * np.cos(ang), self.arm_length * np.sin(ang)
        spin = np.array([1.0, -1.0, 1.0, -1.0])
        A = np.vstack([np.ones(4), y, -x, spin * self.k_m / self.k_f])
        object.__setattr__(self, "_mixer", readonly(A))
        object.__setattr__(self, "_mixer_inv", readonly(np.linalg.inv(A)))
        if self.hover_rotor_speed >= self.omega_max:
            raise ValueError(
                f"omega_max is too low to hover: it must exceed {self.hover_rotor_speed:.6g} rad/s"
            )
        g = self.gains
        assert g is not None  # set above
        airframe = _core.Airframe(
            mass=self.mass,
            inertia=J,
            arm_length=self.arm_length,
            k_f=self.k_f,
            k_m=self.k_m,
            motor_time_constant=self.motor_time_constant,
            omega_min=lo,
            omega_max=hi,
            drag=d,
            configuration=self.configuration,
            gravity=self.gravity,
            k_x=g.k_x,
            k_v=g.k_v,
            k_R=g.k_R,
            k_Omega=g.k_Omega,
            drag_feedforward=self.drag_feedforward,
        )
        object.__setattr__(self, "_airframe", airframe)

    # -- airframes ---------------------------------------------------------------------
    @classmethod
    def crazyflie(cls, **overrides: Any) -> Quadrotor:
        """Bitcraze Crazyflie 2.x (27 g, X configuration).

        Mass 0.027 kg (Bitcraze spec); motor-to-motor diagonal 92 mm, so arm 0.046 m;
        inertia diag(1.4e-5, 1.4e-5, 2.17e-5) kg m^2 and rotor coefficients
        k_f = 3.16e-10 N/rpm^2 = 2.88e-8 N/(rad/s)^2, k_m = 7.94e-12 N m/rpm^2 =
        7.24e-10 N m/(rad/s)^2 from J. Foerster, "System identification of the Crazyflie 2.0
        nano quadrocopter", BSc thesis, ETH Zurich 2015 (as used in gym-pybullet-drones'
        cf2x model). Max thrust about 0.15 N per rotor (thrust-to-weight 2.25) gives
        omega_max = 2280 rad/s. Linear drag from Foerster's K_aero = -diag(9.1785, 9.1785,
        10.311)e-7 N s/m per rad/s of summed rotor speed, taken at hover (sum ~ 6060 rad/s).
        Motor time constant 0.015 s is a typical value for the 7 mm coreless motors (an
        assumption, not from Foerster). Gains: position 4 rad/s (zeta 1), attitude 25 rad/s
        (zeta 0.9).
        """
        rpm2 = (60.0 / (2.0 * math.pi)) ** 2
        params: dict[str, Any] = {
            "mass": 0.027,
            "inertia": (1.4e-5, 1.4e-5, 2.17e-5),
            "arm_length": 0.046,
            "k_f": 3.16e-10 * rpm2,
            "k_m": 7.94e-12 * rpm2,
            "motor_time_constant": 0.015,
            "omega_min": 0.0,
            "omega_max": 2280.0,
            "drag": (9.1785e-7 * 6064.0, 9.1785e-7 * 6064.0, 10.311e-7 * 6064.0),
            "configuration": "x",
        }
        params.update(overrides)
        if "gains" not in overrides:
            params["gains"] = SE3Gains.from_bandwidth(params["mass"], params["inertia"], 4.0, 25.0)
        return cls(**params)

    @classmethod
    def research(cls, **overrides: Any) -> Quadrotor:
        """A 1.2 kg, 450-class research quadrotor (0.25 m arms, X configuration).

        Rotors: the RotorS/Gazebo default motor model (Furrer et al. 2016, "RotorS - a modular
        Gazebo MAV simulator framework"): k_f = 8.54858e-6 N/(rad/s)^2, moment constant
        0.016 m (k_m = 1.368e-7 N m/(rad/s)^2), spin-up time constant 1/80 s,
        omega_max = 838 rad/s (thrust-to-weight 2.0 at 1.2 kg). Inertia
        diag(9.8e-3, 9.8e-3, 1.86e-2) kg m^2 is a point-mass estimate: four 60 g motor+prop
        units at 0.25 m plus a 0.96 kg 15 x 15 x 8 cm central body. Drag: RotorS rotor drag
        8.06428e-5 N s/m per rad/s per rotor at hover (587 rad/s) in x and y, 0.05 N s/m in z
        (assumed). Gains: position 4 rad/s (zeta 1), attitude 20 rad/s (zeta 0.9).
        """
        params: dict[str, Any] = {
            "mass": 1.2,
            "inertia": (9.8e-3, 9.8e-3, 1.86e-2),
            "arm_length": 0.25,
            "k_f": 8.54858e-6,
            "k_m": 0.016 * 8.54858e-6,
            "motor_time_constant": 1.0 / 80.0,
            "omega_min": 0.0,
            "omega_max": 838.0,
            "drag": (4 * 8.06428e-5 * 587.0, 4 * 8.06428e-5 * 587.0, 0.05),
            "configuration": "x",
        }
        params.update(overrides)
        if "gains" not in overrides:
            params["gains"] = SE3Gains.from_bandwidth(params["mass"], params["inertia"], 4.0, 20.0)
        return cls(**params)

    # -- statics -------------------------------------------------------------------------
    @property
    def hover_thrust(self) -> float:
        """Total thrust to hover, ``m g`` (N)."""
        return self.mass * self.gravity

    @property
    def hover_rotor_speed(self) -> float:
        """Trim rotor speed (rad/s) with ``4 k_f w^2 = m g``."""
        return math.sqrt(self.hover_thrust / (4.0 * self.k_f))

    @property
    def mixer(self) -> np.ndarray:
        """(4, 4) map from rotor thrusts ``k_f w_i^2`` (N) to (f N, Mx, My, Mz N m)."""
        return self._mixer

    def thrust_and_moments(self, rotor_speeds: Any) -> tuple[Any, np.ndarray]:
        """Total thrust (N) and body moments (N m) of rotor speeds (..., 4) rad/s."""
        w = np.asarray(rotor_speeds, dtype=np.float64)
        u = (self.k_f * w * w) @ self._mixer.T
        return u[..., 0], u[..., 1:]

    def rotor_speeds_for(self, thrust: float, moments: Any) -> np.ndarray:
        """Rotor speeds (4,) rad/s that give total ``thrust`` (N) and body ``moments`` (N m),
        each rotor's thrust clipped to ``[k_f omega_min^2, k_f omega_max^2]``."""
        m = np.asarray(moments, dtype=np.float64)
        T = self._mixer_inv @ np.array([thrust, m[0], m[1], m[2]])
        T = np.clip(T, self.k_f * self.omega_min**2, self.k_f * self.omega_max**2)
        return np.sqrt(T / self.k_f)

    def initial_state(self, trajectory: Trajectory, t0: float = 0.0) -> QuadState:
        """The state that flies ``trajectory`` exactly at ``t0``: its position and velocity,
        the flat attitude and body rates, and the rotor speeds of the nominal thrust and
        moments (level hover at the yaw reference if it starts at rest)."""
        ref = flat_reference(trajectory, np.array([float(t0)]), self.gravity)
        Om, dOm = ref["Omega"][0], ref["dOmega"][0]
        J = self.inertia
        M = J * dOm + np.cross(Om, J * Om)
        R = ref["R"][0]
        F = self.mass * (ref["a"][0] + self.gravity * E3)
        if self.drag_feedforward and self.drag.any():
            for _ in range(4):  # the drag force depends on the attitude it tilts
                Fd = F + R @ (self.drag * (ref["v"][0] @ R))
                R = desired_attitude(Fd, float(ref["yaw"][0]))
            F = Fd
        w = self.rotor_speeds_for(float(np.linalg.norm(F)), M)
        return QuadState(ref["p"][0], ref["v"][0], R, Om, w)

    # -- dynamics and control --------------------------------------------------------
    def _deriv(self, y: np.ndarray, w_cmd: np.ndarray, wind: np.ndarray) -> np.ndarray:
        R = y[6:15].reshape(3, 3)
        v, Om, w = y[3:6], y[15:18], y[18:22]
        u = self._mixer @ (self.k_f * w * w)
        J = self.inertia
        drag = R @ (self.drag * ((v - wind) @ R))
        dv = (u[0] * R[:, 2] - drag) / self.mass
        dv[2] -= self.gravity
        dR = R @ hat(Om)
        dOm = (u[1:] - cross3(Om, J * Om)) / J
        dw = (w_cmd - w) / self.motor_time_constant
        return np.concatenate([v, dv, dR.ravel(), dOm, dw])

    def _control(self, y: np.ndarray, ref: dict[str, np.ndarray], k: int) -> np.ndarray:
        """Rotor speed commands of the SE(3) controller at reference sample ``k``."""
        assert self.gains is not None  # set in __post_init__
        f, M = se3_control(
            self.gains,
            self.mass,
            self.gravity,
            self.inertia,
            self.drag,
            self.drag_feedforward,
            y,
            ref,
            k,
        )
        return self.rotor_speeds_for(f, M)

    # -- flying ----------------------------------------------------------------------------
    def fly(
        self,
        trajectory: Trajectory,
        duration: float,
        dt: float = 1e-3,
        initial_state: QuadState | None = None,
        rng: Any = None,
        *,
        gusts: Gusts | None = None,
        method: str = FLY_METHODS[0],
    ) -> Flight:
        """Fly ``trajectory`` for ``duration`` s from t = 0 and record the state every ``dt``
        (at most the motor time constant; a shorter ``duration`` is one step).

        Starts from ``initial_state`` or, by default, exactly on the reference
        (:meth:`initial_state`). ``gusts`` adds wind drawn from ``rng`` (a
        ``numpy.random.Generator`` or a seed; None means seed 0, so flights repeat).
        ``method="rust"`` (default): fixed-step RK4, controller at 1/dt, in the Rust core;
        ``"python"``: the same RK4 in NumPy (the reference; the two agree to about 1e-12);
        ``"scipy"``: adaptive DOP853 on the continuous closed loop, sampled every dt.
        """
        if not isinstance(trajectory, Trajectory):
            raise TypeError("trajectory must be a batecho.trajectories.Trajectory")
        T = positive_scalar(duration, "duration")
        h = positive_scalar(dt, "dt")
        if h > self.motor_time_constant:
            raise ValueError(
                f"dt={h} s exceeds the motor time constant "
                f"{self.motor_time_constant} s; RK4 would be inaccurate"
            )
        if method not in FLY_METHODS:
            raise ValueError(f"method must be one of {FLY_METHODS}, got {method!r}")
        steps = T / h
        check_memory(
            steps * BYTES_PER_STEP,
            f"a flight of duration {T:g} s at dt = {h:g} s ({steps:.3g} steps)",
            "use a larger dt, or fly a shorter duration in parts (initial_state=)",
        )
        if method != "rust" and steps > SLOW_STEPS:
            warnings.warn(
                f"a flight of {steps:.3g} steps (duration {T:g} s / dt {h:g} s) runs for "
                "minutes; a larger dt or method='rust' is faster",
                SlowWarning,
                stacklevel=2,
            )
        n = max(1, math.ceil(steps - 1e-9))
        times = np.minimum(np.arange(n + 1) * h, T)
        state = self.initial_state(trajectory) if initial_state is None else initial_state
        if not isinstance(state, QuadState):
            raise TypeError("initial_state must be a QuadState")
        if gusts is None:
            wind = np.zeros((n + 1, 3))
        else:
            gen = (
                rng
                if isinstance(rng, np.random.Generator)
                else np.random.default_rng(0 if rng is None else rng)
            )
            wind = gusts.sample(n + 1, h, gen)
        ref = flat_reference(trajectory, times, self.gravity)
        Y = np.empty((n + 1, 22))
        Y[0] = state.vector()
        if method == "rust":
            Y[:] = _core.fly(
                self._airframe,
                Y[0],
                ref["p"],
                ref["v"],
                ref["a"],
                ref["yaw"],
                ref["Omega"],
                ref["dOmega"],
                wind,
                times,
            )
        elif method == "python":
            y = Y[0].copy()
            for k in range(n):
                hk = times[k + 1] - times[k]
                cmd = self._control(y, ref, k)
                wk = wind[k]
                k1 = self._deriv(y, cmd, wk)
                k2 = self._deriv(y + 0.5 * hk * k1, cmd, wk)
                k3 = self._deriv(y + 0.5 * hk * k2, cmd, wk)
                k4 = self._deriv(y + hk * k3, cmd, wk)
                y = y + (hk / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
                y[6:15] = orthonormalise(y[6:15].reshape(3, 3)).ravel()
                Y[k + 1] = y
        else:
            Y[:] = self._fly_scipy(trajectory, times, Y[0], wind, h)
        return Flight(self, trajectory, times, Y, ref, wind)

    def _fly_scipy(
        self, trajectory: Trajectory, times: np.ndarray, y0: np.ndarray, wind: np.ndarray, h: float
    ) -> np.ndarray:
        def rhs(t: float, y: np.ndarray) -> np.ndarray:
            ref = flat_reference(trajectory, np.array([t]), self.gravity)
            yy = y.copy()
            yy[6:15] = orthonormalise(y[6:15].reshape(3, 3)).ravel()
            k = min(int(t / h), len(wind) - 1)
            return self._deriv(y, self._control(yy, ref, 0), wind[k])

        from scipy.integrate import solve_ivp

        sol = solve_ivp(
            rhs, (times[0], times[-1]), y0, method="DOP853", t_eval=times, rtol=1e-9, atol=1e-10
        )
        if not sol.success:  # pragma: no cover
            raise RuntimeError(f"solve_ivp failed: {sol.message}")
        Y = sol.y.T.copy()
        Y[:, 6:15] = orthonormalise(Y[:, 6:15].reshape(-1, 3, 3)).reshape(-1, 9)
        return Y
