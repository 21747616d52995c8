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

__all__ = ["Policy", "blind", "echo_reactive"]

Policy = Callable[[dict[str, np.ndarray]], np.ndarray]


def _unwrapped(env: Any) -> Any:
    return getattr(env, "unwrapped", env)


def _toward_goal(obs: dict[str, np.ndarray], gain: float) -> float:
    """The yaw-rate command (in [-1, 1]) that turns toward the goal's bearing."""
    return float(np.clip(gain * float(obs["goal"][0]), -1.0, 1.0))


def blind(env: Any, turn_gain: float = 2.0) -> Policy:
    """A policy that flies straight at the goal at full speed, ignoring the echoes: yaw rate
    ``turn_gain`` times the goal's bearing (clipped), forward speed slowed only while it turns
    (by the cosine of the bearing)."""

    def policy(obs: dict[str, np.ndarray]) -> np.ndarray:
        bearing = float(obs["goal"][0])
        forward = max(0.0, float(np.cos(bearing)))
        return np.array([forward, 0.0, 0.0, _toward_goal(obs, turn_gain)], np.float32)

    return policy


def echo_reactive(
    env: Any,
    threshold_db: float = -60.0,
    near_m: float = 4.0,
    stop_m: float = 1.0,
    turn_gain: float = 2.0,
    min_speed: float = 0.15,
) -> Policy:
    """A policy that steers by the two ears' echoes (see the module docstring).

    ``threshold_db``: an echo level (dB re 1) above which a range bin holds an obstacle;
    ``near_m``: within this range echoes steer and slow the drone; ``stop_m``: the range at
    which it is down to ``min_speed`` (a fraction of full speed); ``turn_gain``: how hard it
    turns toward the goal when the way is clear.
    """
    e = _unwrapped(env)
    n_bins, reach = int(e.n_range_bins), float(e.reach_m)
    ranges = (np.arange(n_bins) + 0.5) * reach / n_bins
    near = ranges <= near_m
    floor = float(e.floor_db)

    def policy(obs: dict[str, np.ndarray]) -> np.ndarray:
        db = np.asarray(obs["echoes"], dtype=np.float64)
        loud = db > threshold_db
        # how loud each ear's near echoes are, in dB above the threshold, weighted by nearness
        excess = np.where(loud & near, db - threshold_db, 0.0) * (near_m / ranges)
        left, right = excess.sum(axis=1)
        hits = np.flatnonzero(loud.any(axis=0))
        nearest = float(ranges[hits[0]]) if hits.size else np.inf
        closeness = float(np.clip((near_m - nearest) / (near_m - stop_m), 0.0, 1.0))
        speed = 1.0 - (1.0 - min_speed) * closeness
        if left + right > 0:
            away = (right - left) / (left + right)  # > 0: the left is louder, go right... no
            turn = float(np.clip(-np.sign(left - right) * (0.4 + closeness), -1.0, 1.0))
            if away == 0.0:
                turn = 1.0 if float(obs["goal"][0]) <= 0 else -1.0
            side = 0.6 * turn * closeness
        else:
            turn, side = _toward_goal(obs, turn_gain), 0.0
        del floor
        return np.array([speed, side, 0.0, turn], np.float32)

    return policy
