"""The authors' ginkgo-like L-system tree (docs/model.md §7): bark tubes around the turtle's
segments, the segments themselves as its woody skeleton, and clusters of leaf disks at its leaf
nodes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._random import generator, seed_record
from .._resources import BYTES_PER_LEAF, check_memory, warn_if_slow
from .._validate import finite_scalar, frozen, integer, point3, positive_scalar
from ._shape import unit_rows
from .branches import Branches
from .leaves import Leaves
from .lsystem import S_PER_MODULE, LSystem
from .tree import BranchLayout, Tree
from .turtle import turtle

#: Memory per segment of an L-system tree (bytes): its modules in the string and the turtle's
#: rows; and per side of its bark tube (vertices, faces and their working arrays).
BYTES_PER_SEGMENT = 1000.0
BYTES_PER_TUBE_SIDE = 250.0
#: Time per segment (s), its leaves and bark included, besides the rewriting.
S_PER_SEGMENT = 1e-4


#: The shortest segment an L-system tree may have (m): far below any twig, far above the
#: float64 spacing of positions a few metres from the origin (about 1e-15 m).
MIN_SEGMENT_M = 1e-9


def _power(base: float, exponent: int) -> float:
    try:
        return base**exponent
    except OverflowError:
        return math.inf


def _guard_tree(levels: int, n_lat: int, n_nodes: int, per_node: int, sides: int) -> None:
    """Before growing: the tree's branches, segments and leaves (from the parameters) must fit
    the memory limit, and a growth of more than a minute warns first."""
    q = n_lat + 1.0
    top = _power(q, levels + 1)
    branches = levels + 1.0 if n_lat == 0 else (top - 1.0) / n_lat
    segments = 1.0 + n_nodes * (branches - 1.0)
    leaves = per_node * n_nodes * (branches - 1.0)
    check_memory(
        leaves * BYTES_PER_LEAF + segments * (BYTES_PER_SEGMENT + sides * BYTES_PER_TUBE_SIDE),
        f"an L-system tree of n_levels = {levels} and laterals_per_node = {n_lat} "
        f"({branches:.3g} branches, {leaves:.3g} leaves)",
        "use fewer n_levels or laterals_per_node (or leaf_nodes_per_branch, leaves_per_node)",
    )
    # Each of the levels + 1 rewriting steps reads the whole string grown so far: the
    # branches of level j are read levels + 1 - j times.
    if n_lat == 0:
        reads = (levels + 1.0) * (levels + 2.0) / 2.0
    else:
        reads = (q * top - (levels + 2.0) * q + (levels + 1.0)) / (q - 1.0) ** 2
    modules_per_branch = 4 + 3 * n_nodes + 5 * n_lat
    seconds = segments * S_PER_SEGMENT + reads * modules_per_branch * S_PER_MODULE
    warn_if_slow(
        seconds,
        f"growing an L-system tree of n_levels = {levels} and laterals_per_node = {n_lat}",
        "use fewer n_levels or laterals_per_node",
        stacklevel=3,
    )


def _tubes(
    starts: np.ndarray,
    ends: np.ndarray,
    lefts: np.ndarray,
    ups: np.ndarray,
    r0: np.ndarray,
    r1: np.ndarray,
    sides: int,
) -> tuple[np.ndarray, np.ndarray]:
    """One open ``sides``-gon tube per segment (ring frames from the turtle's L and U)."""
    theta = 2.0 * np.pi * np.arange(sides) / sides
    ring = np.cos(theta)[None, :, None] * lefts[:, None, :] + (
        np.sin(theta)[None, :, None] * ups[:, None, :]
    )
    v0 = starts[:, None, :] + r0[:, None, None] * ring
    v1 = ends[:, None, :] + r1[:, None, None] * ring
    verts = np.concatenate([v0, v1], axis=1).reshape(-1, 3)
    k = np.arange(sides)
    quad = np.stack([k, (k + 1) % sides, (k + 1) % sides + sides, k + sides], axis=1)
    tri = np.concatenate([quad[:, [0, 1, 2]], quad[:, [0, 2, 3]]])
    faces = (2 * sides * np.arange(len(starts)))[:, None, None] + tri[None]
    return verts, faces.reshape(-1, 3)


def grow_lsystem_tree(
    rng: np.random.Generator | int | None = None,
    *,
    n_levels: int = 4,
    contraction: float = 0.62,
    branching_angle_deg: float = 50.0,
    initial_length: float = 2.0,
    leaf_nodes_per_branch: int = 4,
    centre_contraction: float = 0.826,
    leaves_per_node: int = 4,
    leaf_radius_mean: float = 0.025,
    leaf_radius_sd: float = 0.005,
    leaf_radius_min: float = 0.005,
    laterals_per_node: int = 3,
    divergence_deg: float = 137.5,
    angle_jitter_deg: float = 5.0,
    length_jitter: float = 0.1,
    petiole_length: float = 0.03,
    trunk_radius: float = 0.12,
    width_contraction: float = 0.62,
    bark_sides: int = 5,
    base: Sequence[float] = (0.0, 0.0, 0.0),
) -> Tree:
    """The authors' ginkgo-like L-system tree (docs/model.md §7); the defaults are theirs.

    The axiom ``A(l0, 0, -1)`` grows by ``A(l, k, b) -> F(l) ... /(div) [&(angle) A(c l, k+1,
    b')] x laterals A(cc l, k+1, b)`` for ``k < n_levels``: a segment of length ``l`` (the trunk,
    ``initial_length`` m, at level 0), then ``laterals_per_node`` side branches at
    ``branching_angle_deg`` to it, spread evenly in roll and each ``contraction`` times as long,
    and a centre branch ``centre_contraction`` times as long continuing straight on. Branches
    of levels 1..``n_levels`` carry ``leaf_nodes_per_branch`` leaf nodes (their segment is
    split into as many equal parts, a node at the end of each); each node holds a cluster of
    ``leaves_per_node`` disks spread evenly around the branch, ``petiole_length`` m plus a
    radius out, at 60 degrees to it, with uniformly random orientations and radii
    ``Normal(leaf_radius_mean, leaf_radius_sd)`` truncated below at ``leaf_radius_min`` (m; the
    echo model refuses radii under ~0.45 mm). The chain of centre branches from the trunk is
    the trunk (leader); each lateral leaving it starts a first-level branch (``branch_00`` ...
    in growth order). Bark: open ``bark_sides``-gon tubes around the segments, radius
    ``trunk_radius * width_contraction**level`` m; the turtle's segments with those radii are
    the tree's woody skeleton (``Tree.branches``). ``angle_jitter_deg`` (uniform half-width) and
    ``length_jitter`` (relative) randomise the angles and lengths.

    Before growing, the tree's size from its parameters must fit :func:`batecho.memory_limit`
    (MemoryError naming ``n_levels`` and ``laterals_per_node``), a growth of minutes warns
    (:class:`batecho._resources.SlowWarning`), and widths and lengths after ``n_levels``
    contractions must stay within float64 (ValueError).
    """
    gen = generator(rng)
    record = seed_record(rng, gen)
    levels = integer(n_levels, "n_levels", 0)
    c_lat = positive_scalar(contraction, "contraction", strict=True)
    c_ctr = positive_scalar(centre_contraction, "centre_contraction", strict=True)
    angle = finite_scalar(branching_angle_deg, "branching_angle_deg", strict=True)
    if not 0 < angle < 180:
        raise ValueError(f"branching_angle_deg must be in (0, 180), got {branching_angle_deg!r}")
    l0 = positive_scalar(initial_length, "initial_length", strict=True, unit="m")
    n_nodes = integer(leaf_nodes_per_branch, "leaf_nodes_per_branch", 1)
    per_node = integer(leaves_per_node, "leaves_per_node", 1)
    rmean = positive_scalar(leaf_radius_mean, "leaf_radius_mean", strict=True, unit="m")
    rsd = positive_scalar(leaf_radius_sd, "leaf_radius_sd", allow_zero=True, strict=True, unit="m")
    rmin = positive_scalar(leaf_radius_min, "leaf_radius_min", strict=True, unit="m")
    if rmin >= rmean:
        raise ValueError(f"leaf_radius_min ({rmin}) must be below leaf_radius_mean ({rmean})")
    n_lat = integer(laterals_per_node, "laterals_per_node", 0)
    div = finite_scalar(divergence_deg, "divergence_deg", strict=True)
    ajit = positive_scalar(angle_jitter_deg, "angle_jitter_deg", allow_zero=True, strict=True)
    ljit = positive_scalar(length_jitter, "length_jitter", allow_zero=True, strict=True)
    if ljit >= 1:
        raise ValueError(f"length_jitter must be in [0, 1), got {length_jitter!r}")
    petiole = positive_scalar(
        petiole_length, "petiole_length", allow_zero=True, strict=True, unit="m"
    )
    w0 = positive_scalar(trunk_radius, "trunk_radius", strict=True, unit="m")
    wc = positive_scalar(width_contraction, "width_contraction", strict=True)
    sides = integer(bark_sides, "bark_sides", 3)
    b0 = point3(base, "base")
    _guard_tree(levels, n_lat, n_nodes, per_node, sides)
    if w0 * _power(min(wc, 1.0), levels) == 0.0 or not math.isfinite(
        w0 * _power(max(wc, 1.0), levels)
    ):
        raise ValueError(
            f"trunk_radius * width_contraction**n_levels = {w0} * {wc}**{levels} leaves float64 "
            "(0 or inf); use fewer n_levels or a width_contraction nearer 1"
        )
    longest = l0 * _power(max(c_lat, c_ctr, 1.0) * (1.0 + ljit), levels)
    if not math.isfinite(longest * (levels + 1)):
        raise ValueError(
            f"initial_length * contraction**n_levels = {l0} * {max(c_lat, c_ctr)}**{levels} "
            "leaves float64; use fewer n_levels or contractions of at most 1"
        )
    shortest = l0 * _power(min(c_lat, c_ctr, 1.0), levels)
    if not shortest >= MIN_SEGMENT_M:
        raise ValueError(
            f"initial_length * contraction**n_levels = {l0} * {min(c_lat, c_ctr)}**{levels} "
            f"gives segments of about {shortest:.3g} m, below {MIN_SEGMENT_M:g} m (their ends "
            "would not differ in float64 at a tree's size); use fewer n_levels or contractions "
            "nearer 1"
        )

    counter = [0]

    def f(x: float) -> str:
        return repr(float(x))

    def grow(length: float, level: float, branch: float) -> str:
        k = round(level)
        b = round(branch)
        w = w0 * wc**k
        parts = [f"!({f(w)})"]
        if k == 0:
            parts.append(f"G({b})F({f(length)})")
        else:
            piece = length / n_nodes
            parts.append("".join(f"G({b})F({f(piece)})L({b})" for _ in range(n_nodes)))
        if k >= levels:
            return "".join(parts)
        parts.append(f"/({f(div + ajit * gen.uniform(-1.0, 1.0))})")
        for j in range(n_lat):
            child = b
            if b < 0:
                child = counter[0]
                counter[0] += 1
            a = angle + ajit * gen.uniform(-1.0, 1.0)
            ll = c_lat * length * (1.0 + ljit * gen.uniform(-1.0, 1.0))
            parts.append(f"[/({f(360.0 * j / n_lat)})&({f(a)})A({f(ll)},{k + 1},{child})]")
        lc = c_ctr * length * (1.0 + ljit * gen.uniform(-1.0, 1.0))
        parts.append(f"A({f(lc)},{k + 1},{b})")
        return "".join(parts)

    system = LSystem(f"A({f(l0)},0,-1)", {"A": grow}, seed=gen)
    string = system.derive(levels + 1)
    seg = turtle(string, origin=b0, marks="GL", width=w0)
    mk = seg.marks
    is_g = mk.symbols == "G"
    seg_branch = np.array([int(p[0]) for p, g in zip(mk.params, is_g, strict=True) if g])
    node_branch = np.array([int(p[0]) for p, g in zip(mk.params, is_g, strict=True) if not g])
    node_pos = mk.positions[~is_g]
    node_h, node_l, node_u = mk.headings[~is_g], mk.lefts[~is_g], mk.ups[~is_g]

    # bark
    r = seg.widths
    verts, faces = _tubes(seg.starts, seg.ends, seg.lefts, seg.ups, r, r, sides)
    n_br = counter[0]
    names = ("trunk", *(f"branch_{i:02d}" for i in range(n_br)))
    groups = np.repeat(seg_branch + 1, 2 * sides)

    # leaves: clusters at the nodes
    m = len(node_pos)
    if m == 0:
        raise ValueError("the L-system tree has no leaf nodes (n_levels = 0?)")
    psi0 = gen.uniform(0.0, 2.0 * np.pi, m)
    psi = psi0[:, None] + 2.0 * np.pi * np.arange(per_node)[None, :] / per_node
    radial = (
        np.cos(psi)[..., None] * node_l[:, None, :] + np.sin(psi)[..., None] * node_u[:, None, :]
    )
    gamma = math.radians(60.0)
    out = math.cos(gamma) * node_h[:, None, :] + math.sin(gamma) * radial
    radii = gen.normal(rmean, rsd, (m, per_node))
    while (bad := radii < rmin).any():
        radii[bad] = gen.normal(rmean, rsd, int(bad.sum()))
    centers = node_pos[:, None, :] + (petiole + radii)[..., None] * out
    normals = gen.standard_normal((m, per_node, 3))
    normals = unit_rows(normals)
    leaves = Leaves(centers.reshape(-1, 3), normals.reshape(-1, 3), radii.reshape(-1))
    leaf_branch = np.repeat(node_branch, per_node)
    layout = _lsystem_layout(seg, seg_branch, n_br)
    params = {
        "scheme": "grow_lsystem_tree",
        **record,
        "n_levels": levels,
        "contraction": c_lat,
        "branching_angle_deg": angle,
        "initial_length": l0,
        "leaf_nodes_per_branch": n_nodes,
        "centre_contraction": c_ctr,
        "leaves_per_node": per_node,
        "leaf_radius_mean": rmean,
        "leaf_radius_sd": rsd,
        "leaf_radius_min": rmin,
        "laterals_per_node": n_lat,
        "divergence_deg": div,
        "angle_jitter_deg": ajit,
        "length_jitter": ljit,
        "petiole_length": petiole,
        "trunk_radius": w0,
        "width_contraction": wc,
        "bark_sides": sides,
        "base": b0.tolist(),
        "lsystem_string_length": len(string),
    }
    return Tree(
        leaves=leaves,
        bark_vertices=verts,
        bark_faces=faces,
        bark_groups=groups,
        bark_group_names=names,
        leaf_branch=leaf_branch,
        leaf_cluster=np.repeat(np.arange(m), per_node),
        branch_names=names[1:],
        base=b0,
        params=params,
        layout=layout,
        branches=Branches(seg.starts, seg.ends, r),
    )


def _lsystem_layout(seg: Any, seg_branch: np.ndarray, n_br: int) -> BranchLayout:
    """First-level branches of an L-system tree: origin = start of their first segment,
    direction = its heading; the axis is the chain of its first segments that keep going
    (approximated by the segments of the branch at the lowest bracket depth)."""
    origins, dirs, axes = [], [], []
    for b in range(n_br):
        idx = np.flatnonzero(seg_branch == b)
        first = idx[0]
        top = idx[seg.depth[idx] == seg.depth[first]]
        origins.append(seg.starts[first])
        dirs.append(seg.headings[first] / np.linalg.norm(seg.headings[first]))
        axes.append(frozen(np.concatenate([seg.starts[top[:1]], seg.ends[top]])))
    return BranchLayout(
        origins=frozen(np.array(origins).reshape(-1, 3)),
        directions=frozen(np.array(dirs).reshape(-1, 3)),
        reference_index=frozen(np.full(n_br, -1), np.int64),
        length_scales=frozen(np.ones(n_br)),
        bend_vectors_deg=frozen(np.zeros((n_br, 3))),
        axes=tuple(axes),
    )


__all__ = ["grow_lsystem_tree"]
