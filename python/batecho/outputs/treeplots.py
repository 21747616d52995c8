"""Pictures of trees and forests (matplotlib). Every function returns the Figure and never
calls ``show``; axes are in metres, z up."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import flag

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..forest.forest import Forest
    from ..trees.tree import Tree

__all__ = ["plot_forest_3d", "plot_forest_map", "plot_tree"]

_BARK_COLOR = (0.45, 0.32, 0.22)


def _axes3d(ax: Any, figsize: tuple[float, float]) -> tuple[Figure, Any]:
    import matplotlib.pyplot as plt

    if ax is None:
        fig = plt.figure(figsize=figsize)
        ax = fig.add_subplot(projection="3d")
        return fig, ax
    if getattr(ax, "name", "") != "3d":
        raise ValueError("ax must be a 3-D Axes (projection='3d')")
    return ax.figure, ax


def _equal_3d(ax: Any, lo: np.ndarray, hi: np.ndarray) -> None:
    """Equal scale on all three axes over the box ``[lo, hi]``."""
    span = np.maximum(hi - lo, 1e-6)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(span / span.max()))
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(nbins=5))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")


def _subsample(n: int, k: int | None, seed: int = 0) -> np.ndarray:
    if k is None or n <= k:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, size=int(k), replace=False))


def _bark_polys(tree: Tree, max_faces: int | None) -> np.ndarray:
    """The largest bark triangles (trunk and main branches first), (k, 3, 3)."""
    tri = tree.bark_vertices[tree.bark_faces]
    if max_faces is not None and len(tri) > max_faces:
        area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        tri = tri[np.sort(np.argsort(-area, kind="stable")[: int(max_faces)])]
    return tri


def plot_tree(
    tree: Tree,
    ax: Axes | None = None,
    *,
    bark: bool = True,
    leaves: bool = True,
    max_leaves: int | None = 20000,
    max_bark_faces: int | None = 6000,
    leaf_size: float = 2.0,
    cmap: str = "viridis",
    elev: float = 15.0,
    azim: float = -60.0,
    title: str | None = None,
    colorbar: bool = True,
) -> Figure:
    """A 3-D view of a tree: bark as a light polygon collection (its ``max_bark_faces``
    largest triangles), leaves as points coloured by height (a random ``max_leaves`` of them,
    fixed seed); equal scale on all axes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    bark, leaves = flag(bark, "bark"), flag(leaves, "leaves")
    colorbar = flag(colorbar, "colorbar")
    fig, ax3 = _axes3d(ax, (7.0, 7.5))
    lo, hi = tree.bounds()
    if bark and len(tree.bark_faces):
        polys = _bark_polys(tree, max_bark_faces)
        pc = Poly3DCollection(polys, facecolor=_BARK_COLOR, edgecolor="none", alpha=0.9)
        ax3.add_collection3d(pc)
    if leaves:
        c = tree.leaves.centers[_subsample(tree.n_leaves, max_leaves)]
        sc = ax3.scatter(
            c[:, 0],
            c[:, 1],
            c[:, 2],
            c=c[:, 2],
            cmap=cmap,
            s=leaf_size,
            linewidths=0,
            depthshade=False,
        )
        if colorbar:
            fig.colorbar(sc, ax=ax3, shrink=0.6, pad=0.08, label="leaf height (m)")
    _equal_3d(ax3, lo, hi)
    ax3.view_init(elev=elev, azim=azim)
    ax3.set_title(
        title
        if title is not None
        else f"{tree.n_leaves} leaves, {len(tree.branch_names)} branches, "
        f"height {tree.height:.1f} m"
    )
    return fig


