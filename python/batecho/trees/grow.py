"""Trees grown the paper's way (:func:`grow_tree`): an L-system
(:func:`~batecho.trees.branching.trunk_branching`) says where first-level branches leave the
trunk and in which direction; each branch is a branch of a reference tree
(:mod:`batecho.trees.reference_tree`; the shipped OBJ by default), transported there and
randomised in curvature, length and sub-branch positions.

Every random draw comes from the numpy ``Generator`` passed in, so equal seeds give equal
trees.

**Randomisation**, for a branch transported to the L-system's branch point
``o`` with its chord (base to tip of the axis) along the L-system's direction ``d``:

* length: the axis is scaled about its base by ``f = length_scale * exp(length_sd * z)``; the
  axis bark stretches with it (its rings keep their radius) and every unit moves with its anchor
  (arc length ``s -> f s``) without changing size. A tip ``f`` times as far from the base.
* sub-branch positions: every unit but a terminal one (anchored at the tip) slides along the
  axis to ``f s + slide_sd * z`` (clipped to the anchored part of the axis) and turns with the
  axis tangent there; it stays rigid, leaves included.
* curvature: the axis is bent with constant curvature: the tangent at arc length ``t`` turns by
  ``theta t / (f L)`` about a fixed axis perpendicular to ``d``, where the bend vector ``theta``
  (the extra turn of the tip, perpendicular to ``d``) is ``droop_deg`` downwards plus a 2-D
  Gaussian of ``bend_sd_deg`` per component. Arc lengths are kept; bark rings and units turn
  with the tangent (an isometric bend).

The woody skeleton (the reference's bark tubes' axes, with their radii) moves with the bark:
its points ride on the axis or hang with their units like the bark's vertices, so a grown
tree's ``branches`` follow its randomised bark.

With ``length_sd = bend_sd_deg = droop_deg = slide_sd = 0`` and ``length_scale = 1`` each
branch is the reference branch moved rigidly (``x -> o + Q (x - base)``), where ``Q`` turns the
chord's azimuth and then its polar angle into ``d``'s (so a branch's upper side stays up).
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._random import generator, seed_record
from .._resources import BYTES_PER_LEAF, SLOW_S, check_memory, warn_if_slow
from .._validate import finite_scalar, frozen, integer, point3, positive_scalar
from ._shape import point_at, rodrigues, segment_of, transport
from .branching import branching_seconds, trunk_branching
from .lsystem_tree import MIN_SEGMENT_M
from .objfile import Mesh
from .reference_tree import BranchTemplate, Placed, ReferenceTree, assemble, load_reference
from .tree import BranchLayout, Tree

_Z = np.array([0.0, 0.0, 1.0])

#: Memory per bark vertex or skeleton point of a grown branch (bytes): the template's hanging
#: arrays, the deformed copy and the tree's arrays (leaves count ``BYTES_PER_LEAF``).
BYTES_PER_POINT = 100.0
#: Time to grow one first-level branch (s), besides the trunk's branching.
S_PER_BRANCH = 0.01


def _guard_tree(ref: ReferenceTree, nb: int, buds_per_node: Any) -> None:
    """Before growing: ``nb`` copies of the reference's largest branch must fit the memory
    limit, and a growth of more than a minute warns first."""
    per_branch = max(
        len(b.leaf_radii) * BYTES_PER_LEAF
        + (len(b.vertices) + len(b.skeleton_points)) * BYTES_PER_POINT
        for b in ref.branches
    )
    check_memory(
        nb * per_branch,
        f"a tree of n_branches = {nb} (each up to {per_branch / 2**20:.2g} MiB)",
        "use fewer n_branches",
    )
    m = buds_per_node if isinstance(buds_per_node, int) and buds_per_node >= 1 else 1
    trunk_s = branching_seconds(nb, m)
    seconds = nb * S_PER_BRANCH + trunk_s
    if trunk_s <= SLOW_S:  # (a slow branching warns for itself)
        warn_if_slow(
            seconds, f"growing a tree of n_branches = {nb}", "use fewer n_branches", stacklevel=3
        )


def _bend_integral(
    d: np.ndarray, t0: np.ndarray, t: np.ndarray, b: np.ndarray, kappa: float
) -> np.ndarray:
    """``int_{t0}^{t} R_b(kappa u) d du`` row-wise (``d`` unit directions, ``b`` unit bend
    axis, ``R_b(a)`` the rotation by ``a`` about ``b``)."""
    delta = (t - t0)[:, None]
    mid = 0.5 * kappa * (t + t0)[:, None]
    sinc = np.sinc(kappa * delta / (2.0 * np.pi))  # sin(k delta / 2) / (k delta / 2)
    par = (d @ b)[:, None] * b
    perp = d - par
    return par * delta + delta * sinc * (np.cos(mid) * perp + np.sin(mid) * np.cross(b, perp))


def _deform(
    tpl: BranchTemplate,
    rot: np.ndarray,
    f: float,
    bend: np.ndarray,
    slide: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Transport (``rot`` about the template's base, which goes to the origin), scale the axis
    by ``f``, slide the units by ``slide`` (m, per unit) and bend by the rotation vector
    ``bend`` (rad). Returns (points, leaf normals, axis), points = vertices, skeleton points,
    then leaf centres, relative to the branch point."""
    anchor, unit, offset = tpl._hang
    axis = (tpl.axis - tpl.base) @ rot.T
    seg = np.diff(axis, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    dirs = seg / seg_len[:, None]
    arc = tpl.arc
    length = float(arc[-1])
    off = offset @ rot.T
    normals = tpl.leaf_normals @ rot.T
    # (points below nv are bark vertices and skeleton points, the rest leaf centres)
    nv = len(tpl.vertices) + len(tpl.skeleton_points)

    # new anchors (arc length on the scaled axis)
    t_new = f * anchor
    on_unit = unit >= 0
    if tpl.n_units:
        ua = tpl.unit_anchors
        terminal = ua >= length - 1e-9
        lo = f * float(ua.min())
        ua_new = np.where(terminal, f * ua, np.clip(f * ua + slide, lo, f * length))
        t_new[on_unit] = ua_new[unit[on_unit]]
        # turn each slid unit with the axis tangent (before bending)
        j_old = segment_of(arc, ua)
        j_new = segment_of(arc, ua_new / f)
        k = np.cross(dirs[j_old], dirs[j_new])
        sin = np.linalg.norm(k, axis=1)
        cos = np.einsum("ij,ij->i", dirs[j_old], dirs[j_new])
        turn = sin > 1e-12
        if turn.any():
            kh = np.zeros_like(k)
            kh[turn] = k[turn] / sin[turn, None]
            pu = np.flatnonzero(on_unit)
            uu = unit[pu]
            sel = turn[uu]
            idx = pu[sel]
            off[idx] = rodrigues(off[idx], kh[uu[sel]], cos[uu[sel]], sin[uu[sel]])
            li = idx[idx >= nv] - nv
            lu = unit[li + nv]
            normals[li] = rodrigues(normals[li], kh[lu], cos[lu], sin[lu])

    # the bent axis and its rotation at every anchor
    theta = float(np.linalg.norm(bend))
    t_arc = f * arc
    if theta > 1e-15:
        b = bend / theta
        kappa = theta / (f * length)
        steps = _bend_integral(dirs, t_arc[:-1], t_arc[1:], b, kappa)
        new_axis = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
        j = segment_of(t_arc, t_new)
        at = new_axis[j] + _bend_integral(dirs[j], t_arc[j], t_new, b, kappa)
        c, s = np.cos(kappa * t_new), np.sin(kappa * t_new)
        pts = at + rodrigues(off, b, c, s)
        li = np.arange(nv, len(t_new))
        normals = rodrigues(normals, b, c[li], s[li])
    else:
        new_axis = f * axis
        pts = point_at(new_axis, t_arc, t_new) + off
    return pts, normals, new_axis


def grow_tree(
    rng: np.random.Generator | int | None = None,
    *,
    reference: str | os.PathLike | Mesh | ReferenceTree | None = None,
    trunk_height: float | None = None,
    n_branches: int | None = None,
    first_branch_height: float | None = None,
    branching_angle_deg: float = 50.0,
    divergence_deg: float = 137.5,
    lsystem: Mapping[str, Any] | None = None,
    branch_choice: str = "height",
    length_scale: float = 1.0,
    length_sd: float = 0.15,
    bend_sd_deg: float = 15.0,
    droop_deg: float = 0.0,
    slide_sd: float = 0.15,
    base: Sequence[float] = (0.0, 0.0, 0.0),
) -> Tree:
    """Grow a tree the paper's way: L-system first-level branching, branches from a reference
    tree randomised in curvature, length and sub-branch positions (module docstring).

    Parameters (metres, degrees)
    ----------
    rng : numpy.random.Generator, int or None
        All randomness; an int seed or the same Generator state gives the same tree.
    reference : None, OBJ path, Mesh or ReferenceTree
        The reference tree (default: the shipped ``data/reference_tree.obj``; loaded once and
        cached). See :func:`load_reference` for what an OBJ of your own needs.
    trunk_height, n_branches, first_branch_height : optional
        The L-system trunk (:func:`~batecho.trees.branching.trunk_branching`), m; default the
        reference's trunk height, number of branches and lowest branch height. The reference
        trunk is stretched vertically to ``trunk_height``.
    branching_angle_deg, divergence_deg : float
        Angle between each branch's chord and the trunk (50, the paper's), and the roll between
        successive branch nodes (137.5, a golden-angle spiral).
    lsystem : mapping, optional
        More keyword arguments for ``trunk_branching`` (``buds_per_node``, ``contraction``,
        ``angle_jitter_deg``, ``divergence_jitter_deg``, ``internode_jitter``, ...).
    branch_choice : {"height", "random"}
        Which reference branch each L-system branch copies: the one whose base is at the
        nearest relative height on the trunk, or one drawn uniformly.
    length_scale, length_sd : float
        Branch length factor ``f = length_scale * exp(length_sd * z)``, z ~ N(0, 1) per branch.
    bend_sd_deg, droop_deg : float
        Extra bend of each branch, as the turn of its tip: ``droop_deg`` downwards (towards -z)
        plus a Gaussian of sd ``bend_sd_deg`` in each of two perpendicular directions.
    slide_sd : float
        Standard deviation of the slide of each sub-branch unit along its axis, m.
    base : 3-vector
        Trunk base, m.

    Random draws, in this order (always all of them, whatever the sds): the L-system, the
    reference branch indices (``branch_choice="random"`` only), ``z`` for the lengths (b,),
    the bends (b, 2), then per branch the slides (one per unit of its reference branch).

    A length factor that makes a branch shorter than 1e-9 m or longer than float64 holds, or
    a bend too large for float64 to compute with, raises ValueError naming the parameters.
    A tree of more branches than fit :func:`batecho.memory_limit` (each counted as the
    reference's largest) raises MemoryError before it grows; one of minutes warns first
    (:class:`batecho._resources.SlowWarning`).
    """
    gen = generator(rng)
    record = seed_record(rng, gen)
    ref = load_reference(reference)
    if not ref.branches:
        raise ValueError("the reference tree has no first-level branches")
    if not ref.has_skeleton:
        warnings.warn(
            "the reference tree has no woody skeleton (an OBJ without its JSON sidecar), so the "
            "grown tree's wood is silent (Tree.branches is None)",
            UserWarning,
            stacklevel=2,
        )
    if branch_choice not in ("height", "random"):
        raise ValueError(f"branch_choice must be 'height' or 'random', got {branch_choice!r}")
    h_ref = ref.trunk_height
    trunk_h = (
        h_ref
        if trunk_height is None
        else positive_scalar(trunk_height, "trunk_height", strict=True, unit="m")
    )
    nb = len(ref.branches) if n_branches is None else integer(n_branches, "n_branches", 1)
    heights = ref.heights
    h0 = (
        max(float(heights.min()) * trunk_h / h_ref, 0.0)
        if first_branch_height is None
        else positive_scalar(
            first_branch_height, "first_branch_height", allow_zero=True, strict=True, unit="m"
        )
    )
    ls = positive_scalar(length_scale, "length_scale", strict=True)
    lsd = positive_scalar(length_sd, "length_sd", allow_zero=True, strict=True)
    bsd = math.radians(positive_scalar(bend_sd_deg, "bend_sd_deg", allow_zero=True, strict=True))
    droop = math.radians(finite_scalar(droop_deg, "droop_deg", strict=True))
    ssd = positive_scalar(slide_sd, "slide_sd", allow_zero=True, strict=True, unit="m")
    b0 = point3(base, "base")
    if lsystem is not None and not isinstance(lsystem, Mapping):
        raise TypeError(f"lsystem must be a mapping of keyword arguments, got {lsystem!r}")
    extra = dict(lsystem or {})
    for key in ("trunk_height", "n_branches", "first_branch_height", "base", "rng"):
        if key in extra:
            raise ValueError(f"give {key} to grow_tree itself, not in lsystem")
    _guard_tree(ref, nb, extra.get("buds_per_node", 1))
    branching = trunk_branching(
        gen,
        trunk_height=trunk_h,
        n_branches=nb,
        first_branch_height=h0,
        branching_angle_deg=branching_angle_deg,
        divergence_deg=divergence_deg,
        **extra,
    )
    n = len(branching)
    if branch_choice == "random":
        choice = gen.integers(len(ref.branches), size=n)
    else:
        rel = heights / h_ref
        want = branching.heights / trunk_h
        choice = np.argmin(np.abs(want[:, None] - rel[None, :]), axis=1)
    z_len = gen.standard_normal(n)
    z_bend = gen.standard_normal((n, 2))
    # Each branch's length and curvature (its tip's turn over its length) must be numbers
    # float64 can bend with: refused here, naming the parameters, rather than grown as NaN.
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        factors = ls * np.exp(lsd * z_len)
        lengths = factors * np.array([ref.branches[int(c)].arc[-1] for c in choice])
        a, b = droop + bsd * z_bend[:, 0], bsd * z_bend[:, 1]
        curvatures = np.sqrt(a * a + b * b) / lengths  # (as _deform computes it)
    bad = ~(np.isfinite(lengths) & (lengths >= MIN_SEGMENT_M))
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"branch {i}'s length factor length_scale * exp(length_sd * z) = {factors[i]:.3g} "
            f"makes it {lengths[i]:.3g} m long, outside [{MIN_SEGMENT_M:g} m, float64's "
            "largest]; use length_scale and length_sd nearer 1 and 0"
        )
    bad = ~np.isfinite(curvatures)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"branch {i} would turn by {math.degrees(math.hypot(a[i], b[i])):.3g} degrees over "
            f"{lengths[i]:.3g} m, a bend too large for float64; use smaller droop_deg and "
            "bend_sd_deg"
        )
    placed = []
    bends = np.zeros((n, 3))
    for i in range(n):
        tpl = ref.branches[int(choice[i])]
        z_slide = gen.standard_normal(tpl.n_units)
        d = branching.directions[i]
        rot = transport(tpl.chord, d)
        e1 = np.cross(_Z, d)
        if np.linalg.norm(e1) < 1e-9:
            e1 = np.array([0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)  # turning about e1 by a positive angle bends the tip down
        e2 = np.cross(d, e1)
        bend = (droop + bsd * z_bend[i, 0]) * e1 + bsd * z_bend[i, 1] * e2
        bends[i] = bend
        pts, normals, axis = _deform(tpl, rot, float(factors[i]), bend, ssd * z_slide)
        origin = branching.origins[i] - branching.trunk_base
        nv, ns = len(tpl.vertices), len(tpl.skeleton_points)
        placed.append(
            Placed(
                pts[:nv] + origin,
                pts[nv + ns :] + origin,
                normals,
                int(choice[i]),
                axis + origin,
                pts[nv : nv + ns] + origin,
            )
        )
    layout = BranchLayout(
        origins=frozen(branching.origins - branching.trunk_base + b0),
        directions=frozen(branching.directions),
        reference_index=frozen(choice, np.int64),
        length_scales=frozen(factors),
        bend_vectors_deg=frozen(np.degrees(bends)),
        axes=tuple(frozen(p.axis + b0) for p in placed),
    )
    params = {
        "scheme": "grow_tree",
        **record,
        "reference": "shipped" if reference is None else str(getattr(ref, "source", None)),
        "trunk_height": trunk_h,
        "n_branches": nb,
        "first_branch_height": h0,
        "branching_angle_deg": float(branching_angle_deg),
        "divergence_deg": float(divergence_deg),
        "lsystem": extra,
        "branch_choice": branch_choice,
        "length_scale": ls,
        "length_sd": lsd,
        "bend_sd_deg": float(bend_sd_deg),
        "droop_deg": float(droop_deg),
        "slide_sd": ssd,
        "base": b0.tolist(),
    }
    return assemble(ref, placed, trunk_h, b0, layout, params)


__all__ = ["grow_tree"]
