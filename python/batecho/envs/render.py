"""Pictures of an EchoFlight episode: the forest from above, the path flown, each ear's lobe
and the goal, drawn with matplotlib (Agg) as an RGB array or onto given axes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._validate import flag

__all__ = ["draw_episode", "top_view"]

#: Leaves drawn at most (a random subset of a large forest, the same for every frame).
_MAX_LEAVES = 6000


def draw_episode(ax: Any, env: Any, path: np.ndarray | None = None, lobes: bool = True) -> None:
    """Draw ``env``'s forest (leaves from above, trunks as dots), start, goal disc, the path
    ``path`` (k, 3) (default: the path flown so far) and, with ``lobes``, each ear's lobe now
    (a sector of the sonar's reach and beamwidth) onto matplotlib axes ``ax``."""
    from matplotlib.patches import Circle, Wedge

    lobes = flag(lobes, "lobes")
    forest = env.forest
    if forest is not None and forest.n_trees:
        c = forest.leaves.centers
        if len(c) > _MAX_LEAVES:
            c = c[np.random.default_rng(0).choice(len(c), _MAX_LEAVES, replace=False)]
        ax.scatter(c[:, 0], c[:, 1], s=0.3, color="#5a8f3d", alpha=0.35, linewidths=0)
        t = forest.trunk_bases
        ax.scatter(t[:, 0], t[:, 1], s=12, color="#6b4423", zorder=3)
    half = env.width_m / 2.0
    ax.plot([0, env.length_m, env.length_m, 0, 0], [-half, -half, half, half, -half], "k:", lw=0.6)
    ax.add_patch(Circle(tuple(env.goal[:2]), env.goal_radius_m, color="#2b7bba", alpha=0.25))
    ax.plot(*env.start[:2], "o", color="#2b7bba", ms=4)
    p = np.asarray(env.path if path is None else path)
    if len(p):
        ax.plot(p[:, 0], p[:, 1], color="#c0392b", lw=1.4)
    if lobes and env.sim is not None:
        poses = env.ear_poses()
        half_width = float(env.sonar.beamwidth_deg or 30.0) / 2.0
        for pos, fwd, colour in zip(
            poses.positions, poses.forward, ("#8e44ad", "#e67e22"), strict=False
        ):
            theta = math.degrees(math.atan2(fwd[1], fwd[0]))
            ax.add_patch(
                Wedge(
                    tuple(pos[:2]),
                    env.reach_m,
                    theta - half_width,
                    theta + half_width,
                    color=colour,
                    alpha=0.18,
                )
            )
    ax.set_aspect("equal")
    ax.set_xlim(-env.trees_from_m, env.length_m + env.goal_radius_m)
    ax.set_ylim(-half - 1.0, half + 1.0)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def top_view(env: Any, width_px: int = 640) -> np.ndarray:
    """(h, ``width_px``, 3) uint8: :func:`draw_episode` of ``env`` now."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    aspect = (env.width_m + 2.0) / (env.length_m + env.trees_from_m + env.goal_radius_m)
    fig = Figure(figsize=(6.4, max(2.0, 6.4 * aspect) + 0.6), dpi=width_px / 6.4)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    draw_episode(ax, env)
    ax.set_title(f"t = {env._steps / env.pulse_rate_hz:.2f} s", fontsize=9)
    fig.tight_layout()
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()
