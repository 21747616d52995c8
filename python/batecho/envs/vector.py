"""The native batch of ``batecho/EchoFlight-v0``: N environments stepped together, their drones
flown by one :class:`~batecho.QuadrotorSim` call and their pulses sent through one Rust call
(:mod:`batecho.envs.pulses`), each environment in a forest of its own.

``gymnasium.make_vec("batecho/EchoFlight-v0", num_envs=N)`` gives it (``vectorization_mode``
``None`` or ``"vector_entry_point"``); ``"sync"`` gives Gymnasium's loop over N single
environments, with the same results step for step.
"""

from __future__ import annotations

import math
import numbers
from copy import deepcopy
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from .._validate import integer
from ..flight.sim import QuadrotorSim
from .echo_flight import EchoFlightEnv
from .pulses import start_echo_levels

__all__ = ["EchoFlightVectorEnv"]


class EchoFlightVectorEnv(VectorEnv):
    """``num_envs`` :class:`~batecho.envs.EchoFlightEnv` made with the same keyword
    arguments, stepped as one: each step flies every drone by one Rust call and sends every
    pulse by another. Each environment's observations, rewards, ends and infos are those it
    gives alone, step for step, bit for bit. An environment that ended is reset on the next
    step (Gymnasium's ``NEXT_STEP`` autoreset, as in ``SyncVectorEnv``); ``reset(seed=s)``
    seeds environment ``i`` with ``s + i``, or with ``s[i]`` for a list.

    ``max_episode_steps`` (``gymnasium.make_vec(..., max_episode_steps=n)`` passes it) also
    truncates each episode after that many steps, as Gymnasium's ``TimeLimit`` does for
    ``"sync"`` and ``"async"``.
    """

    metadata = {  # noqa: RUF012 (gymnasium's attribute)
        "render_modes": ["rgb_array"],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(self, num_envs: int = 1, max_episode_steps: int | None = None, **kwargs: Any):
        n: Any = num_envs  # (anything a caller passes)
        whole = isinstance(n, numbers.Integral) or (
            isinstance(n, numbers.Real) and math.isfinite(n) and float(n).is_integer()
        )
        if isinstance(n, bool) or not whole or n < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if max_episode_steps is not None:
            max_episode_steps = integer(max_episode_steps, "max_episode_steps", 1)
        self.max_episode_steps = max_episode_steps
        self.envs = [EchoFlightEnv(**kwargs) for _ in range(int(num_envs))]
        first = self.envs[0]
        self.num_envs = len(self.envs)
        self.render_mode = first.render_mode
        # (its frame rate too, as SyncVectorEnv copies it: Gymnasium's vector HumanRendering
        # needs it, and its RecordVideo would play the frames at 30 per second)
        self.metadata = {**type(self).metadata, "render_fps": first.metadata["render_fps"]}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._observations: Any = create_empty_array(self.single_observation_space, self.num_envs)
        self._ended = np.zeros(self.num_envs, dtype=bool)
        self.sim: QuadrotorSim | None = None
        self._flying: list[int] = []

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"seed needs {self.num_envs} seeds, got {len(seeds)}")
        infos: dict[str, Any] = {}
        observations = []
        for i, (env, s) in enumerate(zip(self.envs, seeds, strict=True)):
            obs, info = env.reset(seed=s, options=options)
            observations.append(obs)
            infos = self._add_info(infos, info, i)
        self._ended[:] = False
        self._flying = []  # the drones must be put in the batch's simulation again
        self._observations = concatenate(
            self.single_observation_space, observations, self._observations
        )
        # a copy, as SyncVectorEnv gives: the next step refills the buffer
        return deepcopy(self._observations), infos

    def step(
        self, actions: Any
    ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        try:
            a = np.asarray(actions, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(
                f"actions must be numbers of shape ({self.num_envs}, 4), got {actions!r}"
            ) from None
        if a.shape != (self.num_envs, 4):
            raise ValueError(f"actions must have shape ({self.num_envs}, 4), got {a.shape}")
        if self.envs[0].forest is None:
            raise RuntimeError("call reset() before step()")
        n = self.num_envs
        rewards = np.zeros(n)
        terminated = np.zeros(n, dtype=bool)
        truncated = np.zeros(n, dtype=bool)
        infos: dict[str, Any] = {}
        observations: list[Any] = [None] * n
        flying = [i for i in range(n) if not self._ended[i]]
        # the actions are checked before an ended environment is reset, so that a refused
        # step changes nothing
        commands = [self.envs[i].command(a[i]) for i in flying]
        for j in np.flatnonzero(self._ended).tolist():
            observations[j], info = self.envs[j].reset()
            infos = self._add_info(infos, info, j)
            self._flying = []  # its drone must be put in the batch's simulation again
        if flying:
            before = [self.envs[i]._goal_distance() for i in flying]
            states = self._fly(
                flying, np.array([c[0] for c in commands]), np.array([c[1] for c in commands])
            )
            assert self.sim is not None
            paths = self.sim.path
            for k, i in enumerate(flying):
                self.envs[i]._state = states[k]
            # the pulses run in Rust while the clearances, rewards and ends are found here
            pulses = start_echo_levels([self.envs[i] for i in flying])
            for k, i in enumerate(flying):
                rewards[i], terminated[i], truncated[i], info = self.envs[i].after_flight(
                    a[i], before[k], paths[k]
                )
                # (TimeLimit's rule: truncated at the limit, whether or not it also terminated)
                if self.max_episode_steps is not None:
                    truncated[i] |= self.envs[i]._steps >= self.max_episode_steps
                infos = self._add_info(infos, info, i)
            levels = pulses()
            for i, db in zip(flying, levels, strict=True):
                self.envs[i]._echo_db = db
                observations[i] = self.envs[i]._observation()
        self._ended = terminated | truncated
        self._observations = concatenate(
            self.single_observation_space, observations, self._observations
        )
        return deepcopy(self._observations), rewards, terminated, truncated, infos

    def _fly(self, flying: list[int], velocity: np.ndarray, yaw_rate: np.ndarray) -> np.ndarray:
        """Fly the drones of environments ``flying`` one step under their commands; their
        new states (k, 22)."""
        first = self.envs[0]
        if flying != self._flying or self.sim is None:
            rows = np.stack([self.envs[i].drone_state() for i in flying])
            if self.sim is None:
                self.sim = QuadrotorSim(first.quadrotor, rows)
            else:
                self.sim.reset(rows)
            self._flying = flying
        return self.sim.step(velocity, yaw_rate, dt=first.dt, n_steps=first.n_substeps).vectors

    def render(self) -> tuple[np.ndarray, ...] | None:
        """Each environment's :meth:`~batecho.envs.EchoFlightEnv.render`."""
        if self.render_mode is None:
            return None
        frames = [env.render() for env in self.envs]
        return tuple(f for f in frames if f is not None)
