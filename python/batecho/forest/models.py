"""Tree models by name (``"grow_tree"``, ``"lsystem"``) and a forest of one model grown at
given ground positions, as the paper's experiments and the scene files ask for them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..trees.grow import grow_tree
from ..trees.lsystem_tree import grow_lsystem_tree
from ..trees.tree import Tree
from .forest import Forest

#: The tree models, by the name a scene file or the command line gives.
TREE_MODELS: dict[str, Callable[..., Tree]] = {
    "grow_tree": grow_tree,
    "lsystem": grow_lsystem_tree,
}


def tree_function(model: str) -> Callable[..., Tree]:
    """The function that grows a tree of ``model``."""
    if model not in TREE_MODELS:
        raise ValueError(f"tree model must be one of {sorted(TREE_MODELS)}, got {model!r}")
    return TREE_MODELS[model]


def make_forest(
    positions: Any,
    rng: np.random.Generator,
    model: str = "grow_tree",
    tree_params: dict | None = None,
    **forest_kw: Any,
) -> Forest:
    """A :class:`~batecho.forest.forest.Forest` with a tree (``model``: ``"grow_tree"`` or
    ``"lsystem"``, with ``tree_params``) grown at each (x, y) of ``positions`` (m);
    ``forest_kw`` go to ``Forest.from_positions`` (``variants``, ``scale_sd``)."""
    return Forest.from_positions(
        positions,
        rng,
        tree=tree_function(model),
        tree_params=dict(tree_params or {}),
        **forest_kw,
    )


__all__ = ["TREE_MODELS", "make_forest", "tree_function"]
