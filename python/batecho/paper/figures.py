"""The paper's Figures 5-10 rerun (in spirit) as PNG files, with a straight run toward a tree,
echo images around the circle, and an NPZ of the data behind them."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from .._resources import check_memory, echoes_bytes_per_pulse
from ..echoes.simulate import lobe_members, simulate
from ..flight.kinematic import circle, line_to
from ..flight.poses import Poses, look_at
from ..forest.ipp import draw_tree_positions
from ..forest.models import make_forest
from ..forest.scene import Scene
from ..outputs.files import make_output_folder
from ..outputs.npz import write_npz
from .settings import (
    DEFAULT_SEED,
    PAPER_ALTITUDE_M,
    PAPER_BEAMWIDTHS_DEG,
    PAPER_CLEARANCE_M,
    PAPER_RADIUS_M,
    Progress,
    machine_info,
    no_progress,
    paper_circle_radius,
    paper_sonar,
    tree_settings,
)

__all__ = ["paper_figures"]


def _savefig(fig, path: Path, dpi: int) -> Path:
    fig.savefig(path, dpi=dpi)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return path


def _scene_and_impulse(forest, sonar, pose, members, echoes, title3d: str, title: str):
    """A figure: the scene with one pose and its lobe (left), its impulse response (right)."""
    from ..outputs.plots import _plt, plot_impulse, plot_scene_3d

    plt = _plt()
    fig = plt.figure(figsize=(13, 5.5), constrained_layout=True)
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    plot_scene_3d(forest, pose, sonar, members=members, ax=ax3, lobe_poses=[0], title=title3d)
    ax = fig.add_subplot(1, 2, 2)
    plot_impulse(echoes, 0, ax=ax, title=title)
    return fig


def _min_clearance(forest, poses: Poses) -> float:
    """The smallest distance (m) from the pulse positions of ``poses`` to ``forest``'s leaves
    and bark (:meth:`~batecho.Forest.clearance`)."""
    return float(forest.clearance(poses.positions).min())


def _leaf_centroid(forest) -> np.ndarray:
    return np.asarray(forest.leaves.centers, dtype=np.float64).mean(axis=0)


def paper_figures(
    out_dir: str | os.PathLike,
    seed: int = DEFAULT_SEED,
    *,
    tree_model: str = "grow_tree",
    tree_params: dict | None = None,
    dpi: int = 110,
    echo_pulses: int = 72,
    progress: Progress | None = None,
) -> dict[str, Path]:
    """Write the paper's Figures 5-10 (in spirit) as PNG files into ``out_dir``; return
    ``{name: path}``.

    * ``fig05_no_leaf_in_lobe.png``: one tree, a pose on the circle (5 m up) whose lobe
      (10 deg beam, along the path) holds no leaf, and its impulse response: exactly zero.
    * ``fig06_leaves_in_lobe.png``: the same tree, a pose looking at the crown (20 deg beam),
      the leaves in its lobe highlighted, and its impulse response (Figure 7).
    * ``fig07_impulse_beamwidths.png``: that pose's impulse responses with 10, 20, 50 deg beams.
    * ``fig08_two_trees_circle.png``: two trees and the circle (5 m up, around the mean tree
      position), 4 sample points looking at the centre (20 deg beam), chosen where the lobe
      holds leaves (spread over a 5 deg grid).
    * ``fig09_impulses_circle.png``: the impulse responses at those 4 points.
    * ``fig10_two_three_trees.png``: two and three trees, 15 sample points each (50 deg beam).
    * ``echo_image_circle.png``: envelopes of ``echo_pulses`` pulses around the two-tree circle,
      looking at the centre, with 10, 20 and 50 deg beams.
    * ``straight_run.png``: a straight run toward the single tree (20 deg beam, looking at the
      trunk at 5 m) with the echo image along it; ``straight_run_impulses.png``: 4 of its
      impulse responses.
    * ``paper_figures.npz``: poses, impulse responses and leaf counts behind the figures, the
      seed, the settings (JSON: among them ``min_clearance_m``, each path's smallest distance
      from a pulse to leaves or bark) and the batecho version.

    Tree positions for two and three trees come from the paper's IPP conditioned on the count;
    the single tree stands at the origin. Leaves within 1 cm of a pulse are left out.

    Every pulse keeps :data:`~batecho.paper.settings.PAPER_CLEARANCE_M` (0.5 m) from leaves
    and bark: each circle has the paper's radius of 6.2 m where that clears the crowns at 5 m
    and the smallest wider radius that does otherwise (:func:`paper_circle_radius`); the
    straight run stops that far outside the crown.
    """
    from ..outputs.plots import (
        _impulse_handles,
        _plt,
        plot_echo_image,
        plot_impulse,
        plot_impulses,
        plot_scene_3d,
    )

    # The echo image's pulses, sized before any work (its beams are simulated one at a time).
    n_e = int(echo_pulses)
    s_e = paper_sonar(PAPER_BEAMWIDTHS_DEG[0])
    check_memory(
        n_e * echoes_bytes_per_pulse(s_e.n_bins, int(s_e.n_samples)),
        f"echo_pulses = {n_e}: an echo image of {n_e} pulses around the circle",
        "use fewer echo pulses",
    )
    plt = _plt()
    out = make_output_folder(out_dir)
    ss = np.random.SeedSequence(int(seed))
    rngs = [np.random.default_rng(s) for s in ss.spawn(3)]
    written: dict[str, Path] = {}
    data: dict[str, Any] = {}
    bw10, bw20, bw50 = PAPER_BEAMWIDTHS_DEG
    Z = PAPER_ALTITUDE_M
    radii: dict[str, float] = {}
    clearances: dict[str, float] = {}
    steps = ["one tree", "two trees", "three trees", "straight run"]
    wrap = progress or no_progress
    it = iter(wrap(steps, total=len(steps), desc="paper figures"))

    # -- one tree: Figures 5, 6, 7 ---------------------------------------------------------
    next(it)
    tree_xy = np.zeros(2)
    forest1 = make_forest(tree_xy[None, :], rngs[0], tree_model, tree_params)
    scene1 = Scene(forest1.leaves)
    R = radii["one_tree"] = paper_circle_radius(forest1, tree_xy)
    s10 = paper_sonar(bw10)
    cands = Poses.concatenate(
        [
            circle(tree_xy, R, Z, n_points=24, heading="velocity"),
            circle(tree_xy, R, Z, n_points=24, heading="fixed", yaw_deg=0.0),
        ]
    )
    clearances["one_tree_circle"] = _min_clearance(forest1, cands)
    empty = None
    for i in range(len(cands)):
        if len(lobe_members(scene1, s10, cands[i])) == 0:
            empty = cands[i]
            break
    if empty is None:
        raise RuntimeError("no pose on the circle has an empty lobe; is the tree that large?")
    e5 = simulate(scene1, s10, empty)
    if np.any(e5.impulse != 0.0):  # pragma: no cover - a bug, not a user error
        raise AssertionError("an empty lobe gave a non-zero echo")
    fig = _scene_and_impulse(
        forest1,
        s10,
        empty,
        None,
        e5,
        f"Figure 5: no leaf in the main lobe ({bw10:g} deg beam)",
        "its echo: exactly zero",
    )
    written["fig05"] = _savefig(fig, out / "fig05_no_leaf_in_lobe.png", dpi)
    data["fig05_position"] = empty.positions[0]
    data["fig05_forward"] = empty.forward[0]
    data["fig05_impulse"] = e5.impulse[0]

    crown = _leaf_centroid(forest1)
    p6 = look_at([tree_xy[0] + R, tree_xy[1], Z], crown)
    s20 = paper_sonar(bw20)
    members6 = lobe_members(scene1, s20, p6)
    if len(members6) == 0:
        raise RuntimeError("the pose looking at the crown has no leaf in its lobe")
    e6 = simulate(scene1, s20, p6)
    fig = _scene_and_impulse(
        forest1,
        s20,
        p6,
        members6,
        e6,
        f"Figure 6: {len(members6)} leaves in the main lobe ({bw20:g} deg beam)",
        "its echo (Figure 7)",
    )
    written["fig06"] = _savefig(fig, out / "fig06_leaves_in_lobe.png", dpi)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), constrained_layout=True, sharex=True)
    imp7 = []
    for k, (ax, bw) in enumerate(zip(axes, PAPER_BEAMWIDTHS_DEG, strict=True)):
        e = simulate(scene1, paper_sonar(bw), p6)
        imp7.append(e.impulse[0])
        plot_impulse(
            e,
            0,
            ax=ax,
            title=f"Figure 7: {bw:g} deg beam, {e.n_leaves[0]} leaves in the lobe",
            legend=False,
            range_axis=k == 0,
        )
        if k < len(axes) - 1:
            ax.set_xlabel("")
    fig.legend(*_impulse_handles(axes[0]), loc="outside lower center", ncols=2, frameon=False)
    written["fig07"] = _savefig(fig, out / "fig07_impulse_beamwidths.png", dpi)
    data["fig06_position"] = p6.positions[0]
    data["fig06_forward"] = p6.forward[0]
    data["fig06_members"] = members6
    data["fig07_beamwidths_deg"] = np.asarray(PAPER_BEAMWIDTHS_DEG)
    data["fig07_impulses"] = np.asarray(imp7)
    data["one_tree_positions"] = tree_xy[None, :]
    data["one_tree_n_leaves"] = scene1.n_leaves

    # -- two trees: Figures 8, 9 and the echo images ----------------------------------------
    next(it)
    pos2 = draw_tree_positions(2, rngs[1])
    forest2 = make_forest(pos2, rngs[1], tree_model, tree_params)
    scene2 = Scene(forest2.leaves)
    c2 = pos2.mean(axis=0)
    R = radii["two_trees"] = paper_circle_radius(forest2, c2)
    # Four sample points where the lobe holds leaves (the paper's "four instances"), spread
    # over the 72 points of a 5 deg grid; the quarter points if fewer than four hold any.
    grid = circle(c2, R, Z, n_points=72, heading="center")
    lit = np.flatnonzero(simulate(scene2, s20, grid).n_leaves > 0)
    pick = (
        lit[np.linspace(0, len(lit) - 1, 4).round().astype(int)]
        if len(lit) >= 4
        else np.arange(4) * 18
    )
    p8 = grid[pick]
    angles8 = 5.0 * pick
    e8 = simulate(scene2, s20, p8)
    m8 = [lobe_members(scene2, s20, p8[i]) for i in range(len(p8))]
    fig = plot_scene_3d(
        forest2,
        p8,
        s20,
        members=m8,
        trajectory=np.vstack([grid.positions, grid.positions[:1]]),
        lobe_labels=[f"lobe of point {i + 1} ({angles8[i]:g} deg)" for i in range(4)],
        title=f"Figure 8: two trees, circle of {R:g} m at {Z:g} m, 4 sample points "
        f"({bw20:g} deg beam)",
    )
    written["fig08"] = _savefig(fig, out / "fig08_two_trees_circle.png", dpi)
    fig = plot_impulses(
        e8,
        range(4),
        titles=[
            f"Figure 9: point {i + 1} ({angles8[i]:g} deg), {e8.n_leaves[i]} leaves"
            for i in range(4)
        ],
    )
    written["fig09"] = _savefig(fig, out / "fig09_impulses_circle.png", dpi)
    data["two_trees_positions"] = pos2
    data["fig09_angles_deg"] = angles8
    data["fig09_positions"] = p8.positions
    data["fig09_forward"] = p8.forward
    data["fig09_impulses"] = e8.impulse
    data["fig09_n_leaves"] = e8.n_leaves

    angles = 360.0 * np.arange(n_e) / n_e
    pe = circle(c2, R, Z, n_points=n_e, heading="center")
    fig, axes = plt.subplots(3, 1, figsize=(9, 9.5), constrained_layout=True, sharex=True)
    for k, (ax, bw) in enumerate(zip(axes, PAPER_BEAMWIDTHS_DEG, strict=True)):
        ee = simulate(scene2, paper_sonar(bw), pe)
        plot_echo_image(
            ee,
            ax=ax,
            x=angles,
            xlabel="angle on the circle (deg)",
            title=f"Echoes around two trees from a {R:g} m circle, looking at the centre "
            f"({bw:g} deg beam)",
        )
        if k < len(axes) - 1:
            ax.set_xlabel("")
        data[f"echo_image_{bw:g}deg_n_leaves"] = ee.n_leaves
    written["echo_image"] = _savefig(fig, out / "echo_image_circle.png", dpi)
    clearances["two_trees_circle"] = _min_clearance(forest2, pe)
    data["echo_image_angles_deg"] = angles
    data["echo_image_positions"] = pe.positions
    data["echo_image_forward"] = pe.forward

    # -- Figure 10: two and three trees, 15 points -------------------------------------------
    next(it)
    pos3 = draw_tree_positions(3, rngs[2])
    forest3 = make_forest(pos3, rngs[2], tree_model, tree_params)
    scene3 = Scene(forest3.leaves)
    s50 = paper_sonar(bw50)
    fig = plt.figure(figsize=(15, 7), constrained_layout=True)
    for k, (forest, scene, pos) in enumerate(((forest2, scene2, pos2), (forest3, scene3, pos3))):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        c10 = pos.mean(axis=0)
        R = radii[f"fig10_{len(pos)}_trees"] = paper_circle_radius(forest, c10)
        p10 = circle(c10, R, Z, n_points=15, heading="center")
        m10 = [lobe_members(scene, s50, p10[i]) for i in range(len(p10))]
        e10 = simulate(scene, s50, p10)
        plot_scene_3d(
            forest,
            p10,
            s50,
            members=m10,
            ax=ax,
            lobe_poses=[0, 5, 10],
            trajectory=np.vstack([p10.positions, p10.positions[:1]]),
            title=f"Figure 10: {len(pos)} trees, 15 points on a {R:g} m circle, "
            f"{int(e10.n_leaves.sum()):,} leaf echoes ({bw50:g} deg beam)",
        )
        data[f"fig10_{len(pos)}_trees_n_leaves"] = e10.n_leaves
        clearances[f"fig10_{len(pos)}_trees_circle"] = _min_clearance(forest, p10)
    written["fig10"] = _savefig(fig, out / "fig10_two_three_trees.png", dpi)
    data["three_trees_positions"] = pos3

    # -- a straight run toward the tree ----------------------------------------------------
    next(it)
    # the run stops PAPER_CLEARANCE_M outside the crown at its height
    stop = forest1.clear_circle_radius(tree_xy, 0.0, PAPER_CLEARANCE_M, altitude=Z)
    start = [tree_xy[0] - stop - 10.0, tree_xy[1], Z]
    target = [tree_xy[0], tree_xy[1], Z]
    pr = line_to(start, target, n_points=24, stop_distance=stop)
    er = simulate(scene1, s20, pr)
    dist = np.linalg.norm(pr.positions[:, :2] - tree_xy, axis=1)
    mr = [lobe_members(scene1, s20, pr[i]) for i in (0, len(pr) - 1)]
    fig = plt.figure(figsize=(10, 11), constrained_layout=True)
    ax3 = fig.add_subplot(2, 1, 1, projection="3d")
    plot_scene_3d(
        forest1,
        pr,
        s20,
        members=mr,
        ax=ax3,
        lobe_poses=[0, len(pr) - 1],
        trajectory=pr.positions,
        title=f"A straight run toward the tree ({bw20:g} deg beam)",
    )
    ax = fig.add_subplot(2, 1, 2)
    plot_echo_image(
        er,
        ax=ax,
        x=dist,
        xlabel="distance to the trunk (m)",
        title="Echoes along the run (approaching from left to right)",
    )
    ax.invert_xaxis()
    written["straight_run"] = _savefig(fig, out / "straight_run.png", dpi)
    sel = np.unique(np.linspace(0, len(pr) - 1, 4).round().astype(int))
    fig = plot_impulses(
        er, sel, titles=[f"{dist[i]:.1f} m from the trunk, {er.n_leaves[i]} leaves" for i in sel]
    )
    written["straight_run_impulses"] = _savefig(fig, out / "straight_run_impulses.png", dpi)
    data["straight_run_positions"] = pr.positions
    data["straight_run_forward"] = pr.forward
    data["straight_run_n_leaves"] = er.n_leaves
    clearances["straight_run"] = _min_clearance(forest1, pr)
    for _ in it:
        pass

    settings = {
        "seed": int(seed),
        "tree": tree_settings(tree_model, tree_params),
        "radius_m": radii,
        "min_clearance_m": clearances,
        "radius_rule": f"the paper's {PAPER_RADIUS_M:g} m where it passes "
        f"{PAPER_CLEARANCE_M:g} m outside every crown at {Z:g} m, else the smallest wider "
        "radius that does (batecho.paper.settings.paper_circle_radius)",
        "altitude_m": Z,
        "beamwidths_deg": list(PAPER_BEAMWIDTHS_DEG),
        "sonar": "the model's defaults (docs/model.md) with too_close='skip' and the beamwidth "
        "of each figure",
        "rngs": "numpy SeedSequence(seed).spawn(3): one tree (also the straight run), two "
        "trees, three trees",
        "machine": machine_info(),
    }
    written["data"] = write_npz(
        out / "paper_figures.npz",
        {"seed": int(seed), **data},
        {"settings_json": settings},
    )
    return written
