"""The NumPy reference: docs/model.md written out for clarity, not speed.

Plain NumPy and SciPy, a brute-force lobe test (no BVH, no Rust). ``simulate`` and
``lobe_members`` have the same signatures and results as ``batecho.simulate`` and
``batecho.lobe_members``, receivers at their own places included; the property tests hold the
Rust core to this package. One module a part of the model, in the order of the data:

- ``lobe``: the beampattern, angles and lobe rule (§1-§3)
- ``leaves``: the frequency grid, leaf scattering and the leaves' spectrum (§4-§5)
- ``receivers``: receivers at their own places (§5a)
- ``branches``: branch pieces and their spectrum (§9)
- ``shading``: leaf crossings, blocking branches, ``leaf_sights`` (§10)
- ``echoes``: ``simulate`` and ``lobe_members``
- ``distances``: distances to leaves and branches, ``clearance`` (§6)
- ``parts``: a scene's leaves and branches

Where the Rust core's result hangs on the last bit (the lobe test's threshold, clearance),
the reference computes in the core's order of operations, and the lobe test with the C
library's ``atan2`` and ``exp`` as the core does (``lobe``).
"""

from __future__ import annotations

from .distances import clearance, point_cylinder_distance, point_disk_distance
from .echoes import lobe_members, simulate
from .leaves import _leaf_paper as _leaf_paper  # (the leaf fit, for tests of it alone)
from .lobe import _view as _view  # (the view of points, for tests of the lobe alone)
from .shading import leaf_sights

__all__ = [
    "clearance",
    "leaf_sights",
    "lobe_members",
    "point_cylinder_distance",
    "point_disk_distance",
    "simulate",
]
