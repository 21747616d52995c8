"""Baseline policies of ``batecho/EchoFlight-v0``: each a callable from an observation to an
action, made for one environment (its range bins and reach).

- :func:`blind` flies straight at the goal: full speed ahead, turning toward its bearing.
- :func:`echo_reactive` hears its way: it turns and sidesteps away from the ear whose echoes
  are the stronger within ``near_m``, slows as the nearest echo above ``threshold_db`` closes
  in, and turns toward the goal when nothing is near. It reads only the observation.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium.vector import VectorEnv

from .._validate import finite_scalar, positive_scalar

__all__ = ["Policy", "blind", "echo_reactive"]

Policy = Callable[[dict[str, np.ndarray]], np.ndarray]


def _unwrapped(env: Any, name: str) -> Any:
    if isinstance(env, VectorEnv):
        raise TypeError(
            f"{name} is made for one environment, got a vector environment "
            f"{type(env).__name__}: make one policy from a single environment (gymnasium.make) "
            "and call it on each environment's observation"
        )
    return getattr(env, "unwrapped", env)


def _one(obs: dict[str, np.ndarray]) -> None:
    """Refuse anything but one environment's observation (a batch's has a leading axis)."""
    shape = np.shape(obs["goal"])
    if shape != (2,):
        raise ValueError(
            "the policy takes one environment's observation, whose 'goal' has shape (2,), got "
            f"{shape}: call it on each environment's observation of a batch"
        )


def _toward_goal(obs: dict[str, np.ndarray], gain: float) -> float:
    """The yaw-rate command (in [-1, 1]) that turns toward the goal's bearing."""
    return float(np.clip(gain * float(obs["goal"][0]), -1.0, 1.0))


def blind(env: Any, turn_gain: float = 2.0) -> Policy:
    """A policy that flies straight at the goal at full speed, ignoring the echoes: yaw rate
    ``turn_gain`` times the goal's bearing (clipped), forward speed slowed only while it turns
    (by the cosine of the bearing)."""
    _unwrapped(env, "blind")

    def policy(obs: dict[str, np.ndarray]) -> np.ndarray:
        _one(obs)
        bearing = float(obs["goal"][0])
        forward = max(0.0, float(np.cos(bearing)))
        return np.array([forward, 0.0, 0.0, _toward_goal(obs, turn_gain)], np.float32)

    return policy


def echo_reactive(
    env: Any,
    threshold_db: float = -50.0,
    near_m: float = 3.0,
    stop_m: float = 0.8,
    turn_gain: float = 2.0,
    min_speed: float = 0.1,
) -> Policy:
    """A policy that steers by the two ears' echoes (see the module docstring).

    ``threshold_db``: an echo level (dB re 1) above which a range bin holds an obstacle;
    ``near_m``: within this range such echoes steer and slow the drone; ``stop_m``: the range
    at which it is down to ``min_speed`` (a fraction of full speed); ``turn_gain``: how hard it
    turns toward the goal when nothing is near.

    Each ear's loudness is the sum, over its range bins within ``near_m``, of the echo's
    amplitude above the threshold weighted by ``near_m / range``; the drone turns and
    sidesteps away from the louder ear (toward the goal's side when they are equal), the
    harder the nearer the nearest loud echo.
    """
    threshold_db = finite_scalar(threshold_db, "threshold_db")
    near_m = positive_scalar(near_m, "near_m", unit="m")
    stop_m = positive_scalar(stop_m, "stop_m", allow_zero=True, unit="m")
    if not stop_m < near_m:
        raise ValueError(f"stop_m must be below near_m ({near_m} m), got {stop_m} m")
    turn_gain = finite_scalar(turn_gain, "turn_gain")
    min_speed = positive_scalar(min_speed, "min_speed", allow_zero=True)
    if min_speed > 1:
        raise ValueError(f"min_speed must be at most 1 (a fraction of full speed), got {min_speed}")
    e = _unwrapped(env, "echo_reactive")
    n_bins, reach = int(e.n_range_bins), float(e.reach_m)
    ranges = (np.arange(n_bins) + 0.5) * reach / n_bins
    near = ranges <= near_m
    weight = np.where(near, near_m / ranges, 0.0)
    ceiling = float(e.ceiling_db)
    if np.isfinite(ceiling):  # (the loudest echo's amplitude above the threshold, summed)
        with np.errstate(over="ignore"):
            top = (np.float64(10.0) ** ((ceiling - threshold_db) / 20.0) - 1.0) * weight.sum()
        if not np.isfinite(top):
            raise ValueError(
                f"threshold_db = {threshold_db:g} dB is too far below the echoes' ceiling_db "
                f"({ceiling:g} dB): their amplitudes above it overflow float64"
            )

    def policy(obs: dict[str, np.ndarray]) -> np.ndarray:
        _one(obs)
        db = np.asarray(obs["echoes"], dtype=np.float64)
        loud = (db > threshold_db) & near
        amplitude = np.where(loud, 10.0 ** ((db - threshold_db) / 20.0) - 1.0, 0.0)
        left, right = (amplitude * weight).sum(axis=1)
        hits = np.flatnonzero(loud.any(axis=0))
        if not hits.size:
            return np.array([1.0, 0.0, 0.0, _toward_goal(obs, turn_gain)], np.float32)
        nearest = float(ranges[hits[0]])
        closeness = float(np.clip((near_m - nearest) / (near_m - stop_m), 0.0, 1.0))
        balance = (left - right) / (left + right) if left + right > 0 else 0.0
        if abs(balance) < 0.1:  # as loud on both sides: go round on the goal's side
            balance = -1.0 if float(obs["goal"][0]) >= 0 else 1.0
        away = -float(np.sign(balance)) * max(abs(balance), 0.3)
        turn = float(np.clip(away * (0.5 + closeness), -1.0, 1.0))
        speed = 1.0 - (1.0 - min_speed) * closeness
        return np.array([speed, 0.5 * turn * closeness, 0.0, turn], np.float32)

    return policy
