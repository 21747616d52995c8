"""The experiments of Tanveer et al., "Recreating Bat Behavior on Quad-rotor UAVs": Figures
5-10 and Table 1 (docs/model.md §7), rerun with batecho.

* :func:`paper_figures` writes PNG figures in the spirit of the paper's Figures 5-10, plus a
  straight run toward a tree and echo images along the circle, and an NPZ with their data.
* :func:`table1` times the impulse computation for a whole circle (radius 6.2 m, altitude 5 m,
  around the mean tree position) with 1, 5, 10, 15 pulse points and T = 1...5 trees, and
  prints it beside the paper's MATLAB figures (:meth:`Table1Result.to_markdown`).

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
    PAPER_MACHINE,
    PAPER_POINTS,
    PAPER_RADIUS_M,
    PAPER_TABLE1,
    PAPER_TREES,
    TABLE1_BEAMWIDTH_DEG,
    machine_info,
)
from .settings import tree_settings as tree_settings
from .table1 import Table1Result, table1

__all__ = [
    "PAPER_ALTITUDE_M",
    "PAPER_BEAMWIDTHS_DEG",
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
    "paper_figures",
    "table1",
]
