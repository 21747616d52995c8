"""batecho/EchoFlight-v0 steps per second: one environment, a batch of N in the native vector
environment (``EchoFlightVectorEnv``: one Rust call flies the drones, one sends the pulses) and,
for comparison, N in Gymnasium's synchronous loop, in the default forest (density 0.03
trees/m^2 on 24 m x 14 m, 1.6e5 leaves with seed 1) with the environment's defaults (two ears;
branches and shading as ``DEFAULT_BRANCHES`` and ``DEFAULT_SHADING`` say, or as forced here).

Every drone first flies ahead (untimed) to ``--x-m`` (12 m with seed 1: 4-5 m short of a
crown it hears) and then hovers there while the steps are timed: a step's work -- 50 RK4
steps, the clearance along them, a pulse to both ears, echoes from ~1,000 leaves -- without an
episode's end. ``--split`` times the parts of one environment's step.

Usage::

    python benches/bench_envs.py                  # 1 env, 8 native, 8 sync; 200 steps each
    python benches/bench_envs.py --batch 8 --steps 400 --split
    python benches/bench_envs.py --branches --shading   # force both on
    python benches/bench_envs.py --leaves-only          # branches off
"""

from __future__ import annotations

import argparse
import os
import time
from typing import Any

import gymnasium as gym
import numpy as np

from batecho import Shading
from batecho.envs import ENV_ID, EchoFlightEnv, pulses

FORWARD = np.array([1.0, 0.0, 0.0, 0.0], np.float32)


def fly_in(envs: Any, n: int, x_m: float) -> None:
    """Fly the batch's drones ahead until every one is at ``x_m`` (or its episode ended)."""
    for _ in range(2000):
        xs = np.array([e.unwrapped.drone_state()[0] for e in getattr(envs, "envs", [envs])])
        go = xs < x_m
        if not go.any():
            return
        action = np.where(go[:, None], FORWARD, 0.0).astype(np.float32)
        out = envs.step(action if n > 1 or hasattr(envs, "num_envs") else action[0])
        if np.any(out[2]):
            raise RuntimeError("a drone collided on its way in; choose another --x-m or --seed")


def steps_per_second(
    mode: str, n: int, steps: int, seed: int, x_m: float, kw: dict[str, Any]
) -> tuple[float, int, float]:
    """Environment steps per second, the forest's leaves and the loudest echo heard (dB)."""
    if mode == "single":
        envs: Any = EchoFlightEnv(**kw)
        envs.reset(seed=seed)
        zero: np.ndarray = np.zeros(4, np.float32)
    else:
        envs = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode=mode, **kw)
        envs.reset(seed=[seed] * n)
        zero = np.zeros((n, 4), np.float32)
    first = envs.envs[0].unwrapped if hasattr(envs, "envs") else envs
    fly_in(envs, n, x_m)
    envs.step(zero)
    t = time.perf_counter()
    for _ in range(steps):
        obs = envs.step(zero)[0]
    dt = time.perf_counter() - t
    envs.close()
    return n * steps / dt, first.forest.n_leaves, float(np.max(obs["echoes"]))


def split(steps: int, seed: int, x_m: float, kw: dict[str, Any]) -> dict[str, float]:
    """Seconds per step of one environment's parts: the flight, the clearance along it, the
    pulse (Rust), the envelope and range bins, and the rest (Python)."""
    env = EchoFlightEnv(**kw)
    env.reset(seed=seed)
    fly_in(env, 1, x_m)
    parts: dict[str, float] = {}

    def timed(obj: Any, name: str, key: str) -> None:
        f = getattr(obj, name)

        def g(*args: Any, **kwargs: Any) -> Any:
            t = time.perf_counter()
            r = f(*args, **kwargs)
            parts[key] = parts.get(key, 0.0) + time.perf_counter() - t
            return r

        setattr(obj, name, g)

    assert env.sim is not None
    timed(env.sim, "step", "flight (Rust RK4)")
    timed(env, "_path_clearance", "clearance along the path")
    timed(pulses._core, "simulate_many", "pulse (Rust simulate)")
    timed(pulses, "band_envelope", "envelope")
    timed(env.echo_bins, "levels", "range bins")
    zero = np.zeros(4, np.float32)
    env.step(zero)
    parts.clear()
    t = time.perf_counter()
    for _ in range(steps):
        env.step(zero)
    total = time.perf_counter() - t
    out = {k: v / steps for k, v in parts.items()}
    out["rest (Python)"] = total / steps - sum(out.values())
    out["total"] = total / steps
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--steps", type=int, default=200, help="vector steps timed")
    ap.add_argument("--seed", type=int, default=1, help="seed 1: 11 trees, 1.6e5 leaves")
    ap.add_argument("--x-m", type=float, default=12.0, help="where the drones hover (m)")
    ap.add_argument("--branches", action="store_true", help="branches on, whatever the default")
    ap.add_argument("--leaves-only", action="store_true", help="branches off")
    ap.add_argument("--shading", action="store_true", help="shading on, whatever the default")
    ap.add_argument("--split", action="store_true", help="time the parts of one env's step")
    args = ap.parse_args()
    kw: dict[str, Any] = {}
    if args.branches or args.leaves_only:
        kw["branches"] = not args.leaves_only
    if args.shading:
        kw["shading"] = Shading()
    probe = EchoFlightEnv(**kw)
    what = (
        f"two ears, branches {'on' if probe.branches else 'off'}, "
        f"shading {'on' if probe.shading is not None else 'off'}, "
        f"{os.environ.get('RAYON_NUM_THREADS', 'all')} threads"
    )
    for mode, n in (("single", 1), ("vector_entry_point", args.batch), ("sync", args.batch)):
        rate, leaves, loudest = steps_per_second(mode, n, args.steps, args.seed, args.x_m, kw)
        print(
            f"{n} env(s), {mode:18s}: {rate:8.1f} env steps/s ({leaves:.3g} leaves, {what}; "
            f"loudest echo {loudest:.0f} dB)"
        )
    if args.split:
        for key, sec in split(args.steps, args.seed, args.x_m, kw).items():
            print(f"  {key:28s} {sec * 1e3:7.3f} ms/step")


if __name__ == "__main__":
    main()
