"""Flights: sonar poses, kinematic pulse positions, timed reference trajectories, and a
quadrotor with its SE(3) controller and sonar mount that flies them."""

from __future__ import annotations

from .controller import SE3Gains
from .kinematic import circle, figure_eight, line_to
from .mount import SonarMount
from .poses import Poses, look_at
from .record import Flight
from .sim import QuadrotorSim, SwarmState
from .trajectories import Circle, Cruise, FigureEight, Hover, Line, Trajectory, Waypoints
from .vehicle import GRAVITY, Gusts, Quadrotor, QuadState

__all__ = [
    "GRAVITY",
    "Circle",
    "Cruise",
    "FigureEight",
    "Flight",
    "Gusts",
    "Hover",
    "Line",
    "Poses",
    "QuadState",
    "Quadrotor",
    "QuadrotorSim",
    "SE3Gains",
    "SonarMount",
    "SwarmState",
    "Trajectory",
    "Waypoints",
    "circle",
    "figure_eight",
    "line_to",
    "look_at",
]
