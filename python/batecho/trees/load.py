"""A user's tree from an OBJ file, as it is: bark groups named like ``trunk`` are the trunk,
the others its first-level branches, and each leaf belongs to the branch it hangs from. Its
wood is silent: a bark mesh says nothing batecho can trust about the cylinders under it."""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from .objfile import ObjWarning, load_obj, no_leaves_reason
from .reference_tree import nearest
from .tree import Tree


def load_tree(
    path: str | os.PathLike,
    leaf_patterns: Sequence[str] | None = None,
    up: str = "z",
    per: str = "patch",
    scale: float = 1.0,
    transform: Any = None,
    trunk_pattern: str = "trunk",
) -> Tree:
    """A tree from an OBJ file as it is (see :func:`~batecho.trees.objfile.load_obj` for the
    arguments). Bark groups whose name contains ``trunk_pattern`` (case-insensitive) are the
    trunk, the other bark groups its first-level branches. A leaf belongs to the branch whose
    name its group's name contains (as in the ``leaves_branch_00`` groups that
    :meth:`Tree.to_obj` writes), else to the branch of its nearest bark vertex (-1 for the
    trunk). The base is the mean of the lowest trunk (or bark) vertices, at their lowest z.
    A file without leaf faces is refused (ValueError): a tree needs leaves.

    The tree has no woody skeleton (``branches`` is None): its bark is drawn and written, but
    its wood does not echo or block (docs/model.md §9). An :class:`ObjWarning` says so when the
    file has bark; give the skeleton, if you know it, with
    ``tree.with_branches(batecho.Branches(starts, ends, radii))``."""
    if not isinstance(trunk_pattern, str):
        raise TypeError(f"trunk_pattern must be a str, got {type(trunk_pattern).__name__}")
    mesh = load_obj(
        path, leaf_patterns=leaf_patterns, up=up, per=per, scale=scale, transform=transform
    )
    if mesh.leaves is None:
        raise ValueError(
            f"{path}: {no_leaves_reason(mesh, leaf_patterns)}, and a tree needs leaves; "
            "read the bark alone with load_obj"
        )
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
        near = vgroup[nearest(mesh.leaves.centers[rest], mesh.bark_vertices)]
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
    if len(mesh.bark_faces):
        warnings.warn(
            f"{path}: the tree's bark is a mesh without a skeleton, so its wood is silent "
            "(it neither echoes nor blocks); give its skeleton with "
            "tree.with_branches(batecho.Branches(starts, ends, radii)) if you know it",
            ObjWarning,
            stacklevel=2,
        )
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


__all__ = ["load_tree"]
