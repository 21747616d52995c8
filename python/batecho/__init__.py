"""batecho: the sensory world of an echolocating bat, for bat-inspired quadrotor drones.

Forests of leaves (disks), a bat-like sonar, and the foliage echoes it hears, computed by a
Rust core (BVH main-lobe query, parallel spectra) and checked against a NumPy reference
(:mod:`batecho.reference`). Units: metres, seconds, hertz; degrees only in names ending ``_deg``.

``import batecho`` loads NumPy and the Rust core only. The modules ``paper``, ``plotting``,
``scenefile``, ``trajectories``, ``treeplots`` and ``reference`` (and the names taken from
them) load on first use, and with them matplotlib or SciPy where they need it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._core import __version__
from ._resources import memory_limit, set_memory_limit
from .echoes.received import CallBandWarning
from .echoes.simulate import Echoes, LeafSights, leaf_sights, lobe_members, simulate
from .flight.kinematic import circle, figure_eight, line_to
from .flight.mount import SonarMount
from .flight.poses import Poses, look_at
from .flight.record import Flight
from .flight.vehicle import Quadrotor
from .forest.clearance import DEFAULT_MIN_CLEARANCE_M, ClearanceWarning
from .forest.forest import Forest
from .forest.ipp import (
    PAPER_WINDOW,
    IPPWarning,
    RasterIntensity,
    SquaredExponentialMixture,
    UniformIntensity,
    integrate_intensity,
    paper_intensity,
    sample_ipp,
)
from .forest.scene import Scene
from .sonar.absorption import Atmosphere
from .sonar.beam import Beam, horseshoe_bat_beamwidth_deg
from .sonar.call import Call
from .sonar.receivers import Receiver
from .sonar.shading import Shading
from .sonar.sonar import Sonar
from .trees.branches import Branches
from .trees.branching import Branching, trunk_branching
from .trees.grow import grow_tree
from .trees.leaves import Leaves
from .trees.load import load_tree
from .trees.lsystem import LSystem
from .trees.lsystem_tree import grow_lsystem_tree
from .trees.objfile import Mesh, ObjWarning, load_obj, write_obj
from .trees.reference_tree import REFERENCE_TREE, ReferenceTree, load_reference
from .trees.tree import BranchLayout, Tree
from .trees.turtle import Segments, turtle

if TYPE_CHECKING:
    from . import paper, plotting, scenefile, trajectories, treeplots
    from . import reference as reference
    from .scenefile import SceneFile, ScenefileError, run_scenefile

#: Submodules loaded on first use: name -> module.
_LAZY_MODULES = {
    "paper": ".paper",
    "plotting": ".plotting",
    "reference": ".reference",
    "scenefile": ".scenefile",
    "trajectories": ".trajectories",
    "treeplots": ".treeplots",
}
#: Names loaded on first use: name -> the module that defines them.
_LAZY_NAMES = {
    "SceneFile": ".scenefile",
    "ScenefileError": ".scenefile",
    "run_scenefile": ".scenefile",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY_MODULES:
        return importlib.import_module(_LAZY_MODULES[name], __name__)
    if name in _LAZY_NAMES:
        value = getattr(importlib.import_module(_LAZY_NAMES[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY_MODULES) | set(_LAZY_NAMES))


__all__ = [
    "DEFAULT_MIN_CLEARANCE_M",
    "PAPER_WINDOW",
    "REFERENCE_TREE",
    "Atmosphere",
    "Beam",
    "BranchLayout",
    "Branches",
    "Branching",
    "Call",
    "CallBandWarning",
    "ClearanceWarning",
    "Echoes",
    "Flight",
    "Forest",
    "IPPWarning",
    "LSystem",
    "LeafSights",
    "Leaves",
    "Mesh",
    "ObjWarning",
    "Poses",
    "Quadrotor",
    "RasterIntensity",
    "Receiver",
    "ReferenceTree",
    "Scene",
    "SceneFile",
    "ScenefileError",
    "Segments",
    "Shading",
    "Sonar",
    "SonarMount",
    "SquaredExponentialMixture",
    "Tree",
    "UniformIntensity",
    "__version__",
    "circle",
    "figure_eight",
    "grow_lsystem_tree",
    "grow_tree",
    "horseshoe_bat_beamwidth_deg",
    "integrate_intensity",
    "leaf_sights",
    "line_to",
    "load_obj",
    "load_reference",
    "load_tree",
    "lobe_members",
    "look_at",
    "memory_limit",
    "paper",
    "paper_intensity",
    "plotting",
    "run_scenefile",
    "sample_ipp",
    "scenefile",
    "set_memory_limit",
    "simulate",
    "trajectories",
    "treeplots",
    "trunk_branching",
    "turtle",
    "write_obj",
]
