"""The sonar: beampatterns, the lobe rule, the frequency grid, the leaf model's parameters and
atmospheric absorption, receivers of their own, the emitted call."""

from __future__ import annotations

from .absorption import Atmosphere, iso9613_alpha_db_per_m
from .beam import Beam, horseshoe_bat_beamwidth_deg, sigma_from_beamwidth_deg
from .call import Call
from .receivers import Receiver
from .sonar import DEFAULT_BEAMWIDTH_DEG, Sonar

__all__ = [
    "DEFAULT_BEAMWIDTH_DEG",
    "Atmosphere",
    "Beam",
    "Call",
    "Receiver",
    "Sonar",
    "horseshoe_bat_beamwidth_deg",
    "iso9613_alpha_db_per_m",
    "sigma_from_beamwidth_deg",
]
