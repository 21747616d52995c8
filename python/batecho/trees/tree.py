"""A tree: leaf disks, bark triangles in named groups, its woody skeleton as cylinder segments
and the layout of its first-level branches, with its bounds, its OBJ form and its rigid moves.

Conventions: metres, z up, angles in degrees only in names ending ``_deg``. Trees are built
around their trunk base (``base``, default the origin).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .._geometry import rot_z
from .._pickle import ReadOnlyOnLoading
from .._validate import finite_scalar, flag, frozen, point3, positive_scalar
from ._shape import bounds
from .branches import Branches
from .leaves import Leaves
from .objfile import Mesh, _faces, _vertices, write_obj


@dataclass(frozen=True, eq=False)
class BranchLayout(ReadOnlyOnLoading):
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
            return frozen(base + s * ((x - base) @ rot.T) + t)

        return BranchLayout(
            origins=move(self.origins),
            directions=frozen(self.directions @ rot.T),
            reference_index=self.reference_index,
            length_scales=self.length_scales,
            bend_vectors_deg=frozen(self.bend_vectors_deg @ rot.T),
            axes=tuple(move(a) for a in self.axes),
        )


@dataclass(frozen=True, eq=False)
class Tree(ReadOnlyOnLoading):
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
    layout : BranchLayout or None
        The first-level branching of a grown tree.
    branches : Branches or None
        The woody skeleton (trunk, branches, sub-branches, twigs) as cylinder segments whose
        radii are the bark's: what echoes as wood (docs/model.md §9) and blocks rays
        (§10). None where the tree's wood is unknown (an OBJ tree): then it is silent.
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
    layout: BranchLayout | None = None
    branches: Branches | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.leaves, Leaves):
            raise TypeError(f"leaves must be Leaves, got {type(self.leaves).__name__}")
        n = len(self.leaves)
        bv = _vertices(self.bark_vertices, "bark_vertices")
        bf = _faces(self.bark_faces, len(bv), "bark_faces")
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
        set_(self, "bark_vertices", frozen(bv))
        set_(self, "bark_faces", frozen(bf, np.int64))
        set_(self, "bark_groups", frozen(bg, np.int64))
        set_(self, "bark_group_names", names)
        set_(self, "leaf_branch", frozen(lb, np.int64))
        set_(self, "leaf_cluster", frozen(lc, np.int64))
        set_(self, "branch_names", bnames)
        set_(self, "base", frozen(point3(self.base, "base")))
        set_(self, "params", dict(self.params))
        if self.branches is not None and not isinstance(self.branches, Branches):
            raise TypeError(
                f"branches must be None or batecho.Branches, got {type(self.branches).__name__}"
            )
        if self.layout is not None and not isinstance(self.layout, BranchLayout):
            raise TypeError(
                f"layout must be None or a BranchLayout, got {type(self.layout).__name__}"
            )

    # -- properties ---------------------------------------------------------------------------

    @property
    def n_leaves(self) -> int:
        return len(self.leaves)

    def __len__(self) -> int:
        return len(self.leaves)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box ``(min, max)`` of the bark and the leaf disks, m."""
        return bounds(self.bark_vertices, self.leaves)

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
        wood = "none" if self.branches is None else str(len(self.branches))
        return (
            f"Tree(n_leaves={self.n_leaves}, bark_faces={len(self.bark_faces)}, "
            f"first_level_branches={len(self.branch_names)}, wood_segments={wood}, "
            f"height={self.height:.2f} m)"
        )

    def with_branches(self, branches: Branches | None) -> Tree:
        """This tree with another woody skeleton (in the tree's frame): for an OBJ tree whose
        skeleton you know, or None to silence its wood."""
        return replace(self, branches=branches)

    # -- conversions ----------------------------------------------------------------------------

    def _leaf_groups(self) -> tuple[np.ndarray, list[str]]:
        names = ["leaves"] + [f"leaves_{b}" for b in self.branch_names]
        return self.leaf_branch + 1, names

    def to_mesh(self) -> Mesh:
        """The tree as a :class:`~batecho.trees.objfile.Mesh` (groups: bark groups, then leaf groups
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
        rot = rot_z(finite_scalar(rotation_z_deg, "rotation_z_deg", strict=True))
        scale_leaves = flag(scale_leaves, "scale_leaves")
        t = point3(translation, "translation")
        s = positive_scalar(scale, "scale", strict=True)
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
            layout=None if self.layout is None else self.layout._moved(rot, b, t, s),
            branches=None if self.branches is None else _moved_wood(self.branches, rot, b, t, s),
        )


def _moved_wood(
    wood: Branches, rot: np.ndarray, base: np.ndarray, t: np.ndarray, s: float
) -> Branches:
    """Segments moved as the bark is: ``x -> base + s R (x - base) + t``, radii times ``s``."""
    return Branches._trusted(
        base + s * ((wood.starts - base) @ rot.T) + t,
        base + s * ((wood.ends - base) @ rot.T) + t,
        wood.radii * s,
    )


__all__ = ["BranchLayout", "Tree"]
