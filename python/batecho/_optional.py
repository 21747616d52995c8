"""Which optional parts of batecho this installation has: the trees and forests that the
paper's experiments, forest scene files and forest datasets need."""

from __future__ import annotations

import importlib
from types import ModuleType

FOREST_MISSING = (
    "the paper's experiments need trees and forests (batecho.trees, batecho.forest), "
    "which this installation of batecho does not have"
)


def forest_modules() -> tuple[ModuleType, ModuleType]:
    """``(batecho.trees, batecho.forest)``, or a RuntimeError saying they are missing."""
    try:
        trees = importlib.import_module("batecho.trees")
        forest = importlib.import_module("batecho.forest")
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise RuntimeError(f"{FOREST_MISSING} ({exc})") from exc
    return trees, forest


def forest_available() -> bool:
    """Whether :mod:`batecho.trees` and :mod:`batecho.forest` can be imported."""
    try:
        forest_modules()
    except RuntimeError:
        return False
    return True


__all__ = ["FOREST_MISSING", "forest_available", "forest_modules"]