def plot_forest_map(
    forest: Forest,
    intensity: Any = None,
    window: Any = None,
    ax: Axes | None = None,
    *,
    crowns: bool = True,
    grid: int = 200,
    cmap: str = "Greens",
    title: str | None = None,
) -> Figure:
    """Map view: the intensity (trees per m², default the forest's own) as a heat map over the
    window (default the forest's, else the trees' extent), the tree positions on top, and with
    ``crowns`` each tree's crown radius (largest horizontal leaf distance from its trunk) as a
    circle. Axes in metres."""
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Polygon

    from ..forest.ipp import _as_window

    crowns = flag(crowns, "crowns")
    fig: Any
    if ax is None:
        fig, ax2 = plt.subplots(figsize=(7.0, 6.0))
    else:
        fig, ax2 = ax.figure, ax
    intensity = intensity if intensity is not None else getattr(forest, "intensity", None)
    window = window if window is not None else getattr(forest, "window", None)
    pos = forest.positions
    if window is not None:
        w = _as_window(window)
        xmin, xmax, ymin, ymax = w.bbox
    elif len(pos):
        r = forest.crown_radii.max() if len(pos) else 1.0
        xmin, ymin = pos.min(axis=0) - r
        xmax, ymax = pos.max(axis=0) + r
        w = None
    else:
        raise ValueError("nothing to map: the forest has no trees and no window was given")
    if intensity is not None:
        xs = np.linspace(xmin, xmax, grid)
        ys = np.linspace(ymin, ymax, grid)
        gx, gy = np.meshgrid(xs, ys)
        lam = np.broadcast_to(np.asarray(intensity(gx, gy), dtype=float), gx.shape)
        if w is not None and not w.is_rectangle:
            lam = np.where(w.contains(gx, gy), lam, np.nan)
        im = ax2.imshow(
            lam,
            origin="lower",
            extent=(xmin, xmax, ymin, ymax),
            cmap=cmap,
            aspect="equal",
            interpolation="nearest",
        )
        fig.colorbar(im, ax=ax2, label="trees per m²")
    if w is not None:
        ax2.add_patch(Polygon(w.vertices, closed=True, fill=False, ec="0.3", lw=1.0))
    if crowns and len(pos):
        for (x, y), r in zip(pos, forest.crown_radii, strict=True):
            ax2.add_patch(Circle((x, y), r, fill=False, ec=(0.1, 0.35, 0.1), lw=0.8, alpha=0.8))
    if len(pos):
        ax2.plot(pos[:, 0], pos[:, 1], "^", color=_BARK_COLOR, mec="k", ms=7, label="trees")
        ax2.legend(loc="upper right")
    ax2.set_xlim(xmin, xmax)
    ax2.set_ylim(ymin, ymax)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x (m)")
    ax2.set_ylabel("y (m)")
    ax2.set_title(title if title is not None else f"{len(pos)} trees, {forest.n_leaves} leaves")
    return fig


def plot_forest_3d(
    forest: Forest,
    ax: Axes | None = None,
    *,
    max_leaves: int | None = 40000,
    trunks: bool = True,
    leaf_size: float = 1.0,
    cmap: str = "viridis",
    elev: float = 25.0,
    azim: float = -60.0,
    title: str | None = None,
) -> Figure:
    """A 3-D view of a forest: a random ``max_leaves`` of its leaves (fixed seed) coloured by
    height, and each trunk as a line from its base to its top; equal scale on all axes."""
    trunks = flag(trunks, "trunks")
    fig, ax3 = _axes3d(ax, (9.0, 7.0))
    if forest.n_trees == 0:
        raise ValueError("the forest has no trees")
    lv = forest.leaves
    c = lv.centers[_subsample(len(lv), max_leaves)]
    ax3.scatter(
        c[:, 0],
        c[:, 1],
        c[:, 2],
        c=c[:, 2],
        cmap=cmap,
        s=leaf_size,
        linewidths=0,
        depthshade=False,
    )
    if trunks:
        for base, top in zip(forest.trunk_bases, forest.trunk_tops, strict=True):
            ax3.plot(*np.stack([base, top]).T, color=_BARK_COLOR, lw=2.0)
    lo, hi = forest.bounds()
    _equal_3d(ax3, lo, hi)
    ax3.view_init(elev=elev, azim=azim)
    ax3.set_title(
        title if title is not None else f"{forest.n_trees} trees, {forest.n_leaves} leaves"
    )
    return fig
