"""batecho: the sensory world of an echolocating bat, for bat-inspired quadrotor drones.

Forests of leaves (disks), a bat-like sonar, and the foliage echoes it hears, computed by a
Rust core (BVH main-lobe query, parallel spectra) and checked against a NumPy reference.
Units: metres, seconds, hertz; degrees only in names ending ``_deg``.
"""

from ._core import __version__
from .absorption import Atmosphere
from .echoes import Echoes, lobe_members, simulate
from .leaves import Leaves
from .poses import Poses, look_at
from .scene import Scene
from .sonar import Beam, Sonar, horseshoe_bat_beamwidth_deg

__all__ = [
    "__version__",
    "Atmosphere",
    "Beam",
    "Echoes",
    "Leaves",
    "Poses",
    "Scene",
    "Sonar",
    "horseshoe_bat_beamwidth_deg",
    "lobe_members",
    "look_at",
    "simulate",
]
