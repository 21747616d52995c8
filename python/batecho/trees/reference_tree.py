"""Reference trees: a tree split into its trunk and first-level branch templates, read from
an OBJ file and its JSON structure sidecar, or derived from the OBJ's groups; and a tree
assembled from a trunk and branches placed around it.

**The reference tree.** ``data/reference_tree.obj`` (made by ``tools/make_reference_tree.py``)
has a bark group ``trunk``, one bark group per first-level branch (``branch_00`` ... : the bark
of the branch's axis, its sub-branches and their twigs) and one leaf group per branch
(``leaves_branch_00`` ...). The sidecar ``reference_tree.json`` describes each branch's structure:
its *axis* polyline (starting on the trunk axis), how many of the group's bark triangles belong
to the axis tube, and the sub-branch *units* (a sub-branch with its twigs and leaves) with their
anchors, arc lengths along the axis, and the woody skeleton: every bark tube's axis with the
bark's radius along it, which a grown tree keeps as its :class:`~batecho.Branches`. For an OBJ
without such a sidecar the structure is derived
(:func:`load_reference`): bark groups whose name contains ``trunk`` are the trunk, every other
bark group is a first-level branch whose axis is the straight line from the trunk axis to the
branch's farthest point, and the connected pieces of its bark (with the leaves nearest to them)
are its units; such a reference has no skeleton, and trees grown from it have silent wood.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._pickle import ReadOnlyOnLoading
from .._validate import frozen, point3
from ._shape import arc_lengths, dedupe_polyline, point_at, project
from .branches import Branches
from .leaves import Leaves
from .objfile import Mesh, load_obj
from .tree import BranchLayout, Tree

#: The shipped reference tree (Wavefront OBJ; ``reference_tree.mtl`` and the structure sidecar
#: ``reference_tree.json`` lie beside it).
REFERENCE_TREE: Path = Path(__file__).resolve().parents[1] / "data" / "reference_tree.obj"

_JSON_FORMAT = "batecho-reference-tree"


@dataclass(frozen=True, eq=False)
class BranchTemplate(ReadOnlyOnLoading):
    """One first-level branch of a reference tree, ready to be transported and randomised.

    Everything in the reference's frame (m). ``axis`` (m, 3) polyline from ``base`` (on the
    trunk axis) with arc lengths ``arc``; ``chord`` the unit vector from base to tip. Points
    (bark vertices, then leaf centres) hang on the axis: ``unit`` -1 for the axis itself (the
    point rides on the axis at its own arc length ``anchor``), else the sub-branch unit, which
    hangs rigidly at ``unit_anchors[unit]``; ``offset`` is the point minus its anchor point.

    The woody skeleton (empty when the reference has none): ``skeleton_points`` (q, 3) hang on
    the axis like the bark's vertices (``skeleton_unit``), and ``skeleton_segments`` (s, 2)
    join pairs of them into cylinders of ``skeleton_radii`` (s,), the bark's mean radius along
    each.
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
    skeleton_points: np.ndarray
    skeleton_unit: np.ndarray
    skeleton_segments: np.ndarray
    skeleton_radii: np.ndarray

    @property
    def length(self) -> float:
        """Arc length of the axis, m."""
        return float(self.arc[-1])

    @property
    def n_units(self) -> int:
        return len(self.unit_anchors)

    @functools.cached_property
    def _hang(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(anchor arc length, unit, offset) of every point: vertices, skeleton points, then
        leaf centres."""
        pts = np.concatenate([self.vertices, self.skeleton_points, self.leaf_centers])
        unit = np.concatenate([self.vertex_unit, self.skeleton_unit, self.leaf_unit])
        anchor = np.empty(len(pts))
        on_axis = unit < 0
        anchor[on_axis] = project(pts[on_axis], self.axis, self.arc)
        anchor[~on_axis] = self.unit_anchors[unit[~on_axis]]
        offset = pts - point_at(self.axis, self.arc, anchor)
        return anchor, unit, offset


@dataclass(frozen=True, eq=False)
class ReferenceTree(ReadOnlyOnLoading):
    """A reference tree split into trunk and first-level branch templates (see
    :func:`load_reference`). ``structure`` is ``"json"`` (from the sidecar) or ``"derived"``.
    ``trunk_skeleton`` (p, 4): the trunk tube's axis points and bark radii, rows
    ``[x, y, z, r]`` (empty without a skeleton)."""

    mesh: Mesh
    trunk_base: np.ndarray
    trunk_top: np.ndarray
    trunk_vertices: np.ndarray
    trunk_faces: np.ndarray
    trunk_leaves: Leaves | None
    branches: tuple[BranchTemplate, ...]
    structure: str
    source: Path | None = None
    trunk_skeleton: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    @property
    def has_skeleton(self) -> bool:
        """Whether the reference knows its woody skeleton (then grown trees have branches)."""
        return len(self.trunk_skeleton) > 0 or any(len(b.skeleton_radii) for b in self.branches)

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
        return assemble(
            self,
            [self._placed(k) for k in range(len(self.branches))],
            trunk_height=self.trunk_height,
            base=np.zeros(3),
            layout=None,
            params={"reference": str(self.source) if self.source else None, "grown": False},
        )

    def _placed(self, k: int) -> Placed:
        b = self.branches[k]
        pts = np.concatenate([b.vertices, b.skeleton_points, b.leaf_centers]) - self.trunk_base
        nv, ns = len(b.vertices), len(b.skeleton_points)
        return Placed(
            pts[:nv], pts[nv + ns :], b.leaf_normals, k, b.axis - self.trunk_base, pts[nv : nv + ns]
        )


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
    and options, then cached) or a loaded :class:`~batecho.trees.objfile.Mesh` (derived anew each
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
    t_base = point3(trunk["base"], "trunk base")
    t_top = point3(trunk["top"], "trunk top")
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
        axis = dedupe_polyline(np.array(b["axis"], dtype=np.float64))
        tubes = [(-1, b["axis_tube"])] if "axis_tube" in b else []
        for u, unit_tubes in enumerate(b.get("subbranch_tubes", [])):
            tubes += [(u, t) for t in unit_tubes]
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
                _skeleton(tubes, path),
            )
        )
    t_faces = mesh.bark_faces[~used_faces]
    tv, tl = np.unique(t_faces, return_inverse=True)
    rest = np.flatnonzero(~used_leaves)
    return ReferenceTree(
        mesh=mesh,
        trunk_base=frozen(t_base),
        trunk_top=frozen(t_top),
        trunk_vertices=frozen(mesh.bark_vertices[tv]),
        trunk_faces=frozen(tl.reshape(-1, 3), np.int64),
        trunk_leaves=mesh.leaves[rest] if len(rest) else None,
        branches=tuple(branches),
        structure="json",
        source=path,
        trunk_skeleton=frozen(_rows4(trunk.get("tube", []), path)),
    )


def _rows4(rows: Any, path: Path) -> np.ndarray:
    """A tube's rows ``[x, y, z, r]`` as a (p, 4) array, checked."""
    a = np.asarray(rows, dtype=np.float64).reshape(-1, 4) if len(rows) else np.zeros((0, 4))
    if len(a) == 1 or not np.isfinite(a).all() or (a[:, 3] <= 0).any():
        raise ValueError(
            f"{path}: a skeleton tube in the JSON sidecar needs two or more rows [x, y, z, r] "
            "with finite coordinates and radii > 0; regenerate it with tools/make_reference_tree.py"
        )
    return a


_Skeleton = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _skeleton(tubes: list[tuple[int, Any]], path: Path) -> _Skeleton:
    """(points, unit of each point, segments, radii) of a branch's tubes ``(unit, rows)``: each
    tube's consecutive points joined, a segment's radius the mean of its ends'."""
    pts, units, segs, radii = [np.zeros((0, 3))], [np.zeros(0, np.int64)], [], []
    n = 0
    for u, rows in tubes:
        a = _rows4(rows, path)
        if not len(a):
            continue
        pts.append(a[:, :3])
        units.append(np.full(len(a), u, np.int64))
        k = np.arange(len(a) - 1)
        segs.append(np.column_stack([k, k + 1]) + n)
        radii.append(0.5 * (a[:-1, 3] + a[1:, 3]))
        n += len(a)
    return (
        np.concatenate(pts),
        np.concatenate(units),
        np.concatenate(segs) if segs else np.zeros((0, 2), np.int64),
        np.concatenate(radii) if radii else np.zeros(0),
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
    skeleton: _Skeleton | None = None,
) -> BranchTemplate:
    arc = arc_lengths(axis)
    chord = axis[-1] - axis[0]
    if np.linalg.norm(chord) < 1e-9:
        raise ValueError(f"branch {name!r}: its axis starts and ends at the same point")
    if leaves is None:
        lc, ln, lr = np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    else:
        lc, ln, lr = leaves.centers, leaves.normals, leaves.radii
    if skeleton is None:
        skeleton = (
            np.zeros((0, 3)),
            np.zeros(0, np.int64),
            np.zeros((0, 2), np.int64),
            np.zeros(0),
        )
    sp, su, ss, sr = skeleton
    return BranchTemplate(
        name=name,
        base=frozen(axis[0]),
        axis=frozen(axis),
        arc=frozen(arc),
        chord=frozen(chord / np.linalg.norm(chord)),
        height=float(axis[0, 2] - trunk_base[2]),
        vertices=frozen(vertices),
        faces=frozen(faces, np.int64),
        vertex_unit=frozen(vertex_unit, np.int64),
        leaf_centers=frozen(lc),
        leaf_normals=frozen(ln),
        leaf_radii=frozen(lr),
        leaf_unit=frozen(leaf_unit, np.int64),
        unit_anchors=frozen(np.clip(anchors, 0.0, arc[-1])),
        skeleton_points=frozen(sp),
        skeleton_unit=frozen(su, np.int64),
        skeleton_segments=frozen(ss, np.int64),
        skeleton_radii=frozen(sr),
    )


def nearest(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
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
        near = used[nearest(leaves.centers[rest], mesh.bark_vertices[used])]
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
        arc = arc_lengths(axis)
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
            s = project(verts, axis, arc)
            d = np.linalg.norm(verts - point_at(axis, arc, s), axis=1)
            for j, c in enumerate(others):
                m = np.flatnonzero(comp == c)
                anchors[j] = s[m[np.argmin(d[m])]]
        lunit = vunit[nearest(leaves.centers[lid], verts)] if len(lid) else np.zeros(0, int)
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
        trunk_base=frozen(t_base),
        trunk_top=frozen(t_top),
        trunk_vertices=frozen(mesh.bark_vertices[tv]),
        trunk_faces=frozen(tl.reshape(-1, 3), np.int64),
        trunk_leaves=leaves[rest] if len(rest) else None,
        branches=tuple(branches[i] for i in order),
        structure="derived",
        source=mesh.source,
    )


@dataclass
class Placed:
    """One branch in place, relative to the new trunk base: bark vertices, leaf centres and
    normals, the template index, the final axis and the skeleton's points."""

    vertices: np.ndarray
    leaf_centers: np.ndarray
    leaf_normals: np.ndarray
    template: int
    axis: np.ndarray
    skeleton: np.ndarray


def assemble(
    ref: ReferenceTree,
    placed: list[Placed],
    trunk_height: float,
    base: np.ndarray,
    layout: BranchLayout | None,
    params: dict[str, Any],
) -> Tree:
    """Trunk (stretched to ``trunk_height``) plus the placed branches, at ``base``; with the
    reference's skeleton, the tree's :class:`~batecho.Branches` (the trunk's stretched like its
    bark, the branches' from their placed points; the radii kept)."""
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
    wood = _assembled_skeleton(ref, placed, zs, base)
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
        layout=layout,
        branches=wood,
    )


