"""Where the sonar pulses from: kinematic pulse positions and timed reference trajectories,
from :mod:`batecho.flight.kinematic` and :mod:`batecho.flight.trajectories` under their public
module name (``import batecho.trajectories``)."""

from __future__ import annotations

from .flight.kinematic import circle, figure_eight, line_to
from .flight.trajectories import Circle, Cruise, FigureEight, Hover, Line, Trajectory, Waypoints

__all__ = [
    "Circle",
    "Cruise",
    "FigureEight",
    "Hover",
    "Line",
    "Trajectory",
    "Waypoints",
    "circle",
    "figure_eight",
    "line_to",
]
