"""``batecho/EchoFlight-v0``: a quadrotor crosses a forest drawn from a Poisson process, steered
by a policy that hears the foliage's echoes and never sees the trees (docs/guide/envs.md).

An episode: a forest of ``density`` trees per m² on a corridor ``length_m`` long and
``width_m`` wide (trees from ``trees_from_m`` to ``length_m - trees_from_m`` along it); the
drone starts hovering at its near edge, at ``altitude_m`` among the crowns, facing along the
corridor, and must reach the goal disc (``goal_radius_m``, horizontal) at the far edge.

A step is one pulse interval (``1 / pulse_rate_hz`` s). The action (4,) in [-1, 1] is a command
in the heading frame: forward, left and up velocity (times ``max_speed_mps``,
``max_speed_mps``, ``max_climb_mps``) and yaw rate (times ``max_yaw_rate``), clipped to [-1, 1]
(an action that is not 4 finite numbers raises ValueError). The SE(3)
controller tracks it through the quadrotor's full dynamics (:class:`~batecho.QuadrotorSim`,
RK4 steps of ``dt``); at the end of the interval the sonar sends one pulse and both ears
record its echoes.

The drone's sonar (:func:`default_sonar`) sits at its centre, looking along its nose, and has
two ears of its own (:meth:`~batecho.Sonar.binaural`): ``ear_separation_m`` apart along the
body's left axis, each turned ``ear_yaw_deg`` outward, so that the nearer side's echoes are the
louder in its ear. The forest's trees echo from their leaves and, with ``branches``, their
branches and trunks (docs/model.md §9); with ``shading``, leaves and branches in the way dim or
silence what lies behind them (docs/model.md §10). :data:`DEFAULT_BRANCHES` and
:data:`DEFAULT_SHADING` are the defaults of both. Collisions count leaves, branches (with
``branches``) and bark (:meth:`~batecho.Scene.min_clearance`,
:meth:`~batecho.forest.clearance.BarkGrid.set_clearance`) and the ground.

The observation (a Dict, float32):

- ``echoes`` (2, ``n_range_bins``): each ear's echo envelope (docs/model.md §5, the analytic
  signal of the impulse response, sampled four times finer than its Nyquist rate:
  :func:`~batecho.echoes.envelope.band_envelope`) in dB re 1 (relative pressure), the largest
  in each of ``n_range_bins`` equal range bins from 0 to the sonar's reach, clipped to
  [``floor_db``, ``ceiling_db``]; row 0 the left ear, row 1 the right;
- ``velocity`` (3,): the body-frame velocity (forward, left, up), m/s (clipped to +-20);
- ``attitude`` (3,): roll, pitch and yaw (rad, ZYX Euler angles of body -> world);
- ``goal`` (2,): the goal's bearing in the heading frame (rad, positive to the left) and its
  horizontal distance (m).

The reward is the progress toward the goal (m, the fall of its horizontal distance) less
``effort_weight`` times the action's squared norm; a collision or leaving the corridor costs
``collision_penalty`` and reaching the goal earns ``success_reward``. The episode terminates on
a collision (a clearance below ``drone_radius_m`` anywhere along the step's RK4 path;
``info["collision"]``), on leaving the corridor (``info["out_of_bounds"]``) or on reaching the
goal (``info["is_success"]``), and is truncated after ``max_time_s``. A step after either
end raises RuntimeError until :meth:`~EchoFlightEnv.reset`.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .._resources import check_memory
from .._validate import flag, integer
from ..echoes.envelope import envelope_stride
from ..echoes.simulate import method_and_tol
from ..flight.mount import SonarMount
from ..flight.poses import Poses
from ..flight.sim import BYTES_PER_PATH_POINT, QuadrotorSim
from ..flight.trajectories import Hover
from ..flight.vehicle import Quadrotor
from ..forest.forest import Forest
from ..forest.ipp import UniformIntensity
from ..forest.scene import Scene
from ..sonar.shading import Shading
from ..sonar.sonar import Sonar
from .pulses import (
    ENVELOPE_OVERSAMPLING,
    EchoBins,
    echo_levels,
    echo_levels_db,
    start_echo_levels,
)

__all__ = [
    "CLEARANCE_HORIZON_M",
    "DEFAULT_BRANCHES",
    "DEFAULT_SHADING",
    "EchoFlightEnv",
    "default_sonar",
    "echo_levels_db",
]

#: Whether the trees' branches and trunks echo (and block, with shading) by default.
DEFAULT_BRANCHES = True
#: The shading of echoes by default (docs/model.md §10, tau = 0.6, branches block; None: every
#: scatterer echoes as though it stood alone).
DEFAULT_SHADING: Shading | None = Shading()

#: The ears' spacing (m) along the body's left axis: a few centimetres, as on a small drone
#: (a bat's ears are 1-2 cm apart).
EAR_SEPARATION_M = 0.05
#: Each ear's turn outward (deg), as a bat's pinnae point to either side of the call's axis.
EAR_YAW_DEG = 25.0

#: Clearances (m) in ``info["clearance_m"]`` are exact up to this (or up to the drone's radius,
#: if larger: a clipped clearance must not read as a collision) and clipped to it.
CLEARANCE_HORIZON_M = 2.0

#: Body velocities in the observation are clipped to +- this (m/s).
MAX_OBSERVED_SPEED_MPS = 20.0

#: Attempts at drawing a forest whose start and goal keep clear of it before giving up.
_MAX_DRAWS = 50


def default_sonar(
    ear_separation_m: float = EAR_SEPARATION_M,
    ear_yaw_deg: float = EAR_YAW_DEG,
    shading: Shading | None = DEFAULT_SHADING,
) -> Sonar:
    """The environment's sonar: the paper's (30 deg beam, 60-80 kHz, the detectable lobe) with
    two ears (:meth:`~batecho.Sonar.binaural`, each with the emitter's 30 deg pattern), a
    reach cut to 5 m (``max_range_m``; 3 s of flight at the top speed) and a record that
    just covers it (200 kHz sampling, 6,000 samples = 30 ms, 5.1 m). Leaves and branch
    pieces within ``min_range_m`` of a pulse are left out (``too_close="skip"``): the pulse
    of a step that ends in a collision may come from inside a crown or a branch."""
    return Sonar.binaural(
        ear_separation_m,
        ear_yaw_deg,
        beamwidth_deg=30.0,
        fs=200e3,
        n_samples=6_000,
        max_range_m=5.0,
        shading=shading,
        too_close="skip",
    )


def _yaw(R: np.ndarray) -> float:
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def _euler_zyx(R: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (rad) of ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = math.asin(max(-1.0, min(1.0, -float(R[2, 0]))))
    roll = math.atan2(float(R[2, 1]), float(R[2, 2]))
    return np.array([roll, pitch, _yaw(R)])


def _is_real(x: Any) -> bool:
    """Whether ``x`` is a real number, NumPy's included."""
    return isinstance(x, numbers.Real)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class EchoFlightEnv(gym.Env[dict[str, Any], np.ndarray]):
    """Fly a quadrotor across a forest by its echoes (module docstring; ``batecho/EchoFlight-v0``).

    Lengths in m, speeds in m/s, rates in rad/s, times in s. ``sonar``: a
    :class:`~batecho.Sonar` with two receivers, the left ear first, and a fixed record
    (default :func:`default_sonar` of ``ear_separation_m`` and ``ear_yaw_deg``), its shading
    set to ``shading`` and its ``too_close`` to ``"skip"`` (as :func:`default_sonar`'s);
    ``branches``: whether branches and trunks echo; ``quadrotor``: a
    :class:`~batecho.Quadrotor` (default :meth:`~batecho.Quadrotor.crazyflie`);
    ``tree_params``: keyword arguments of :func:`~batecho.grow_tree`; ``variants``: distinct
    trees grown per forest (each placed tree one of them, turned and scaled).

    Parameters that would end an episode before it starts are refused: the drone must start
    above the ground (``altitude_m > drone_radius_m``), fit in the corridor
    (``width_m > 2 drone_radius_m``) and start outside the goal (``goal_radius_m <
    length_m``); the reward's weights are finite and >= 0.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}  # noqa: RUF012 (gymnasium's attribute)

    def __init__(
        self,
        *,
        density: float = 0.03,
        length_m: float = 24.0,
        width_m: float = 14.0,
        trees_from_m: float = 3.0,
        altitude_m: float = 2.5,
        goal_radius_m: float = 2.5,
        ceiling_m: float = 8.0,
        drone_radius_m: float = 0.15,
        pulse_rate_hz: float = 20.0,
        max_time_s: float = 40.0,
        max_speed_mps: float = 1.5,
        max_climb_mps: float = 0.5,
        max_yaw_rate: float = 1.5,
        dt: float = 1e-3,
        n_range_bins: int = 32,
        ear_separation_m: float = EAR_SEPARATION_M,
        ear_yaw_deg: float = EAR_YAW_DEG,
        branches: bool = DEFAULT_BRANCHES,
        shading: Shading | None = DEFAULT_SHADING,
        floor_db: float = -100.0,
        ceiling_db: float = 20.0,
        effort_weight: float = 0.01,
        collision_penalty: float = 10.0,
        success_reward: float = 10.0,
        sonar: Sonar | None = None,
        quadrotor: Quadrotor | None = None,
        tree_params: dict[str, Any] | None = None,
        variants: int = 4,
        method: str = "auto",
        tol: float = 1e-6,
        render_mode: str | None = None,
    ):
        for name, value in (
            ("length_m", length_m),
            ("width_m", width_m),
            ("altitude_m", altitude_m),
            ("goal_radius_m", goal_radius_m),
            ("drone_radius_m", drone_radius_m),
            ("pulse_rate_hz", pulse_rate_hz),
            ("max_time_s", max_time_s),
            ("max_speed_mps", max_speed_mps),
            ("max_climb_mps", max_climb_mps),
            ("max_yaw_rate", max_yaw_rate),
            ("dt", dt),
        ):
            if not (_is_real(value) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        for name, value in (
            ("effort_weight", effort_weight),
            ("collision_penalty", collision_penalty),
            ("success_reward", success_reward),
        ):
            if not (_is_real(value) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        if not (math.isfinite(density) and density >= 0):
            raise ValueError(f"density must be a finite number >= 0 (trees/m^2), got {density!r}")
        if not 0 <= trees_from_m < length_m / 2:
            raise ValueError(f"trees_from_m must be in [0, length_m/2), got {trees_from_m!r}")
        for name, value in (
            ("ceiling_m", ceiling_m),
            ("floor_db", floor_db),
            ("ceiling_db", ceiling_db),
        ):
            if isinstance(value, bool) or not _is_real(value):
                raise TypeError(f"{name} must be a real number, got {value!r}")
        if not ceiling_m > altitude_m:
            raise ValueError(f"ceiling_m ({ceiling_m}) must be above altitude_m ({altitude_m})")
        if not math.isfinite(ceiling_m):
            raise ValueError(f"ceiling_m must be finite, got {ceiling_m!r}")
        # (an episode that ends before it starts: the drone on the ground, wider than the
        # corridor, or starting in the goal)
        if not altitude_m > drone_radius_m:
            raise ValueError(
                f"altitude_m ({altitude_m}) must be above drone_radius_m ({drone_radius_m}): "
                "the drone would start touching the ground"
            )
        if not width_m > 2.0 * drone_radius_m:
            raise ValueError(
                f"width_m ({width_m}) must be more than the drone's diameter, "
                f"2 * drone_radius_m = {2.0 * drone_radius_m:g} m"
            )
        if not goal_radius_m < length_m:
            raise ValueError(
                f"goal_radius_m ({goal_radius_m}) must be less than length_m ({length_m}), the "
                "distance from the start to the goal: the drone would start in the goal"
            )
        if quadrotor is not None and not isinstance(quadrotor, Quadrotor):
            raise TypeError(
                f"quadrotor must be None or a batecho.Quadrotor, got {type(quadrotor).__name__}"
            )
        quadrotor = Quadrotor.crazyflie() if quadrotor is None else quadrotor
        if dt > quadrotor.motor_time_constant:  # (as QuadrotorSim.step refuses it)
            raise ValueError(
                f"dt={dt} s exceeds the quadrotor's motor time constant "
                f"{quadrotor.motor_time_constant} s; RK4 would be inaccurate"
            )
        variants = integer(variants, "variants", 1)
        method, tol = method_and_tol(method, tol)
        if int(n_range_bins) != n_range_bins or n_range_bins < 1:
            raise ValueError(f"n_range_bins must be an integer >= 1, got {n_range_bins!r}")
        # (the empty bins hold floor_db: beyond float32's range they would be -inf)
        if not abs(floor_db) <= float(np.finfo(np.float32).max):
            raise ValueError(f"floor_db must be a finite float32 number (dB), got {floor_db!r}")
        # (the echoes' Box is float32; an infinite ceiling clips nothing)
        if math.isfinite(ceiling_db) and abs(ceiling_db) > float(np.finfo(np.float32).max):
            raise ValueError(f"ceiling_db must be a float32 number (dB) or inf, got {ceiling_db!r}")
        if not floor_db < ceiling_db:
            raise ValueError(f"floor_db ({floor_db}) must be below ceiling_db ({ceiling_db})")
        steps = 1.0 / (pulse_rate_hz * dt)
        check_memory(
            steps * BYTES_PER_PATH_POINT,
            f"a pulse interval 1/pulse_rate_hz = {1 / pulse_rate_hz:g} s of RK4 steps "
            f"dt = {dt:g} s ({steps:.3g} of them, the path of a step)",
            "use a higher pulse_rate_hz or a larger dt",
        )
        n_sub = round(steps)
        if n_sub < 1 or abs(n_sub * dt * pulse_rate_hz - 1.0) > 1e-9:
            raise ValueError(
                f"the pulse interval 1/pulse_rate_hz = {1 / pulse_rate_hz:g} s must be a whole "
                f"number of RK4 steps dt = {dt:g} s"
            )
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.density = float(density)
        self.length_m, self.width_m = float(length_m), float(width_m)
        self.trees_from_m, self.altitude_m = float(trees_from_m), float(altitude_m)
        self.goal_radius_m, self.ceiling_m = float(goal_radius_m), float(ceiling_m)
        self.drone_radius_m = float(drone_radius_m)
        #: Clearances (m) are exact up to this and clipped to it (:data:`CLEARANCE_HORIZON_M`).
        self.clearance_horizon_m = max(CLEARANCE_HORIZON_M, self.drone_radius_m)
        self.pulse_rate_hz, self.dt, self.n_substeps = float(pulse_rate_hz), float(dt), n_sub
        n_pulses = max_time_s * pulse_rate_hz
        if not math.isfinite(n_pulses):
            raise ValueError(
                f"max_time_s = {max_time_s:g} s is too long: its number of steps, "
                f"max_time_s * pulse_rate_hz ({pulse_rate_hz:g} Hz), overflows float64"
            )
        self.max_steps = math.ceil(n_pulses - 1e-9)
        self.scales = np.array([max_speed_mps, max_speed_mps, max_climb_mps, max_yaw_rate])
        self.n_range_bins = int(n_range_bins)
        self.floor_db, self.ceiling_db = float(floor_db), float(ceiling_db)
        self.effort_weight = float(effort_weight)
        self.collision_penalty, self.success_reward = (
            float(collision_penalty),
            float(success_reward),
        )
        branches = flag(branches, "branches")
        if shading is not None and not isinstance(shading, Shading):
            raise TypeError(f"shading must be None or a batecho.Shading, got {shading!r}")
        if sonar is None:
            sonar = default_sonar(ear_separation_m, ear_yaw_deg, shading)
        if not isinstance(sonar, Sonar):
            raise TypeError(f"sonar must be a batecho.Sonar, got {type(sonar).__name__}")
        if sonar.n_receivers != 2:
            raise ValueError(
                f"sonar must have two receivers, the left ear first (Sonar.binaural), got "
                f"{sonar.n_receivers}"
            )
        if sonar.is_auto:
            raise ValueError("sonar must have a fixed record (an int n_samples), not 'auto'")
        if sonar.shading != shading or sonar.too_close != "skip":
            sonar = sonar.replace(shading=shading, too_close="skip")
        self.sonar = sonar
        self.branches, self.shading = branches, shading
        self.ear_separation_m, self.ear_yaw_deg = float(ear_separation_m), float(ear_yaw_deg)
        self.quadrotor = quadrotor
        self.tree_params = dict(tree_params or {})
        self.variants = int(variants)
        self.method, self.tol = method, float(tol)
        #: Each ear's place and facing on the body (left, right), for pictures.
        self.ears = tuple(
            SonarMount(
                offset=r.offset_m,
                yaw_deg=0.0 if r.beam is None else r.beam.center_deg[0],
                pitch_deg=0.0 if r.beam is None else r.beam.center_deg[1],
            )
            for r in self.sonar.receivers or ()
        )
        reach = min(self.sonar.reach_m(), self.sonar.record_range_m)
        if not math.isfinite(reach):
            raise ValueError("the sonar must have a finite reach (a cone lobe needs max_range_m)")
        #: The range the echo bins cover (m): the lobe's reach, within the record.
        self.reach_m = float(reach)
        n = int(self.sonar.n_samples)
        #: The envelope is taken at every this many samples (:mod:`batecho.envs.pulses`).
        self.envelope_stride = envelope_stride(
            n, self.sonar.fs, self.sonar.band_hz, ENVELOPE_OVERSAMPLING
        )
        times = np.arange(0, n, self.envelope_stride) / self.sonar.fs
        ranges = self.sonar.sound_speed * times / 2.0
        heard = int(np.count_nonzero(ranges < self.reach_m))
        if self.n_range_bins > heard:
            raise ValueError(
                f"n_range_bins must be at most {heard}, the envelope's samples within the "
                f"sonar's reach of {self.reach_m:.3g} m (more bins would stay empty), got "
                f"{n_range_bins!r}"
            )
        self.echo_bins = EchoBins(
            ranges,
            self.reach_m,
            self.n_range_bins,
            self.floor_db,
            self.ceiling_db,
        )
        self.render_mode = render_mode
        # one frame per step, so that a recorded video plays in real time
        self.metadata = {**self.metadata, "render_fps": self.pulse_rate_hz}

        self.action_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        #: The bounds the observation's speeds (m/s) and goal distance (m) are clipped to.
        self.max_observed_speed_mps = MAX_OBSERVED_SPEED_MPS
        self.max_goal_distance_m = 2.0 * math.hypot(
            self.length_m + self.trees_from_m + self.goal_radius_m, self.width_m
        )
        vmax, dmax = self.max_observed_speed_mps, self.max_goal_distance_m
        self.observation_space = spaces.Dict(
            {
                "echoes": spaces.Box(floor_db, ceiling_db, (2, self.n_range_bins), np.float32),
                "velocity": spaces.Box(-vmax, vmax, (3,), np.float32),
                "attitude": spaces.Box(-np.pi, np.pi, (3,), np.float32),
                "goal": spaces.Box(
                    np.array([-np.pi, 0.0], np.float32), np.array([np.pi, dmax], np.float32)
                ),
            }
        )
        self.forest: Forest | None = None
        self._forests: dict[int, Forest] = {}
        self.sim: QuadrotorSim | None = None
        self._state: np.ndarray | None = None
        self.goal = np.zeros(3)
        self.path: list[np.ndarray] = []
        self._echo_db = np.full((2, self.n_range_bins), self.floor_db)
        self._steps = 0
        #: Whether the episode has terminated or been truncated (step() then needs a reset).
        self._ended = False

    # -- an episode ---------------------------------------------------------------------------

    def _draw_forest(self) -> Forest:
        """A forest whose start and goal keep twice the drone's radius plus 0.5 m from it."""
        half = self.width_m / 2.0
        window = (self.trees_from_m, self.length_m - self.trees_from_m, -half, half)
        need = 2.0 * self.drone_radius_m + 0.5
        ends = np.array([self.start, self.goal])
        density = self.density
        intensity = UniformIntensity(density)
        for _ in range(_MAX_DRAWS):
            seed = int(self.np_random.integers(2**63))
            if seed in self._forests:  # the same seed's forest as an earlier episode's
                forest = self._forests[seed]
                if forest.n_trees == 0 or float(forest.clearance(ends).min()) >= need:
                    return forest
                continue
            forest = Forest.from_ipp(
                intensity,
                window,
                seed,
                tree_params=self.tree_params,
                variants=self.variants,
                lambda_max=max(density, 1e-12),
            )
            self._forests = {seed: forest}  # kept for the next episode of the same seed
            if forest.n_trees == 0 or float(forest.clearance(ends).min()) >= need:
                return forest
        raise RuntimeError(
            f"no forest of density {self.density} trees/m^2 in {_MAX_DRAWS} draws left the "
            f"start and goal {need:.2f} m clear; lower density or raise altitude_m"
        )

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """A new forest, start and goal, all drawn from ``seed`` (or the environment's
        generator); a NumPy integer seed is the Python int it equals."""
        if isinstance(seed, np.integer):  # (Gymnasium refuses NumPy integers)
            seed = int(seed)
        super().reset(seed=seed)
        q = self.width_m / 4.0
        self.start = np.array([0.0, float(self.np_random.uniform(-q, q)), self.altitude_m])
        self.goal = np.array([self.length_m, float(self.np_random.uniform(-q, q)), self.altitude_m])
        self.forest = self._draw_forest()
        state = self.quadrotor.initial_state(Hover(self.start, yaw_deg=0.0))
        if self.sim is None:
            self.sim = QuadrotorSim(self.quadrotor, state)
        else:
            self.sim.reset(state)
        self._state = self.sim.state.vectors[0]
        self._steps = 0
        self._ended = False
        self.path = [self.start.copy()]
        self._echo_db = self._pulse()
        return self._observation(), self._info(
            self._path_clearance(self.start[None, :]), False, False, False
        )

    # -- a step -------------------------------------------------------------------------------

    def command(self, action: Any) -> tuple[np.ndarray, float]:
        """The world velocity (3,) m/s and yaw rate (rad/s) that ``action`` commands now."""
        try:
            a = np.asarray(action, dtype=np.float64)
        except (TypeError, ValueError):
            a = np.full(0, np.nan)  # not numbers: refused below
        if a.shape != (4,) or not np.all(np.isfinite(a)):
            raise ValueError(f"action must be 4 finite numbers, shape (4,), got {action!r}")
        u = np.clip(a, -1.0, 1.0) * self.scales
        psi = _yaw(self.drone_state()[6:15].reshape(3, 3))
        c, s = math.cos(psi), math.sin(psi)
        return np.array([c * u[0] - s * u[1], s * u[0] + c * u[1], u[2]]), float(u[3])

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        if self.sim is None or self.forest is None:
            raise RuntimeError("call reset() before step()")
        if self._ended:
            raise RuntimeError(
                "the episode has ended (terminated or truncated): call reset() before step()"
            )
        velocity, yaw_rate = self.command(action)
        before = self._goal_distance()
        self._state = self.sim.step(
            velocity, yaw_rate, dt=self.dt, n_steps=self.n_substeps
        ).vectors[0]
        # the pulse runs in Rust while the clearance, reward and ends are found here
        pulse = start_echo_levels([self])
        ends = self.after_flight(action, before, self.sim.path[0])
        self._echo_db = pulse()[0]
        return self._observation(), *ends

    def after_flight(
        self, action: Any, before: float, path: np.ndarray
    ) -> tuple[float, bool, bool, dict[str, Any]]:
        """The reward, terminated, truncated and info of a step whose flight took the drone
        along ``path`` (k, 3) (its positions after each RK4 step) from ``before`` m off the
        goal; the drone's state is already the step's last."""
        self._steps += 1
        self.path.append(path[-1].copy())
        clearance = self._path_clearance(path)
        collision = clearance < self.drone_radius_m
        p = path[-1]
        half = self.width_m / 2.0
        out = not collision and bool(
            p[0] < -self.trees_from_m
            or p[0] > self.length_m + self.goal_radius_m
            or abs(p[1]) > half
            or p[2] > self.ceiling_m
        )
        success = not (collision or out) and self._goal_distance() <= self.goal_radius_m
        a = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        reward = before - self._goal_distance() - self.effort_weight * float(a @ a)
        if collision or out:
            reward -= self.collision_penalty
        if success:
            reward += self.success_reward
        terminated = collision or out or success
        truncated = not terminated and self._steps >= self.max_steps
        self._ended = terminated or truncated
        return (
            float(reward),
            bool(terminated),
            bool(truncated),
            self._info(clearance, collision, out, success),
        )

    def _path_clearance(self, path: np.ndarray) -> float:
        """The smallest distance (m) from ``path`` (k, 3) to the forest's leaves, branches
        (with ``branches``) and bark and to the ground, exact up to
        :attr:`clearance_horizon_m` and clipped there."""
        assert self.forest is not None
        d = min(float(path[:, 2].min()), self.clearance_horizon_m)
        # (below the ground, d < 0: no distance to the forest can be smaller)
        if self.forest.n_trees and d > 0.0:
            d = self.echo_scene().min_clearance(path, d)
            d = min(d, self.forest.bark_grid().set_clearance(path, d))
        return d

    # -- what the drone senses ----------------------------------------------------------------

    def drone_state(self) -> np.ndarray:
        """The drone's state now, (22,) in :meth:`~batecho.QuadState.vector`'s layout."""
        if self._state is None:
            raise RuntimeError("call reset() first: no episode has started")
        return self._state

    def echo_scene(self) -> Scene:
        """The scene that echoes: the forest's leaves and, with ``branches``, its wood."""
        assert self.forest is not None
        return self.forest.scene(branches=self.branches)

    def ear_poses(self) -> Poses:
        """The two ears' poses now (their places and the directions they face): left, then
        right."""
        st = self.drone_state()
        p, R = st[0:3], st[6:15].reshape(3, 3)
        return Poses.concatenate([ear.pose(p, R) for ear in self.ears])

    def _pulse(self) -> np.ndarray:
        return echo_levels([self])[0]

    def _goal_distance(self) -> float:
        return float(np.hypot(*(self.goal[:2] - self.drone_state()[0:2])))

    def _observation(self) -> dict[str, np.ndarray]:
        st = self.drone_state()
        R, p = st[6:15].reshape(3, 3), st[0:3]
        d = self.goal[:2] - p[:2]
        vmax = self.max_observed_speed_mps
        bearing = _wrap(math.atan2(float(d[1]), float(d[0])) - _yaw(R))
        return {
            "echoes": self._echo_db.astype(np.float32),
            "velocity": np.clip(R.T @ st[3:6], -vmax, vmax).astype(np.float32),
            "attitude": _euler_zyx(R).astype(np.float32),
            "goal": np.array([bearing, min(math.hypot(*d), self.max_goal_distance_m)], np.float32),
        }

    def _info(self, clearance: float, collision: bool, out: bool, success: bool) -> dict[str, Any]:
        return {
            "clearance_m": clearance,
            "collision": collision,
            "out_of_bounds": out,
            "is_success": success,
            "time_s": self._steps / self.pulse_rate_hz,
            "position": self.drone_state()[0:3].copy(),
        }

    # -- pictures -----------------------------------------------------------------------------

    def render(self) -> np.ndarray | None:
        """An RGB array (h, w, 3) uint8 of the forest from above, the path so far and each
        ear's lobe now (``render_mode="rgb_array"``); None without a render mode."""
        if self.render_mode is None:
            return None
        if self.forest is None:
            raise RuntimeError("call reset() before render()")
        from .render import top_view

        return top_view(self)
