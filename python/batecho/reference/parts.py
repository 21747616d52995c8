"""The parts of a scene as the reference takes them: its leaves and its branches."""

from __future__ import annotations

from typing import Any

from ..forest.scene import Scene
from ..trees.branches import Branches
from ..trees.leaves import Leaves, as_leaves


def _parts(scene: Any) -> tuple[Leaves | None, Branches | None]:
    """The leaves and branches of a Scene, Leaves, or anything with ``.leaves``."""
    if isinstance(scene, Scene):
        return scene.leaves, scene.branches
    return as_leaves(scene), None
