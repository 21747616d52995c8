"""Flying step by step: :class:`QuadrotorSim` flies one or many drones of one airframe under
velocity-and-yaw-rate commands, a command in and a state out, in the Rust core (drones in
parallel, the same results for any thread count).

A command holds for one call of :meth:`QuadrotorSim.step`. Its reference starts at the
drone's position and heading at the call and moves level at the commanded velocity while the
heading turns at the commanded rate (:class:`batecho.flight.trajectories.Cruise`); the SE(3)
controller tracks it through the full dynamics of docs/model.md §8 with fixed RK4 steps.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core
from .._pickle import ReadOnlyOnLoading
from .._resources import check_memory
from .._validate import finite, finite_scalar, integer, positive_scalar, readonly, real_array
from .vehicle import Quadrotor, QuadState

__all__ = ["QuadrotorSim", "SwarmState"]

#: Memory per drone of a simulation (bytes): its state rows in Python and in Rust, with room
#: for the integrator's temporaries.
BYTES_PER_DRONE = 1000.0
#: Memory per drone and RK4 step of :meth:`QuadrotorSim.step` (bytes): the path's position
#: (3 f64) in Rust and in the returned array.
BYTES_PER_PATH_POINT = 48.0


@dataclass(frozen=True, eq=False)
class SwarmState(ReadOnlyOnLoading):
    """The states of n drones at ``time`` (s): ``positions``, ``velocities`` (n, 3) world;
    ``attitudes`` (n, 3, 3) body -> world; ``angular_velocities`` (n, 3) body rad/s;
    ``rotor_speeds`` (n, 4) rad/s; ``vectors`` (n, 22) in :meth:`QuadState.vector`'s layout.
    Read-only views of one array."""

    time: float
    vectors: np.ndarray

    @property
    def positions(self) -> np.ndarray:
        return self.vectors[:, 0:3]

    @property
    def velocities(self) -> np.ndarray:
        return self.vectors[:, 3:6]

    @property
    def attitudes(self) -> np.ndarray:
        return self.vectors[:, 6:15].reshape(-1, 3, 3)

    @property
    def angular_velocities(self) -> np.ndarray:
        return self.vectors[:, 15:18]

    @property
    def rotor_speeds(self) -> np.ndarray:
        return self.vectors[:, 18:22]

    def __len__(self) -> int:
        return len(self.vectors)

    def state(self, i: int) -> QuadState:
        """Drone ``i``'s state."""
        y = self.vectors[i]
        return QuadState(y[0:3], y[3:6], y[6:15].reshape(3, 3), y[15:18], y[18:22])


def _state_rows(states: Any, n: int | None) -> np.ndarray:
    if isinstance(states, QuadState):
        states = [states]
    if isinstance(states, (list, tuple)) and states and isinstance(states[0], QuadState):
        if not all(isinstance(s, QuadState) for s in states):
            raise TypeError("states must all be QuadState")
        rows = np.stack([s.vector() for s in states])
    else:
        rows = finite(real_array(states, "states"), "states")
        if rows.ndim == 1:
            rows = rows[None, :]
        if rows.ndim != 2 or rows.shape[1] != 22:
            raise ValueError(f"states must have shape (n, 22), got {rows.shape}")
    if n is not None and len(rows) == 1 and n > 1:
        rows = np.repeat(rows, n, axis=0)
    if n is not None and len(rows) != n:
        raise ValueError(f"n_drones = {n} but {len(rows)} states were given; give one or {n}")
    return rows


