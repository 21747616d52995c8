"""The baselines of batecho/EchoFlight-v0 side by side: success, collision, out-of-bounds and
time-out rates of the blind and echo-reactive policies over the same seeded forests at several
densities, as a Markdown table (with the seeds), and a picture of typical episodes.

Usage::

    python benches/baselines.py                       # 100 forests at 0.03 and 0.06 trees/m^2
    python benches/baselines.py --episodes 20 --densities 0.02 0.05 --out baselines-out
    python benches/baselines.py --max-minutes 30       # as many forests as finish in 30 min
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from batecho.envs import EchoFlightEnv
from batecho.envs.baselines import blind, echo_reactive

POLICIES = {"blind": blind, "echo_reactive": echo_reactive}
OUTCOMES = ("is_success", "collision", "out_of_bounds", "truncated")


def episode(env: EchoFlightEnv, make_policy, seed: int) -> tuple[str, np.ndarray, float]:
    """One episode: its outcome (one of OUTCOMES), path (k, 3) and duration (s)."""
    obs, info = env.reset(seed=seed)
    policy = make_policy(env)
    while True:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated:
            break
    for key in OUTCOMES[:3]:
        if info[key]:
            return key, np.array(env.path), info["time_s"]
    return "truncated", np.array(env.path), info["time_s"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=100, help="seeded forests per density")
    ap.add_argument("--densities", type=float, nargs="+", default=[0.03, 0.06])
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("baselines-out"))
    ap.add_argument(
        "--max-minutes",
        type=float,
        default=None,
        help="stop after the first forest that ends past this wall time (the table and the "
        "picture cover the forests that finished)",
    )
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    seeds = range(args.first_seed, args.first_seed + args.episodes)
    examples: dict = {}
    envs = {d: EchoFlightEnv(density=d) for d in args.densities}
    counts = {(d, name): dict.fromkeys(OUTCOMES, 0) for d in args.densities for name in POLICIES}
    t0 = time.perf_counter()
    # seed by seed, every density and policy: a run stopped early has as many of each
    for k, seed in enumerate(seeds):
        for density, env in envs.items():
            for name, make in POLICIES.items():
                outcome, path, _ = episode(env, make, seed)
                counts[(density, name)][outcome] += 1
                if seed == args.first_seed:
                    examples[(density, name)] = (path, outcome)
        table = _table(seeds.start, k + 1, counts)
        (args.out / "baselines.md").write_text(table + "\n")
        elapsed = time.perf_counter() - t0
        print(f"{k + 1} forests per density after {elapsed:.0f} s", flush=True)
        if args.max_minutes is not None and elapsed > 60.0 * args.max_minutes:
            break
    print(table)
    _picture(args, examples)


def _table(first: int, n: int, counts: dict) -> str:
    """The Markdown table of the rates over the ``n`` forests of seeds ``first`` onward."""
    rows = [
        f"| {density:g} | {name} | {c['is_success'] / n:.2f} | {c['collision'] / n:.2f} | "
        f"{c['out_of_bounds'] / n:.2f} | {c['truncated'] / n:.2f} |"
        for (density, name), c in counts.items()
    ]
    return "\n".join(
        [
            f"Seeds {first}..{first + n - 1} (reset(seed=s)), {n} forests per density, default "
            "EchoFlightEnv otherwise.",
            "",
            "| density (trees/m^2) | policy | success | collision | out of bounds | time out |",
            "|---|---|---|---|---|---|",
            *rows,
        ]
    )


def _picture(args: argparse.Namespace, examples: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from batecho.envs.render import draw_episode

    n = len(args.densities)
    fig, axes = plt.subplots(n, 1, figsize=(7.5, 3.6 * n), squeeze=False)
    colours = {"blind": "#7f8c8d", "echo_reactive": "#c0392b"}
    for ax, density in zip(axes[:, 0], args.densities, strict=True):
        env = EchoFlightEnv(density=density)
        env.reset(seed=args.first_seed)
        draw_episode(ax, env, path=np.zeros((0, 3)), lobes=False)
        for name in POLICIES:
            path, outcome = examples[(density, name)]
            ax.plot(path[:, 0], path[:, 1], color=colours[name], lw=1.6, label=f"{name}: {outcome}")
        ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
        ax.set_title(f"density {density:g} trees/m², seed {args.first_seed}", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out / "baselines.png", dpi=130)
    print(f"wrote {args.out / 'baselines.png'} and {args.out / 'baselines.md'}")


if __name__ == "__main__":
    main()
