"""batecho/EchoFlight-v0 steps per second: one environment, and a batch of N in Gymnasium's
synchronous vector environment, in the default forest (density 0.03 trees/m^2 on 24 m x 14 m,
about 1.6e5 leaves), two ears, a pulse per step. Resets are not timed; every environment hovers at
its start in the same seed's forest (a step's work -- 50 RK4 steps, the clearance along them,
a pulse to both ears -- without an episode's end).

Usage::

    python benches/bench_envs.py                  # 1 and 8 environments, 200 steps each
    python benches/bench_envs.py --batch 8 --steps 400
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium as gym
import numpy as np

from batecho.envs import ENV_ID


def steps_per_second(n_envs: int, steps: int, seed: int) -> tuple[float, int]:
    """Environment steps per second (n_envs steps per vector step) and the forest's leaves."""
    envs = gym.make_vec(ENV_ID, num_envs=n_envs, vectorization_mode="sync")
    envs.reset(seed=[seed] * n_envs)
    leaves = envs.unwrapped.envs[0].unwrapped.forest.n_leaves  # type: ignore[attr-defined]
    action = np.tile(np.zeros(4, np.float32), (n_envs, 1))
    envs.step(action)  # warm: the sonar's tables, the first pulse
    t = time.perf_counter()
    for _ in range(steps):
        envs.step(action)
    dt = time.perf_counter() - t
    envs.close()
    return n_envs * steps / dt, leaves


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--steps", type=int, default=200, help="vector steps timed")
    ap.add_argument("--seed", type=int, default=1, help="seed 1: 11 trees, 1.6e5 leaves")
    args = ap.parse_args()
    threads = os.environ.get("RAYON_NUM_THREADS", "all")
    for n in (1, args.batch):
        rate, leaves = steps_per_second(n, args.steps, args.seed)
        print(
            f"{n} env(s): {rate:8.1f} env steps/s ({leaves:.3g} leaves, two ears, "
            f"{threads} threads)"
        )


if __name__ == "__main__":
    main()
