"""The experiments of Tanveer et al., "Recreating Bat Behavior on Quad-rotor UAVs": Figures
5-10 and Table 1 (docs/model.md §7), rerun with batecho.

* :func:`paper_figures` writes PNG figures in the spirit of the paper's Figures 5-10, plus a
  straight run toward a tree and echo images along the circle, and an NPZ with their data.
* :func:`table1` times the impulse computation for a whole circle (altitude 5 m, around the
  mean tree position) with 1, 5, 10, 15 pulse points and T = 1...5 trees, and prints it beside
  the paper's MATLAB figures (:meth:`Table1Result.to_markdown`).

The paper's circle (radius 6.2 m at 5 m) passes through the crowns of its own forests: its
trees are about 8.4 m tall, their crowns reach 3-4 m from the trunk, and two or more trees
from its IPP stand about 5 m from their mean position. Every experiment here keeps each pulse
0.5 m from leaves and bark: a circle keeps the 6.2 m where that clears every crown at 5 m and
otherwise takes the smallest wider radius that does (:func:`paper_circle_radius`).

Trees come from :mod:`batecho.trees` and forests from :mod:`batecho.forest`. Tree positions are
drawn from the paper's inhomogeneous Poisson process (:func:`batecho.paper_intensity` on the
20 m x 20 m :data:`batecho.PAPER_WINDOW`) *conditioned on the number of trees*
(:func:`draw_tree_positions`). Units: metres, seconds; degrees only in names ending ``_deg``.
"""

from __future__ import annotations

from ..forest.ipp import draw_tree_positions
from ..forest.models import make_forest
from .figures import paper_figures
from .settings import (
    PAPER_ALTITUDE_M,
    PAPER_BEAMWIDTHS_DEG,
    PAPER_CLEARANCE_M,
    PAPER_MACHINE,
    PAPER_POINTS,
    PAPER_RADIUS_M,
    PAPER_TABLE1,
    PAPER_TREES,
    TABLE1_BEAMWIDTH_DEG,
    machine_info,
    paper_circle_radius,
)
from .settings import tree_settings as tree_settings
from .table1 import Table1Result, table1

__all__ = [
    "PAPER_ALTITUDE_M",
    "PAPER_BEAMWIDTHS_DEG",
    "PAPER_CLEARANCE_M",
    "PAPER_MACHINE",
    "PAPER_POINTS",
    "PAPER_RADIUS_M",
    "PAPER_TABLE1",
    "PAPER_TREES",
    "TABLE1_BEAMWIDTH_DEG",
    "Table1Result",
    "draw_tree_positions",
    "machine_info",
    "make_forest",
    "paper_circle_radius",
    "paper_figures",
    "table1",
]
