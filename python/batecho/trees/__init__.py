"""Trees: leaf disks, branches as cylinder segments, bark meshes read from and written to OBJ
files, L-systems, and trees grown the paper's way or the authors' L-system way."""

from __future__ import annotations

from .branches import Branches
from .branching import Branching, trunk_branching
from .grow import grow_tree
from .leaves import MAX_COORDINATE_M, Leaves, as_leaves
from .load import load_tree
from .lsystem import LSystem
from .lsystem_tree import grow_lsystem_tree
from .objfile import DEFAULT_LEAF_PATTERNS, Mesh, ObjWarning, leaf_cards, load_obj, write_obj
from .reference_tree import REFERENCE_TREE, BranchTemplate, ReferenceTree, load_reference
from .tree import BranchLayout, Tree
from .turtle import Segments, turtle

__all__ = [
    "DEFAULT_LEAF_PATTERNS",
    "MAX_COORDINATE_M",
    "REFERENCE_TREE",
    "BranchLayout",
    "BranchTemplate",
    "Branches",
    "Branching",
    "LSystem",
    "Leaves",
    "Mesh",
    "ObjWarning",
    "ReferenceTree",
    "Segments",
    "Tree",
    "as_leaves",
    "grow_lsystem_tree",
    "grow_tree",
    "leaf_cards",
    "load_obj",
    "load_reference",
    "load_tree",
    "trunk_branching",
    "turtle",
    "write_obj",
]
