"""batecho: the sensory world of an echolocating bat, for bat-inspired quadrotor drones.

Forests of leaves (disks), a bat-like sonar, and the foliage echoes it hears, computed by a
Rust core (BVH main-lobe query, parallel spectra) and checked against a NumPy reference
(:mod:`batecho.reference`). Units: metres, seconds, hertz; degrees only in names ending ``_deg``.
"""

from . import paper, plotting, scenefile, trajectories, treeplots
from ._core import __version__
from .absorption import Atmosphere
from .echoes import Echoes, lobe_members, simulate
from .forest import Forest
from .ipp import (
    PAPER_WINDOW,
    IPPWarning,
    RasterIntensity,
    SquaredExponentialMixture,
    integrate_intensity,
    paper_intensity,
    sample_ipp,
)
from .leaves import Leaves
from .lsystem import Branching, LSystem, Segments, trunk_branching, turtle
from .meshio import Mesh, ObjWarning, load_obj, write_obj
from .poses import Poses, look_at
from .quadrotor import Flight, Quadrotor, SonarMount
from .scene import Scene
from .scenefile import SceneFile, ScenefileError, run_scenefile
from .sonar import Beam, Sonar, horseshoe_bat_beamwidth_deg
from .trajectories import circle, figure_eight, line_to
from .trees import (
    REFERENCE_TREE,
    BranchLayout,
    ReferenceTree,
    Tree,
    grow_lsystem_tree,
    grow_tree,
    load_reference,
    load_tree,
)

__all__ = [
    "PAPER_WINDOW",
    "REFERENCE_TREE",
    "Atmosphere",
    "Beam",
    "BranchLayout",
    "Branching",
    "Echoes",
    "Flight",
    "Forest",
    "IPPWarning",
    "LSystem",
    "Leaves",
    "Mesh",
    "ObjWarning",
    "Poses",
    "Quadrotor",
    "RasterIntensity",
    "ReferenceTree",
    "Scene",
    "SceneFile",
    "ScenefileError",
    "Segments",
    "Sonar",
    "SonarMount",
    "SquaredExponentialMixture",
    "Tree",
    "__version__",
    "circle",
    "figure_eight",
    "grow_lsystem_tree",
    "grow_tree",
    "horseshoe_bat_beamwidth_deg",
    "integrate_intensity",
    "line_to",
    "load_obj",
    "load_reference",
    "load_tree",
    "lobe_members",
    "look_at",
    "paper",
    "paper_intensity",
    "plotting",
    "run_scenefile",
    "sample_ipp",
    "scenefile",
    "simulate",
    "trajectories",
    "treeplots",
    "trunk_branching",
    "turtle",
    "write_obj",
]