def _assembled_skeleton(
    ref: ReferenceTree, placed: list[Placed], zs: float, base: np.ndarray
) -> Branches | None:
    """The tree's skeleton from the reference's trunk (stretched by ``zs``) and the placed
    branches' skeleton points, at ``base``; None without a skeleton."""
    if not ref.has_skeleton:
        return None
    starts, ends, radii = [], [], []
    t = ref.trunk_skeleton
    if len(t):
        pts = (t[:, :3] - ref.trunk_base) * np.array([1.0, 1.0, zs]) + base
        starts.append(pts[:-1])
        ends.append(pts[1:])
        radii.append(0.5 * (t[:-1, 3] + t[1:, 3]))
    for p in placed:
        tpl = ref.branches[p.template]
        seg = tpl.skeleton_segments
        if len(seg):
            pts = p.skeleton + base
            starts.append(pts[seg[:, 0]])
            ends.append(pts[seg[:, 1]])
            radii.append(tpl.skeleton_radii)
    s, e = np.concatenate(starts), np.concatenate(ends)
    keep = np.einsum("ij,ij->i", e - s, e - s) > 0.0
    return Branches(s[keep], e[keep], np.concatenate(radii)[keep])


__all__ = [
    "REFERENCE_TREE",
    "BranchTemplate",
    "Placed",
    "ReferenceTree",
    "assemble",
    "load_reference",
    "nearest",
]
