"""Matplotlib figures of trees and forests: :mod:`batecho.outputs.treeplots` under its public
name (``import batecho.treeplots``)."""

from __future__ import annotations

from .outputs.treeplots import plot_forest_3d, plot_forest_map, plot_tree

__all__ = ["plot_forest_3d", "plot_forest_map", "plot_tree"]
