"""The reference's shading (docs/model.md §10), by brute force: the leaf disks a ray crosses,
whether a branch blocks it, the factor tau^(m_out + m_back) of each counting leaf and branch
piece, and ``leaf_sights``.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np

from .._geometry import dots
from ..flight.poses import Poses
from ..sonar.sonar import Sonar
from ..trees.branches import Branches
from ..trees.leaves import Leaves
from .lobe import _counting
from .parts import _parts


def _disk_crossings(leaves: Leaves, origin: np.ndarray, w: np.ndarray, own: int) -> int:
    """How many leaf disks (all but ``own``) the open segment t w, 0 < t < 1, from the origin
    crosses: the plane's hit t = (n . v) / (n . w) in (0, 1), inside the radius or on the rim.
    A segment parallel to a disk's plane does not cross it."""
    v = leaves.centers - origin
    nrm = leaves.normals
    # (at extreme coordinates the products overflow to inf or NaN, which the tests below
    # reject as the Rust core does)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        nv = dots(nrm, v)
        d = nrm[:, 0] * w[0] + nrm[:, 1] * w[1] + nrm[:, 2] * w[2]
        t = nv / d
        q = t[:, None] * w[None, :] - v
        hit = (d != 0.0) & (t > 0.0) & (t < 1.0) & (dots(q, q) <= leaves.radii * leaves.radii)
    if own >= 0:
        hit[own] = False
    return int(hit.sum())


def _joined(branches: Branches) -> list[set[int]]:
    """For each segment, the others that share one of its end points bit for bit."""
    key = lambda x: tuple(np.asarray(x, dtype=np.float64).view(np.uint64).tolist())
    at: dict[tuple, set[int]] = {}
    for j in range(len(branches)):
        for pt in {key(branches.starts[j]), key(branches.ends[j])}:
            at.setdefault(pt, set()).add(j)
    return [
        (at[key(branches.starts[j])] | at[key(branches.ends[j])]) - {j}
        for j in range(len(branches))
    ]


def _blocked(branches: Branches, origin: np.ndarray, w: np.ndarray, spared: set[int]) -> bool:
    """Whether the open segment t w, 0 < t < 1, passes through the interior of a branch
    cylinder (any but those in ``spared``): some t where the point lies closer to the axis
    than the radius and strictly between the segment's end planes."""
    for j in range(len(branches)):
        if j in spared:
            continue
        d = branches.ends[j] - branches.starts[j]
        length = math.sqrt(float(dots(d, d)))
        u = d / length
        s = branches.starts[j] - origin
        su = float(dots(s, u))
        e0 = s - su * u
        c = float(dots(e0, e0)) - float(branches.radii[j]) ** 2
        sw = float(dots(w, u))
        e1 = w - sw * u
        qa, qb = float(dots(e1, e1)), float(dots(e0, e1))
        lo, hi = 0.0, 1.0
        if qa == 0.0:
            if not c < 0.0:
                continue
        else:
            disc = qb * qb - qa * c
            if not disc > 0.0:
                continue
            root = math.sqrt(disc)
            lo, hi = max(lo, (qb - root) / qa), min(hi, (qb + root) / qa)
        if sw == 0.0:
            if not 0.0 < -su < length:
                continue
        else:
            t0, t1 = su / sw, (su + length) / sw
            a, b = (t0, t1) if sw > 0.0 else (t1, t0)
            lo, hi = max(lo, a), min(hi, b)
        if lo < hi:
            return True
    return False


def _two_way_factor(tau: float, s: int) -> float:
    """tau^s, s = m_out + m_back (docs/model.md §10), as (tau^2)^(s // 2), times tau for odd
    s."""
    even = 1.0 if s < 2 else (tau * tau) ** (s // 2)
    return even * tau if s % 2 else even


def _shading(
    leaves: Leaves | None,
    branches: Branches | None,
    sonar: Sonar,
    tx: np.ndarray,
    leaf_idx: np.ndarray,
    piece_seg: np.ndarray,
    piece_ref: np.ndarray,
    at: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """For the leaves ``leaf_idx`` and the pieces (segments ``piece_seg``, reference points
    ``piece_ref`` (n, 3)) heard from the emitter at ``tx``, by the receiver at ``at`` (None:
    at the emitter), by brute force (docs/model.md §10): tau^(m_out + m_back), m_out the leaf
    disks the open segment from the emitter to the leaf's centre (the piece's reference point)
    crosses, m_back those the segment from the receiver crosses (a leaf's own disk apart;
    m_back = m_out at the emitter), and 0 where a branch blocks either (with
    ``branches_block``; a piece's own segment and those joined to it apart)."""
    sh = sonar.shading
    if sh is None:
        return np.ones(len(leaf_idx)), np.ones(len(piece_seg))
    tau = sh.leaf_transmission
    joined = _joined(branches) if branches is not None else []
    ends = (tx,) if at is None else (tx, at)

    def factor(point: np.ndarray, own_leaf: int, spared: set[int]) -> float:
        s = 0
        for origin in ends:
            w = point - origin
            if sh.branches_block and branches is not None and _blocked(branches, origin, w, spared):
                return 0.0
            s += 0 if leaves is None else _disk_crossings(leaves, origin, w, own_leaf)
        return _two_way_factor(tau, 2 * s if at is None else s)

    assert leaves is not None or len(leaf_idx) == 0
    fl = [factor(cast(Leaves, leaves).centers[j], int(j), set()) for j in leaf_idx]
    fp = [factor(piece_ref[q], -1, {int(g)} | joined[g]) for q, g in enumerate(piece_seg)]
    return np.asarray(fl, dtype=np.float64), np.asarray(fp, dtype=np.float64)


def leaf_sights(scene: Any, sonar: Sonar, pose: Poses, *, branches_block: bool = True):
    """For each counting leaf of one pose (ascending index): the other leaf disks its ray
    crosses and whether a branch blocks it, by testing every leaf and branch."""
    from ..echoes.simulate import LeafSights, refuse_receivers

    refuse_receivers(sonar, "leaf_sights")
    leaves, branches = _parts(scene)
    if leaves is None:
        raise ValueError("leaf_sights needs a scene with leaves")
    idx = np.flatnonzero(_counting(leaves, sonar, pose, 0)[0])
    origin = pose.positions[0]
    crossings = np.zeros(idx.size, dtype=np.int64)
    blocked = np.zeros(idx.size, dtype=bool)
    for q, j in enumerate(idx):
        w = leaves.centers[j] - origin
        crossings[q] = _disk_crossings(leaves, origin, w, int(j))
        if branches_block and branches is not None:
            blocked[q] = _blocked(branches, origin, w, set())
    return LeafSights(idx.astype(np.int64), crossings, blocked)
