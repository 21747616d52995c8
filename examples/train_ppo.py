"""Train a Stable-Baselines3 PPO agent on batecho/EchoFlight-v0 for a short budget, then fly it
and the two baselines (blind, echo-reactive) through the same seeded forests and print their
success and collision rates side by side. An example, not part of CI.

Usage::

    pip install "batecho[env]" stable-baselines3     # torch comes with it
    python examples/train_ppo.py --steps 50000 --envs 4 --episodes 20 --out ppo-out
    python examples/train_ppo.py --steps 300000 --leaves-only   # trees without branches

The agent is SB3's ``MultiInputPolicy`` (an MLP over the Dict observation) with observations
and rewards normalised by ``VecNormalize``; it is evaluated deterministically on forests of
seeds ``--eval-seed`` onward, which training never draws (training seeds its environments
from ``--seed``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

try:
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize
except ImportError as e:  # pragma: no cover - an example with an optional dependency
    raise SystemExit(
        "examples/train_ppo.py needs Stable-Baselines3 (and torch): pip install stable-baselines3"
    ) from e

from batecho.envs import ENV_ID
from batecho.envs.baselines import blind, echo_reactive


def episode(env: gym.Env, act: Any, seed: int) -> dict[str, Any]:
    """One episode of ``act`` (observation -> action) on the forest of ``seed``."""
    obs, info = env.reset(seed=seed)
    steps = 0
    while True:
        obs, _, terminated, truncated, info = env.step(act(obs))
        steps += 1
        if terminated or truncated:
            break
    return {
        "seed": seed,
        "success": bool(info["is_success"]),
        "collision": bool(info["collision"]),
        "out_of_bounds": bool(info["out_of_bounds"]),
        "time_s": float(info["time_s"]),
        "steps": steps,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=50_000, help="training environment steps")
    ap.add_argument("--envs", type=int, default=4, help="environments trained in parallel")
    ap.add_argument("--density", type=float, default=0.03, help="trees per m^2")
    ap.add_argument(
        "--leaves-only", action="store_true", help="trees without branches (faster steps)"
    )
    ap.add_argument("--episodes", type=int, default=20, help="evaluation episodes per policy")
    ap.add_argument("--seed", type=int, default=0, help="training seed")
    ap.add_argument("--eval-seed", type=int, default=1_000_000, help="first evaluation forest")
    ap.add_argument("--out", type=Path, default=Path("ppo-out"))
    ap.add_argument(
        "--eval-only", action="store_true", help="evaluate the agent saved in --out, untrained"
    )
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    env_kw: dict[str, Any] = {"density": args.density}
    if args.leaves_only:
        env_kw["branches"] = False

    train = VecNormalize(
        make_vec_env(ENV_ID, n_envs=args.envs, seed=args.seed, env_kwargs=env_kw),
        norm_obs=True,
        norm_reward=True,
    )
    t0 = time.perf_counter()
    if args.eval_only:
        train = VecNormalize.load(str(args.out / "vecnormalize.pkl"), train.venv)
        model = PPO.load(args.out / "ppo_echoflight", device="cpu")
    else:
        model = PPO(
            "MultiInputPolicy",
            train,
            n_steps=256,
            batch_size=256,
            learning_rate=3e-4,
            gamma=0.99,
            seed=args.seed,
            verbose=1,
            device="cpu",
        )
        model.learn(total_timesteps=args.steps)
        model.save(args.out / "ppo_echoflight")
        train.save(str(args.out / "vecnormalize.pkl"))
    train_s = time.perf_counter() - t0
    train.training = False

    def ppo(obs: dict[str, np.ndarray]) -> np.ndarray:
        action, _ = model.predict(train.normalize_obs(obs), deterministic=True)
        return np.asarray(action, np.float32)

    env = gym.make(ENV_ID, **env_kw)
    seeds = [args.eval_seed + k for k in range(args.episodes)]
    policies = {"ppo": ppo, "blind": blind(env), "echo_reactive": echo_reactive(env)}
    results: dict[str, Any] = {
        "train_steps": args.steps,
        "train_envs": args.envs,
        "train_wall_s": round(train_s, 1),
        "density": args.density,
        "branches": not args.leaves_only,
        "eval_seeds": seeds,
        "policies": {},
    }
    for name, act in policies.items():
        runs = [episode(env, act, s) for s in seeds]
        rate = {k: float(np.mean([r[k] for r in runs])) for k in ("success", "collision")}
        results["policies"][name] = {**rate, "episodes": runs}
        print(
            f"{name:14s} success {rate['success']:5.0%}  collision {rate['collision']:5.0%}  "
            f"({len(runs)} forests of density {args.density}, seeds {seeds[0]}-{seeds[-1]})"
        )
    print(f"trained {args.steps} steps in {train_s / 60:.1f} min")
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
    print(f"wrote {args.out / 'results.json'}")


if __name__ == "__main__":
    main()
