"""Trees: leaf disks plus bark triangles, grown the paper's way or the authors' L-system way.

* :func:`grow_tree` -- the paper's scheme: an L-system (:func:`~batecho.lsystem.trunk_branching`)
  says where first-level branches leave the trunk and in which direction; each branch is a
  branch of a reference CAD tree (the shipped OBJ by default), transported there and randomised
  in curvature, length and sub-branch positions.
* :func:`grow_lsystem_tree` -- the authors' own ginkgo-like L-system tree (MODEL.md section 7).
* :func:`load_tree` -- a user's OBJ tree as it is.

Conventions: metres, z up, angles in degrees only in names ending ``_deg``. Trees are built
around their trunk base (``base``, default the origin). Every random draw comes from the numpy
``Generator`` passed in, so equal seeds give equal trees.

**The reference tree.** ``data/reference_tree.obj`` (made by ``tools/make_reference_tree.py``)
has a bark group ``trunk``, one bark group per first-level branch (``branch_00`` ... : the bark
of the branch's axis, its sub-branches and their twigs) and one leaf group per branch
(``leaves_branch_00`` ...). The sidecar ``reference_tree.json`` describes each branch's structure:
its *axis* polyline (starting on the trunk axis), how many of the group's bark triangles belong
to the axis tube, and the sub-branch *units* (a sub-branch with its twigs and leaves) with their
anchors, arc lengths along the axis. For an OBJ without such a sidecar the structure is derived
(:func:`load_reference`): bark groups whose name contains ``trunk`` are the trunk, every other
bark group is a first-level branch whose axis is the straight line from the trunk axis to the
branch's farthest point, and the connected pieces of its bark (with the leaves nearest to them)
are its units.

**Randomisation** (:func:`grow_tree`), for a branch transported to the L-system's branch point
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

With ``length_sd = bend_sd_deg = droop_deg = slide_sd = 0`` and ``length_scale = 1`` each
branch is the reference branch moved rigidly (``x -> o + Q (x - base)``), where ``Q`` turns the
chord's azimuth and then its polar angle into ``d``'s (so a branch's upper side stays up).
"""

from __future__ import annotations

import functools
import json
import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .leaves import Leaves
from .lsystem import LSystem, trunk_branching, turtle
from .meshio import Mesh, load_obj, write_obj

__all__ = [
    "REFERENCE_TREE",
    "BranchLayout",
    "BranchTemplate",
    "ReferenceTree",
    "Tree",
    "grow_lsystem_tree",
    "grow_tree",
    "load_reference",
    "load_tree",
]

#: The shipped reference tree (Wavefront OBJ; ``reference_tree.mtl`` and the structure sidecar
#: ``reference_tree.json`` lie beside it).
REFERENCE_TREE: Path = Path(__file__).resolve().parent / "data" / "reference_tree.obj"

_JSON_FORMAT = "batecho-reference-tree"
_Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# small helpers
# --------------------------------------------------------------------------------------------


def _gen(rng: Any) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or (isinstance(rng, numbers.Integral) and not isinstance(rng, bool)):
        return np.random.default_rng(rng)
    if isinstance(rng, np.random.SeedSequence):
        return np.random.default_rng(rng)
    raise TypeError(f"rng must be a numpy Generator, an int seed or None, got {rng!r}")


def _seed_record(rng: Any, gen: np.random.Generator) -> dict[str, Any]:
    """What reproduces a tree: the int seed (if one was given) and the bit generator state."""
    seed = int(rng) if isinstance(rng, numbers.Integral) and not isinstance(rng, bool) else None
    return {"seed": seed, "rng_state": gen.bit_generator.state}


def _real(x: Any, name: str) -> float:
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {x!r}")
    v = float(x)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return v


def _positive(x: Any, name: str, unit: str = "") -> float:
    v = _real(x, name)
    if v <= 0:
        raise ValueError(f"{name} must be > 0{' ' + unit if unit else ''}, got {x!r}")
    return v


def _nonneg(x: Any, name: str, unit: str = "") -> float:
    v = _real(x, name)
    if v < 0:
        raise ValueError(f"{name} must be >= 0{' ' + unit if unit else ''}, got {x!r}")
    return v


def _count(x: Any, name: str, minimum: int = 0) -> int:
    if isinstance(x, bool) or not isinstance(x, numbers.Integral) or x < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {x!r}")
    return int(x)