class QuadrotorSim:
    """Drones of one :class:`~batecho.flight.vehicle.Quadrotor` flown step by step.

    ``QuadrotorSim(quad, states)``: ``states`` is a :class:`QuadState`, a list of them, or an
    (n, 22) array (see :meth:`QuadState.vector`); one state with ``n_drones`` > 1 starts every
    drone there (otherwise ``n_drones``, if given, must be the number of states). :meth:`step`
    takes a velocity-and-yaw-rate command per drone and returns their new
    :class:`SwarmState`; :attr:`path` holds the positions after every RK4 step of the last
    call.
    """

    def __init__(self, quadrotor: Quadrotor, states: Any, n_drones: int | None = None):
        if not isinstance(quadrotor, Quadrotor):
            raise TypeError("quadrotor must be a batecho.Quadrotor")
        if n_drones is not None:
            n_drones = integer(n_drones, "n_drones", 1)
            check_memory(
                n_drones * BYTES_PER_DRONE,
                f"a simulation of n_drones = {n_drones} drones",
                "fly fewer drones per simulation",
            )
        self.quadrotor = quadrotor
        rows = _state_rows(states, n_drones)
        self._swarm = _core.Swarm(quadrotor._airframe, rows)
        self.time = 0.0
        self.path = readonly(np.empty((len(rows), 0, 3)))

    def __getstate__(self) -> dict[str, Any]:
        # The Rust swarm does not pickle; it holds nothing but the airframe and the states.
        return {
            "quadrotor": self.quadrotor,
            "states": np.array(self._swarm.states),
            "time": self.time,
            "path": self.path,
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["quadrotor"], state["states"])  # type: ignore[misc]
        self.time = state["time"]
        self.path = readonly(np.array(state["path"]))

    @property
    def n_drones(self) -> int:
        return self._swarm.n_drones

    @property
    def state(self) -> SwarmState:
        """The drones' current states."""
        return SwarmState(self.time, readonly(self._swarm.states))

    def reset(self, states: Any, time: float = 0.0) -> SwarmState:
        """Puts the drones at ``states`` (as in the constructor; their number may change) and
        the clock at ``time`` (s)."""
        t = finite_scalar(time, "time")
        self._swarm.reset(_state_rows(states, None))
        self.time = t
        self.path = readonly(np.empty((self.n_drones, 0, 3)))
        return self.state

    def step(
        self,
        velocity: Any,
        yaw_rate: Any = 0.0,
        *,
        dt: float = 1e-3,
        n_steps: int = 1,
        wind: Any = None,
    ) -> SwarmState:
        """Flies ``n_steps`` RK4 steps of ``dt`` s under the command ``velocity`` ((3,) or
        (n, 3) m/s, world) and ``yaw_rate`` (scalar or (n,) rad/s), with the wind ``wind``
        ((3,) or (n, 3) m/s, default calm) held over the call. Returns the new states."""
        n = self.n_drones
        v = finite(real_array(velocity, "velocity"), "velocity")
        v = np.broadcast_to(v, (n, 3)) if v.shape in ((3,), (1, 3)) else v
        if v.shape != (n, 3):
            raise ValueError(f"velocity must have shape (3,) or ({n}, 3), got {v.shape}")
        r = finite(real_array(yaw_rate, "yaw_rate"), "yaw_rate")
        r = np.broadcast_to(r, (n,)) if r.ndim == 0 or r.shape == (1,) else r
        if r.shape != (n,):
            raise ValueError(f"yaw_rate must be a scalar or have shape ({n},), got {r.shape}")
        w = np.zeros((n, 3)) if wind is None else finite(real_array(wind, "wind"), "wind")
        w = np.broadcast_to(w, (n, 3)) if w.shape in ((3,), (1, 3)) else w
        if w.shape != (n, 3):
            raise ValueError(f"wind must have shape (3,) or ({n}, 3), got {w.shape}")
        h = positive_scalar(dt, "dt")
        tau = self.quadrotor.motor_time_constant
        if h > tau:  # (as the core refuses it, with dt in a few digits)
            raise ValueError(
                f"dt={h:g} s exceeds the motor time constant {tau:g} s; RK4 would be inaccurate"
            )
        if isinstance(n_steps, bool) or not isinstance(n_steps, numbers.Real):
            raise TypeError(f"n_steps must be an integer >= 1, got {n_steps!r}")
        if not float(n_steps).is_integer() or n_steps < 1:
            raise ValueError(f"n_steps must be an integer >= 1, got {n_steps!r}")
        # (a count beyond any memory in a few digits, not hundreds)
        steps = f"{int(n_steps)}" if n_steps < 1e15 else f"{float(n_steps):.3g}"
        check_memory(
            float(n) * float(n_steps) * BYTES_PER_PATH_POINT,
            f"a step of {n} drones by n_steps = {steps} RK4 steps (its path)",
            "step fewer RK4 steps per call",
        )
        path = self._swarm.step(
            np.ascontiguousarray(v),
            np.ascontiguousarray(r),
            np.ascontiguousarray(w),
            h,
            int(n_steps),
        )
        self.time += int(n_steps) * h
        self.path = readonly(path)
        return self.state

    def __repr__(self) -> str:
        return f"QuadrotorSim(n_drones={self.n_drones}, t={self.time:.6g} s)"