def _point3(x: Any, name: str) -> np.ndarray:
    try:
        v = np.array(x, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a 3-vector of real numbers, got {x!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be a finite 3-vector, got {x!r}")
    return v


def _ro(a: np.ndarray, dtype: Any = np.float64) -> np.ndarray:
    out = np.ascontiguousarray(a, dtype=dtype)
    if out is a or out.base is not None:
        out = out.copy()
    out.setflags(write=False)
    return out


def _unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _rodrigues(v: np.ndarray, axis: np.ndarray, cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Rotate rows ``v`` about unit ``axis`` (one (3,) or one per row) by angles given as their
    cosines and sines (broadcast over rows)."""
    axis = np.broadcast_to(axis, v.shape)
    c = np.asarray(cos)[..., None]
    s = np.asarray(sin)[..., None]
    d = np.einsum("ij,ij->i", axis, v)[:, None]
    return v * c + np.cross(axis, v) * s + axis * d * (1.0 - c)


def _rot_z(angle_deg: float) -> np.ndarray:
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _transport(chord: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The rotation taking unit ``chord`` to unit ``direction``: turn the azimuth to 0, change
    the polar angle (about the horizontal axis perpendicular to it), turn to the new azimuth.
    Keeps a branch's upper side up (unlike the minimal rotation)."""

    def polar_azimuth(u: np.ndarray) -> tuple[float, float]:
        rho = math.hypot(u[0], u[1])
        polar = math.atan2(rho, u[2])
        az = math.atan2(u[1], u[0]) if rho > 1e-12 else 0.0
        return polar, az

    pc, ac = polar_azimuth(chord)
    pd, ad = polar_azimuth(direction)
    b = pd - pc
    cb, sb = math.cos(b), math.sin(b)
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    return _rot_z(math.degrees(ad)) @ ry @ _rot_z(-math.degrees(ac))


def _arc(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def _dedupe_polyline(points: np.ndarray) -> np.ndarray:
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-9])
    pts = points[keep]
    if len(pts) < 2:
        raise ValueError("a branch axis needs at least two distinct points")
    return pts


def _segment_of(arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(arc) - 2)


def _project(points: np.ndarray, axis: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Arc length of the nearest point of the polyline ``axis`` to each of ``points``."""
    a = axis[:-1]
    d = np.diff(axis, axis=0)
    ll = np.einsum("ij,ij->i", d, d)
    best = np.full(len(points), np.inf)
    out = np.zeros(len(points))
    for j in range(len(a)):  # a few dozen segments at most
        t = np.clip((points - a[j]) @ d[j] / ll[j], 0.0, 1.0)
        q = a[j] + t[:, None] * d[j]
        dist = np.einsum("ij,ij->i", points - q, points - q)
        better = dist < best
        best[better] = dist[better]
        out[better] = arc[j] + t[better] * math.sqrt(ll[j])
    return out


def _at(axis: np.ndarray, arc: np.ndarray, s: np.ndarray) -> np.ndarray:
    j = _segment_of(arc, s)
    d = axis[j + 1] - axis[j]
    f = (s - arc[j]) / (arc[j + 1] - arc[j])
    return axis[j] + f[:, None] * d


def _bounds(vertices: np.ndarray, leaves: Leaves | None) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = [], []
    if len(vertices):
        lo.append(vertices.min(axis=0))
        hi.append(vertices.max(axis=0))
    if leaves is not None:
        nv = leaves.normals
        ext = leaves.radii[:, None] * np.sqrt(np.clip(1.0 - nv * nv, 0.0, None))
        lo.append((leaves.centers - ext).min(axis=0))
        hi.append((leaves.centers + ext).max(axis=0))
    return np.min(lo, axis=0), np.max(hi, axis=0)


# --------------------------------------------------------------------------------------------
# Tree
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class BranchLayout:
    """Where a grown tree's first-level branches are and how they were randomised.

    ``origins`` (b, 3) m, branch points on the trunk axis; ``directions`` (b, 3) unit vectors
    (the L-system's directions, the reference chord's new direction); ``reference_index`` (b,)
    the reference branch each one copies (-1 for L-system trees); ``length_scales`` (b,) the
    factors ``f``; ``bend_vectors_deg`` (b, 3) the extra turn of each tip as a rotation vector,
    degrees; ``axes`` the final axis polylines ((m_i, 3) each, m), from origin to tip.
    """

    origins: np.ndarray
    directions: np.ndarray
    reference_index: np.ndarray
    length_scales: np.ndarray
    bend_vectors_deg: np.ndarray
    axes: tuple[np.ndarray, ...]

    def __len__(self) -> int:
        return int(self.origins.shape[0])

    @property
    def tips(self) -> np.ndarray:
        """(b, 3) the axes' end points, m."""
        if not self.axes:
            return np.zeros((0, 3))
        return np.array([a[-1] for a in self.axes])

    def _moved(self, rot: np.ndarray, base: np.ndarray, t: np.ndarray, s: float) -> BranchLayout:
        def move(x: np.ndarray) -> np.ndarray:
            return _ro(base + s * ((x - base) @ rot.T) + t)

        return BranchLayout(
            origins=move(self.origins),
            directions=_ro(self.directions @ rot.T),
            reference_index=self.reference_index,
            length_scales=self.length_scales,
            bend_vectors_deg=_ro(self.bend_vectors_deg @ rot.T),
            axes=tuple(move(a) for a in self.axes),
        )


@dataclass(frozen=True, eq=False)
class Tree:
    """One tree: leaf disks and bark triangles, z up, metres.

    Attributes
    ----------
    leaves : Leaves
        The leaf disks.
    bark_vertices : (v, 3) float64
    bark_faces : (f, 3) int64
        Bark triangles, indices into ``bark_vertices``.
    bark_groups : (f,) int64
        Index into ``bark_group_names`` of each triangle (``trunk``, ``branch_00``, ...).
    bark_group_names : tuple of str
    leaf_branch : (n,) int64
        First-level branch of each leaf, an index into ``branch_names`` (-1: on the trunk or
        unknown).
    leaf_cluster : (n,) int64
        Leaves sharing an attachment (a sub-branch unit of a reference branch, or an L-system
        leaf node) share a number; -1 where unknown.
    branch_names : tuple of str
        The first-level branches (their bark group names).
    base : (3,) float64
        The trunk base, m.
    params : dict
        The parameters and the seed used (``seed``: the int seed or None; ``rng_state``: the
        bit generator's state on entry, which reproduces the tree).
    branches : BranchLayout or None
        The first-level branching of a grown tree.
    """

    leaves: Leaves
    bark_vertices: np.ndarray
    bark_faces: np.ndarray
    bark_groups: np.ndarray
    bark_group_names: tuple[str, ...]
    leaf_branch: np.ndarray
    leaf_cluster: np.ndarray
    branch_names: tuple[str, ...] = ()
    base: np.ndarray = field(default_factory=lambda: np.zeros(3))
    params: dict[str, Any] = field(default_factory=dict)
    branches: BranchLayout | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.leaves, Leaves):
            raise TypeError(f"leaves must be Leaves, got {type(self.leaves).__name__}")
        n = len(self.leaves)
        bv = np.asarray(self.bark_vertices, dtype=np.float64).reshape(-1, 3)
        bf = np.asarray(self.bark_faces, dtype=np.int64).reshape(-1, 3)
        if len(bf) and (bf.min() < 0 or bf.max() >= len(bv)):
            raise ValueError("bark_faces index outside bark_vertices")
        names = tuple(str(s) for s in self.bark_group_names) or ("bark",)
        bg = np.zeros(len(bf), np.int64) if self.bark_groups is None else self.bark_groups
        bg = np.asarray(bg, dtype=np.int64).reshape(-1)
        if bg.shape != (len(bf),) or (len(bg) and (bg.min() < 0 or bg.max() >= len(names))):
            raise ValueError("bark_groups must give each face an index into bark_group_names")
        lb = np.asarray(self.leaf_branch, dtype=np.int64).reshape(-1)
        lc = np.asarray(self.leaf_cluster, dtype=np.int64).reshape(-1)
        if lb.shape != (n,) or lc.shape != (n,):
            raise ValueError(f"leaf_branch and leaf_cluster must have shape ({n},)")
        bnames = tuple(str(s) for s in self.branch_names)
        if n and (lb.min() < -1 or lb.max() >= len(bnames)):
            raise ValueError("leaf_branch must be -1 or an index into branch_names")
        set_(self, "bark_vertices", _ro(bv))
        set_(self, "bark_faces", _ro(bf, np.int64))
        set_(self, "bark_groups", _ro(bg, np.int64))
        set_(self, "bark_group_names", names)
        set_(self, "leaf_branch", _ro(lb, np.int64))
        set_(self, "leaf_cluster", _ro(lc, np.int64))
        set_(self, "branch_names", bnames)
        set_(self, "base", _ro(_point3(self.base, "base")))
        set_(self, "params", dict(self.params))

    # -- properties ---------------------------------------------------------------------------

    @property
    def n_leaves(self) -> int:
        return len(self.leaves)

    def __len__(self) -> int:
        return len(self.leaves)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box ``(min, max)`` of the bark and the leaf disks, m."""
        return _bounds(self.bark_vertices, self.leaves)

    @property
    def height(self) -> float:
        """Top of the tree (bark or leaf disk) above its base, m."""
        return float(self.bounds()[1][2] - self.base[2])

    @property
    def trunk_top(self) -> np.ndarray:
        """(3,) the top of the trunk: above the base, at the highest vertex of the bark groups
        named like ``trunk`` (the tree's top where there is none), m."""
        tg = [i for i, n in enumerate(self.bark_group_names) if "trunk" in n.lower()]
        sel = np.isin(self.bark_groups, tg)
        if sel.any():
            z = float(self.bark_vertices[np.unique(self.bark_faces[sel]), 2].max())
        else:
            z = float(self.bounds()[1][2])
        return np.array([self.base[0], self.base[1], z])

    @property
    def crown_radius(self) -> float:
        """Largest horizontal distance of a leaf centre from the trunk axis, m."""
        d = self.leaves.centers[:, :2] - self.base[:2]
        return float(np.sqrt((d * d).sum(axis=1)).max())

    def __repr__(self) -> str:
        return (
            f"Tree(n_leaves={self.n_leaves}, bark_faces={len(self.bark_faces)}, "
            f"branches={len(self.branch_names)}, height={self.height:.2f} m)"
        )

    # -- conversions ----------------------------------------------------------------------------

    def _leaf_groups(self) -> tuple[np.ndarray, list[str]]:
        names = ["leaves"] + [f"leaves_{b}" for b in self.branch_names]
        return self.leaf_branch + 1, names

    def to_mesh(self) -> Mesh:
        """The tree as a :class:`~batecho.meshio.Mesh` (groups: bark groups, then leaf groups
        ``leaves`` and ``leaves_<branch>``)."""
        lg, lnames = self._leaf_groups()
        nb = len(self.bark_group_names)
        return Mesh(
            leaves=self.leaves,
            bark_vertices=self.bark_vertices,
            bark_faces=self.bark_faces,
            leaf_groups=lg + nb,
            bark_face_groups=self.bark_groups,
            group_names=(*self.bark_group_names, *lnames),
        )

    def to_obj(self, path: str | os.PathLike, sides: int = 8, mtl: bool = True) -> Path:
        """Write the tree as an OBJ (+ MTL): bark triangles in their groups, each leaf disk as a
        ``sides``-gon card of the same centre, normal and area in ``leaves_<branch>`` groups,
        so that :func:`load_tree` reads back the same disks and branches. Returns the path."""
        lg, lnames = self._leaf_groups()
        return write_obj(
            path,
            self.bark_vertices,
            self.bark_faces,
            self.leaves,
            bark_groups=self.bark_groups,
            bark_group_names=self.bark_group_names,
            leaf_groups=lg,
            leaf_group_names=lnames,
            sides=sides,
            mtl=mtl,
            comment=f"batecho tree: {self.n_leaves} leaves, height {self.height:.3f} m",
        )

    def transformed(
        self,
        rotation_z_deg: float = 0.0,
        translation: Sequence[float] = (0.0, 0.0, 0.0),
        scale: float = 1.0,
        scale_leaves: bool = False,
    ) -> Tree:
        """The tree turned by ``rotation_z_deg`` about the vertical through its base, scaled by
        ``scale`` about its base, then moved by ``translation`` (m):
        ``x -> base + scale * Rz (x - base) + translation``. Leaf radii keep their size unless
        ``scale_leaves`` (leaf size is a species trait, tree size is not)."""
        rot = _rot_z(_real(rotation_z_deg, "rotation_z_deg"))
        t = _point3(translation, "translation")
        s = _positive(scale, "scale")
        b = self.base
        lv = self.leaves
        leaves = Leaves._trusted(
            b + s * ((lv.centers - b) @ rot.T) + t,
            lv.normals @ rot.T,
            lv.radii * s if scale_leaves else lv.radii,
        )
        return replace(
            self,
            leaves=leaves,
            bark_vertices=b + s * ((self.bark_vertices - b) @ rot.T) + t,
            base=b + t,
            branches=None if self.branches is None else self.branches._moved(rot, b, t, s),
        )


# --------------------------------------------------------------------------------------------
# reference trees
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class BranchTemplate:
    """One first-level branch of a reference tree, ready to be transported and randomised.

    Everything in the reference's frame (m). ``axis`` (m, 3) polyline from ``base`` (on the
    trunk axis) with arc lengths ``arc``; ``chord`` the unit vector from base to tip. Points
    (bark vertices, then leaf centres) hang on the axis: ``unit`` -1 for the axis itself (the
    point rides on the axis at its own arc length ``anchor``), else the sub-branch unit, which
    hangs rigidly at ``unit_anchors[unit]``; ``offset`` is the point minus its anchor point.
    """

    name: str
    base: np.ndarray
    axis: np.ndarray
    arc: np.ndarray
    chord: np.ndarray
    height: float
    vertices: np.ndarray
    faces: np.ndarray
    vertex_unit: np.ndarray
    leaf_centers: np.ndarray
    leaf_normals: np.ndarray
    leaf_radii: np.ndarray
    leaf_unit: np.ndarray
    unit_anchors: np.ndarray

    @property
    def length(self) -> float:
        """Arc length of the axis, m."""
        return float(self.arc[-1])

    @property
    def n_units(self) -> int:
        return len(self.unit_anchors)

    @functools.cached_property
    def _hang(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(anchor arc length, unit, offset) of every point: vertices then leaf centres."""
        pts = np.concatenate([self.vertices, self.leaf_centers])
        unit = np.concatenate([self.vertex_unit, self.leaf_unit])
        anchor = np.empty(len(pts))
        on_axis = unit < 0
        anchor[on_axis] = _project(pts[on_axis], self.axis, self.arc)
        anchor[~on_axis] = self.unit_anchors[unit[~on_axis]]
        offset = pts - _at(self.axis, self.arc, anchor)
        return anchor, unit, offset


@dataclass(frozen=True, eq=False)
class ReferenceTree:
    """A reference tree split into trunk and first-level branch templates (see
    :func:`load_reference`). ``structure`` is ``"json"`` (from the sidecar) or ``"derived"``."""

    mesh: Mesh
    trunk_base: np.ndarray
    trunk_top: np.ndarray
    trunk_vertices: np.ndarray
    trunk_faces: np.ndarray
    trunk_leaves: Leaves | None
    branches: tuple[BranchTemplate, ...]
    structure: str
    source: Path | None = None

    @property
    def trunk_height(self) -> float:
        return float(self.trunk_top[2] - self.trunk_base[2])

    @property
    def heights(self) -> np.ndarray:
        """(b,) heights of the branch bases above the trunk base, m."""
        return np.array([b.height for b in self.branches])

    @property
    def n_leaves(self) -> int:
        return self.mesh.n_leaves

    def __repr__(self) -> str:
        src = "" if self.source is None else f", source={self.source.name!r}"
        return (
            f"ReferenceTree(branches={len(self.branches)}, n_leaves={self.n_leaves}, "
            f"trunk_height={self.trunk_height:.2f} m, structure={self.structure!r}{src})"
        )

    def tree(self) -> Tree:
        """The reference itself as a :class:`Tree` (trunk base moved to the origin)."""
        return _assemble(
            self,
            [self._placed(k) for k in range(len(self.branches))],
            trunk_height=self.trunk_height,
            base=np.zeros(3),
            layout=None,
            params={"reference": str(self.source) if self.source else None, "grown": False},
        )

    def _placed(self, k: int) -> _Placed:
        b = self.branches[k]
        pts = np.concatenate([b.vertices, b.leaf_centers]) - self.trunk_base
        nv = len(b.vertices)
        return _Placed(pts[:nv], pts[nv:], b.leaf_normals, k, b.axis - self.trunk_base)


def _sidecar(path: Path) -> dict[str, Any] | None:
    js = path.with_suffix(".json")
    if not js.is_file():
        return None
    try:
        doc = json.loads(js.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("format") != _JSON_FORMAT:
        return None
    return doc


def load_reference(
    reference: str | os.PathLike | Mesh | ReferenceTree | None = None,
    leaf_patterns: Sequence[str] | None = None,
    up: str = "z",
    scale: float = 1.0,
    trunk_pattern: str = "trunk",
) -> ReferenceTree:
    """A reference tree for :func:`grow_tree`: the shipped one (``None``), an OBJ path (with a
    ``.json`` structure sidecar beside it if there is one; both are loaded once per file version
    and options, then cached) or a loaded :class:`~batecho.meshio.Mesh` (derived anew each
    time: pass the returned ReferenceTree on to grow many trees from it).

    Without a sidecar the structure is derived per bark group: groups whose name contains
    ``trunk_pattern`` (case-insensitive; else the group holding the lowest vertex) are the
    trunk, whose axis is vertical through the mean of its lowest vertices; every other bark
    group is a first-level branch: its base is the point of the trunk axis at the height of its
    vertex nearest to that axis, its axis the straight line to its farthest point, and each
    connected piece of its bark that does not touch the base is a rigid sub-branch unit,
    anchored where it comes closest to the axis. A leaf belongs to the branch whose name its
    group name contains, else to the group of its nearest bark vertex; within a branch it
    joins the unit of its nearest bark vertex.
    """
    if isinstance(reference, ReferenceTree):
        return reference
    if isinstance(reference, Mesh):
        return _derive(reference, trunk_pattern)
    if reference is None:
        path = REFERENCE_TREE
        if not path.is_file():
            raise FileNotFoundError(
                f"the shipped reference tree {path} is missing (a broken install?); "
                "tools/make_reference_tree.py regenerates it"
            )
    elif isinstance(reference, (str, os.PathLike)):
        path = Path(reference).resolve()
        if not path.is_file():
            raise FileNotFoundError(f"reference tree OBJ not found: {path}")
    else:
        raise TypeError(
            "reference must be None, an OBJ path, a Mesh or a ReferenceTree; "
            f"got {type(reference).__name__}"
        )
    patterns = None if leaf_patterns is None else tuple(leaf_patterns)
    st = path.stat()
    return _cached_reference(
        str(path), st.st_mtime_ns, st.st_size, patterns, up, float(scale), trunk_pattern
    )


@functools.lru_cache(maxsize=8)
def _cached_reference(
    path: str,
    _mtime_ns: int,
    _size: int,
    leaf_patterns: tuple[str, ...] | None,
    up: str,
    scale: float,
    trunk_pattern: str,
) -> ReferenceTree:
    """An OBJ path's reference tree, loaded once per (file version, options)."""
    p = Path(path)
    mesh = load_obj(p, leaf_patterns=leaf_patterns, up=up, scale=scale)
    doc = _sidecar(p) if (up == "z" and scale == 1.0) else None
    if doc is not None:
        return _from_sidecar(mesh, doc, p)
    return _derive(mesh, trunk_pattern)


def _from_sidecar(mesh: Mesh, doc: Mapping[str, Any], path: Path) -> ReferenceTree:
    names = list(mesh.group_names)
    if mesh.leaves is None:
        raise ValueError(f"{path}: the reference tree has no leaves")

    def group(name: str) -> int:
        if name not in names:
            raise ValueError(f"{path}: group {name!r} named in the JSON sidecar is not in the OBJ")
        return names.index(name)

    used_faces = np.zeros(len(mesh.bark_faces), bool)
    used_leaves = np.zeros(mesh.n_leaves, bool)
    trunk = doc["trunk"]
    t_base = _point3(trunk["base"], "trunk base")
    t_top = _point3(trunk["top"], "trunk top")
    branches = []
    for b in doc["branches"]:
        fid = np.flatnonzero(mesh.bark_face_groups == group(b["bark_group"]))
        lid = np.flatnonzero(mesh.leaf_groups == group(b["leaf_group"]))
        tri = [int(b["axis_bark_triangles"]), *map(int, b["subbranch_bark_triangles"])]
        nl = [int(x) for x in b["subbranch_leaves"]]
        anchors = np.array(b["subbranch_anchors"], dtype=np.float64)
        if sum(tri) != len(fid) or sum(nl) != len(lid) or len(anchors) != len(nl):
            raise ValueError(
                f"{path}: the JSON sidecar does not match the OBJ for branch {b['name']!r} "
                f"({sum(tri)} bark triangles and {sum(nl)} leaves listed, {len(fid)} and "
                f"{len(lid)} found); regenerate both with tools/make_reference_tree.py"
            )
        used_faces[fid] = True
        used_leaves[lid] = True
        face_unit = np.repeat(np.arange(-1, len(nl)), tri)
        faces = mesh.bark_faces[fid]
        vid, local = np.unique(faces, return_inverse=True)
        vunit = np.full(len(vid), -1, np.int64)
        vunit[local.reshape(-1)] = np.repeat(face_unit, 3)
        axis = _dedupe_polyline(np.array(b["axis"], dtype=np.float64))
        branches.append(
            _template(
                b["name"],
                axis,
                t_base,
                mesh.bark_vertices[vid],
                local.reshape(-1, 3),
                vunit,
                mesh.leaves[lid] if len(lid) else None,
                np.repeat(np.arange(len(nl)), nl),
                anchors,
            )
        )
    t_faces = mesh.bark_faces[~used_faces]
    tv, tl = np.unique(t_faces, return_inverse=True)
    rest = np.flatnonzero(~used_leaves)
    return ReferenceTree(
        mesh=mesh,
        trunk_base=_ro(t_base),
        trunk_top=_ro(t_top),
        trunk_vertices=_ro(mesh.bark_vertices[tv]),
        trunk_faces=_ro(tl.reshape(-1, 3), np.int64),
        trunk_leaves=mesh.leaves[rest] if len(rest) else None,
        branches=tuple(branches),
        structure="json",
        source=path,
    )


def _template(
    name: str,
    axis: np.ndarray,
    trunk_base: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    vertex_unit: np.ndarray,
    leaves: Leaves | None,
    leaf_unit: np.ndarray,
    anchors: np.ndarray,
) -> BranchTemplate:
    arc = _arc(axis)
    chord = axis[-1] - axis[0]
    if np.linalg.norm(chord) < 1e-9:
        raise ValueError(f"branch {name!r}: its axis starts and ends at the same point")
    if leaves is None:
        lc, ln, lr = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    else:
        lc, ln, lr = leaves.centers, leaves.normals, leaves.radii
    return BranchTemplate(
        name=name,
        base=_ro(axis[0]),
        axis=_ro(axis),
        arc=_ro(arc),
        chord=_ro(chord / np.linalg.norm(chord)),
        height=float(axis[0, 2] - trunk_base[2]),
        vertices=_ro(vertices),
        faces=_ro(faces, np.int64),
        vertex_unit=_ro(vertex_unit, np.int64),
        leaf_centers=_ro(lc),
        leaf_normals=_ro(ln),
        leaf_radii=_ro(lr),
        leaf_unit=_ro(leaf_unit, np.int64),
        unit_anchors=_ro(np.clip(anchors, 0.0, arc[-1])),
    )


def _nearest(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Index of the nearest of ``targets`` to each of ``points``."""
    from scipy.spatial import cKDTree

    if len(points) == 0:
        return np.zeros(0, np.int64)
    return cKDTree(targets).query(points)[1].astype(np.int64)


def _derive(mesh: Mesh, trunk_pattern: str) -> ReferenceTree:
    """Structure from the groups alone (see :func:`load_reference`)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    if mesh.leaves is None:
        raise ValueError("the reference tree has no leaves")
    if len(mesh.bark_faces) == 0:
        raise ValueError("the reference tree has no bark; it needs a trunk and branch groups")
    names = list(mesh.group_names)
    fg = mesh.bark_face_groups
    present = [int(g) for g in np.unique(fg)]
    pat = trunk_pattern.lower()
    trunk_groups = [g for g in present if pat and pat in names[g].lower()]
    if not trunk_groups:
        lowest = int(np.argmin(mesh.bark_vertices[:, 2]))
        trunk_groups = [int(fg[np.flatnonzero((mesh.bark_faces == lowest).any(axis=1))[0]])]
    branch_groups = [g for g in present if g not in trunk_groups]
    if not branch_groups:
        raise ValueError(
            "the reference tree has a single bark group; grow_tree needs its first-level "
            "branches as separate bark groups (and a sidecar JSON for sub-branch structure)"
        )
    is_trunk = np.isin(fg, trunk_groups)
    tv_ids = np.unique(mesh.bark_faces[is_trunk])
    tverts = mesh.bark_vertices[tv_ids]
    z0, z1 = tverts[:, 2].min(), tverts[:, 2].max()
    low = tverts[tverts[:, 2] <= z0 + 0.05 * (z1 - z0) + 1e-9]
    cx, cy = low[:, 0].mean(), low[:, 1].mean()
    t_base = np.array([cx, cy, z0])
    t_top = np.array([cx, cy, z1])

    # leaves -> branch groups: by name, else by the nearest bark vertex's group
    leaves = mesh.leaves
    vgroup = np.full(len(mesh.bark_vertices), -1, np.int64)
    vgroup[mesh.bark_faces.reshape(-1)] = np.repeat(fg, 3)
    leaf_owner = np.full(len(leaves), -1, np.int64)
    by_name: dict[int, int] = {}
    for lg in np.unique(mesh.leaf_groups):
        hits = [g for g in branch_groups if names[g].lower() in names[lg].lower()]
        if hits:
            by_name[int(lg)] = max(hits, key=lambda g: len(names[g]))
    for lg, g in by_name.items():
        leaf_owner[mesh.leaf_groups == lg] = g
    rest = np.flatnonzero(leaf_owner < 0)
    if len(rest):
        used = np.unique(mesh.bark_faces)
        near = used[_nearest(leaves.centers[rest], mesh.bark_vertices[used])]
        g = vgroup[near]
        leaf_owner[rest] = np.where(np.isin(g, trunk_groups), -1, g)

    branches = []
    for g in branch_groups:
        faces = mesh.bark_faces[fg == g]
        vid, local = np.unique(faces, return_inverse=True)
        local = local.reshape(-1, 3)
        verts = mesh.bark_vertices[vid]
        lid = np.flatnonzero(leaf_owner == g)
        rho = np.hypot(verts[:, 0] - cx, verts[:, 1] - cy)
        k0 = int(np.argmin(rho))
        base = np.array([cx, cy, verts[k0, 2]])
        pts = np.concatenate([verts, leaves.centers[lid]])
        tip = pts[int(np.argmax(np.linalg.norm(pts - base, axis=1)))]
        axis = base + np.linspace(0.0, 1.0, 9)[:, None] * (tip - base)
        arc = _arc(axis)
        n = len(verts)
        rows = np.concatenate([local[:, 0], local[:, 1], local[:, 2]])
        cols = np.concatenate([local[:, 1], local[:, 2], local[:, 0]])
        adj = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
        _, comp = connected_components(adj, directed=False)
        root = comp[k0]
        others = [c for c in np.unique(comp) if c != root]
        cunit = np.full(comp.max() + 1, -1, np.int64)
        cunit[others] = np.arange(len(others))
        vunit = cunit[comp]
        anchors = np.zeros(len(others))
        if others:
            s = _project(verts, axis, arc)
            d = np.linalg.norm(verts - _at(axis, arc, s), axis=1)
            for j, c in enumerate(others):
                m = np.flatnonzero(comp == c)
                anchors[j] = s[m[np.argmin(d[m])]]
        lunit = vunit[_nearest(leaves.centers[lid], verts)] if len(lid) else np.zeros(0, int)
        branches.append(
            _template(
                names[g],
                axis,
                t_base,
                verts,
                local,
                vunit,
                leaves[lid] if len(lid) else None,
                lunit,
                anchors,
            )
        )
    order = np.argsort([b.height for b in branches], kind="stable")
    t_faces = mesh.bark_faces[is_trunk]
    tv, tl = np.unique(t_faces, return_inverse=True)
    rest = np.flatnonzero(leaf_owner < 0)
    return ReferenceTree(
        mesh=mesh,
        trunk_base=_ro(t_base),
        trunk_top=_ro(t_top),
        trunk_vertices=_ro(mesh.bark_vertices[tv]),
        trunk_faces=_ro(tl.reshape(-1, 3), np.int64),
        trunk_leaves=leaves[rest] if len(rest) else None,
        branches=tuple(branches[i] for i in order),
        structure="derived",
        source=mesh.source,
    )


# --------------------------------------------------------------------------------------------
# growing from a reference
# --------------------------------------------------------------------------------------------


@dataclass
class _Placed:
    """One branch in place, relative to the new trunk base: bark vertices, leaf centres and
    normals, the template index and the final axis."""

    vertices: np.ndarray
    leaf_centers: np.ndarray
    leaf_normals: np.ndarray
    template: int
    axis: np.ndarray


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
    ``bend`` (rad). Returns (points, leaf normals, axis), points = vertices then leaf centres,
    relative to the branch point."""
    anchor, unit, offset = tpl._hang
    axis = (tpl.axis - tpl.base) @ rot.T
    seg = np.diff(axis, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    dirs = seg / seg_len[:, None]
    arc = tpl.arc
    length = float(arc[-1])
    off = offset @ rot.T
    normals = tpl.leaf_normals @ rot.T
    nv = len(tpl.vertices)

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
        j_old = _segment_of(arc, ua)
        j_new = _segment_of(arc, ua_new / f)
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
            off[idx] = _rodrigues(off[idx], kh[uu[sel]], cos[uu[sel]], sin[uu[sel]])
            li = idx[idx >= nv] - nv
            lu = unit[li + nv]
            normals[li] = _rodrigues(normals[li], kh[lu], cos[lu], sin[lu])

    # the bent axis and its rotation at every anchor
    theta = float(np.linalg.norm(bend))
    t_arc = f * arc
    if theta > 1e-15:
        b = bend / theta
        kappa = theta / (f * length)
        steps = _bend_integral(dirs, t_arc[:-1], t_arc[1:], b, kappa)
        new_axis = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
        j = _segment_of(t_arc, t_new)
        at = new_axis[j] + _bend_integral(dirs[j], t_arc[j], t_new, b, kappa)
        c, s = np.cos(kappa * t_new), np.sin(kappa * t_new)
        pts = at + _rodrigues(off, b, c, s)
        li = np.arange(nv, len(t_new))
        normals = _rodrigues(normals, b, c[li], s[li])
    else:
        new_axis = f * axis
        pts = _at(new_axis, t_arc, t_new) + off
    return pts, normals, new_axis


def _assemble(
    ref: ReferenceTree,
    placed: list[_Placed],
    trunk_height: float,
    base: np.ndarray,
    layout: BranchLayout | None,
    params: dict[str, Any],
) -> Tree:
    """Trunk (stretched to ``trunk_height``) plus the placed branches, at ``base``."""
    zs = trunk_height / ref.trunk_height
    tv = ref.trunk_vertices - ref.trunk_base
    tv = tv * np.array([1.0, 1.0, zs]) + base
    verts = [tv]
    faces = [ref.trunk_faces]
    groups = [np.zeros(len(ref.trunk_faces), np.int64)]
    names = ["trunk"]
    branch_names = []
    lc, ln, lr, lb, lcl = [], [], [], [], []
    n_v = len(tv)
    if ref.trunk_leaves is not None:
        tl = ref.trunk_leaves
        lc.append((tl.centers - ref.trunk_base) * np.array([1.0, 1.0, zs]) + base)
        ln.append(tl.normals)
        lr.append(tl.radii)
        lb.append(np.full(len(tl), -1))
        lcl.append(np.full(len(tl), -1))
    cluster0 = 0
    for i, p in enumerate(placed):
        tpl = ref.branches[p.template]
        name = f"branch_{i:02d}"
        names.append(name)
        branch_names.append(name)
        verts.append(p.vertices + base)
        faces.append(tpl.faces + n_v)
        groups.append(np.full(len(tpl.faces), i + 1, np.int64))
        n_v += len(p.vertices)
        if len(tpl.leaf_radii):
            lc.append(p.leaf_centers + base)
            ln.append(p.leaf_normals)
            lr.append(tpl.leaf_radii)
            lb.append(np.full(len(tpl.leaf_radii), i))
            lcl.append(np.where(tpl.leaf_unit >= 0, tpl.leaf_unit + cluster0, -1))
        cluster0 += tpl.n_units
    if not lc:
        raise ValueError("the tree has no leaves")
    normals = np.concatenate(ln)
    leaves = Leaves._trusted(
        np.concatenate(lc), normals / np.linalg.norm(normals, axis=1)[:, None], np.concatenate(lr)
    )
    return Tree(
        leaves=leaves,
        bark_vertices=np.concatenate(verts),
        bark_faces=np.concatenate(faces),
        bark_groups=np.concatenate(groups),
        bark_group_names=tuple(names),
        leaf_branch=np.concatenate(lb),
        leaf_cluster=np.concatenate(lcl),
        branch_names=tuple(branch_names),
        base=base,
        params=params,
        branches=layout,
    )


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
        The L-system trunk (:func:`~batecho.lsystem.trunk_branching`), m; default the
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
    """
    gen = _gen(rng)
    record = _seed_record(rng, gen)
    ref = load_reference(reference)
    if not ref.branches:
        raise ValueError("the reference tree has no first-level branches")
    if branch_choice not in ("height", "random"):
        raise ValueError(f"branch_choice must be 'height' or 'random', got {branch_choice!r}")
    h_ref = ref.trunk_height
    trunk_h = h_ref if trunk_height is None else _positive(trunk_height, "trunk_height", "m")
    nb = len(ref.branches) if n_branches is None else _count(n_branches, "n_branches", 1)
    heights = ref.heights
    h0 = (
        max(float(heights.min()) * trunk_h / h_ref, 0.0)
        if first_branch_height is None
        else _nonneg(first_branch_height, "first_branch_height", "m")
    )
    ls = _positive(length_scale, "length_scale")
    lsd = _nonneg(length_sd, "length_sd")
    bsd = math.radians(_nonneg(bend_sd_deg, "bend_sd_deg"))
    droop = math.radians(_real(droop_deg, "droop_deg"))
    ssd = _nonneg(slide_sd, "slide_sd", "m")
    b0 = _point3(base, "base")
    extra = dict(lsystem or {})
    for key in ("trunk_height", "n_branches", "first_branch_height", "base", "rng"):
        if key in extra:
            raise ValueError(f"give {key} to grow_tree itself, not in lsystem")
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
    factors = ls * np.exp(lsd * z_len)
    placed = []
    bends = np.zeros((n, 3))
    for i in range(n):
        tpl = ref.branches[int(choice[i])]
        z_slide = gen.standard_normal(tpl.n_units)
        d = branching.directions[i]
        rot = _transport(tpl.chord, d)
        e1 = np.cross(_Z, d)
        if np.linalg.norm(e1) < 1e-9:
            e1 = np.array([0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)  # turning about e1 by a positive angle bends the tip down
        e2 = np.cross(d, e1)
        bend = (droop + bsd * z_bend[i, 0]) * e1 + bsd * z_bend[i, 1] * e2
        bends[i] = bend
        pts, normals, axis = _deform(tpl, rot, float(factors[i]), bend, ssd * z_slide)
        origin = branching.origins[i] - branching.trunk_base
        nv = len(tpl.vertices)
        placed.append(
            _Placed(pts[:nv] + origin, pts[nv:] + origin, normals, int(choice[i]), axis + origin)
        )
    layout = BranchLayout(
        origins=_ro(branching.origins - branching.trunk_base + b0),
        directions=_ro(branching.directions),
        reference_index=_ro(choice, np.int64),
        length_scales=_ro(factors),
        bend_vectors_deg=_ro(np.degrees(bends)),
        axes=tuple(_ro(p.axis + b0) for p in placed),
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
    return _assemble(ref, placed, trunk_h, b0, layout, params)


# --------------------------------------------------------------------------------------------
# the authors' L-system tree
# --------------------------------------------------------------------------------------------


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
    """The authors' ginkgo-like L-system tree (MODEL.md section 7); the defaults are theirs.

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
    ``trunk_radius * width_contraction**level`` m. ``angle_jitter_deg`` (uniform half-width) and
    ``length_jitter`` (relative) randomise the angles and lengths.
    """
    gen = _gen(rng)
    record = _seed_record(rng, gen)
    levels = _count(n_levels, "n_levels", 0)
    c_lat = _positive(contraction, "contraction")
    c_ctr = _positive(centre_contraction, "centre_contraction")
    angle = _real(branching_angle_deg, "branching_angle_deg")
    if not 0 < angle < 180:
        raise ValueError(f"branching_angle_deg must be in (0, 180), got {branching_angle_deg!r}")
    l0 = _positive(initial_length, "initial_length", "m")
    n_nodes = _count(leaf_nodes_per_branch, "leaf_nodes_per_branch", 1)
    per_node = _count(leaves_per_node, "leaves_per_node", 1)
    rmean = _positive(leaf_radius_mean, "leaf_radius_mean", "m")
    rsd = _nonneg(leaf_radius_sd, "leaf_radius_sd", "m")
    rmin = _positive(leaf_radius_min, "leaf_radius_min", "m")
    if rmin >= rmean:
        raise ValueError(f"leaf_radius_min ({rmin}) must be below leaf_radius_mean ({rmean})")
    n_lat = _count(laterals_per_node, "laterals_per_node", 0)
    div = _real(divergence_deg, "divergence_deg")
    ajit = _nonneg(angle_jitter_deg, "angle_jitter_deg")
    ljit = _nonneg(length_jitter, "length_jitter")
    if ljit >= 1:
        raise ValueError(f"length_jitter must be in [0, 1), got {length_jitter!r}")
    petiole = _nonneg(petiole_length, "petiole_length", "m")
    w0 = _positive(trunk_radius, "trunk_radius", "m")
    wc = _positive(width_contraction, "width_contraction")
    sides = _count(bark_sides, "bark_sides", 3)
    b0 = _point3(base, "base")

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
    normals = _unit_rows(normals)
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
        branches=layout,
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
        axes.append(_ro(np.concatenate([seg.starts[top[:1]], seg.ends[top]])))
    return BranchLayout(
        origins=_ro(np.array(origins).reshape(-1, 3)),
        directions=_ro(np.array(dirs).reshape(-1, 3)),
        reference_index=_ro(np.full(n_br, -1), np.int64),
        length_scales=_ro(np.ones(n_br)),
        bend_vectors_deg=_ro(np.zeros((n_br, 3))),
        axes=tuple(axes),
    )


# --------------------------------------------------------------------------------------------
# a user's OBJ tree
# --------------------------------------------------------------------------------------------


def load_tree(
    path: str | os.PathLike,
    leaf_patterns: Sequence[str] | None = None,
    up: str = "z",
    per: str = "patch",
    scale: float = 1.0,
    transform: Any = None,
    trunk_pattern: str = "trunk",
) -> Tree:
    """A tree from an OBJ file as it is (see :func:`~batecho.meshio.load_obj` for the
    arguments). Bark groups whose name contains ``trunk_pattern`` (case-insensitive) are the
    trunk, the other bark groups its first-level branches. A leaf belongs to the branch whose
    name its group's name contains (as in the ``leaves_branch_00`` groups that
    :meth:`Tree.to_obj` writes), else to the branch of its nearest bark vertex (-1 for the
    trunk). The base is the mean of the lowest trunk (or bark) vertices, at their lowest z."""
    mesh = load_obj(
        path, leaf_patterns=leaf_patterns, up=up, per=per, scale=scale, transform=transform
    )
    if mesh.leaves is None:
        raise ValueError(f"{path}: no leaves found (leaf_patterns {leaf_patterns!r})")
    names = list(mesh.group_names)
    fg = mesh.bark_face_groups
    present = [int(g) for g in np.unique(fg)]
    pat = trunk_pattern.lower()
    trunk = [g for g in present if pat and pat in names[g].lower()]
    branch_groups = [g for g in present if g not in trunk]
    bindex = {g: i for i, g in enumerate(branch_groups)}
    leaf_branch = np.full(mesh.n_leaves, -1, np.int64)
    unresolved = np.ones(mesh.n_leaves, bool)
    for lg in np.unique(mesh.leaf_groups):
        hits = [g for g in branch_groups if names[g].lower() in names[lg].lower()]
        sel = mesh.leaf_groups == lg
        if hits:
            leaf_branch[sel] = bindex[max(hits, key=lambda g: len(names[g]))]
            unresolved[sel] = False
        elif pat and pat in names[lg].lower():
            unresolved[sel] = False
    rest = np.flatnonzero(unresolved)
    if len(rest) and branch_groups:
        vgroup = np.full(len(mesh.bark_vertices), -1, np.int64)
        vgroup[mesh.bark_faces.reshape(-1)] = np.repeat(fg, 3)
        near = vgroup[_nearest(mesh.leaves.centers[rest], mesh.bark_vertices)]
        leaf_branch[rest] = np.array([bindex.get(int(g), -1) for g in near], np.int64)
    # bark groups: renumber to the groups present
    remap = np.full(len(names), -1, np.int64)
    remap[present] = np.arange(len(present))
    if len(mesh.bark_vertices):
        tv = (
            mesh.bark_vertices[np.unique(mesh.bark_faces[np.isin(fg, trunk)])]
            if trunk
            else mesh.bark_vertices
        )
        z0, z1 = tv[:, 2].min(), tv[:, 2].max()
        low = tv[tv[:, 2] <= z0 + 0.02 * (z1 - z0) + 1e-9]
        base = np.array([low[:, 0].mean(), low[:, 1].mean(), z0])
    else:
        c = mesh.leaves.centers
        base = np.array([c[:, 0].mean(), c[:, 1].mean(), c[:, 2].min()])
    return Tree(
        leaves=mesh.leaves,
        bark_vertices=mesh.bark_vertices,
        bark_faces=mesh.bark_faces,
        bark_groups=remap[fg] if len(fg) else np.zeros(0, np.int64),
        bark_group_names=tuple(names[g] for g in present) or ("bark",),
        leaf_branch=leaf_branch,
        leaf_cluster=np.full(mesh.n_leaves, -1, np.int64),
        branch_names=tuple(names[g] for g in branch_groups),
        base=base,
        params={
            "scheme": "load_tree",
            "source": str(path),
            "up": up,
            "per": per,
            "scale": float(scale),
        },
    )
