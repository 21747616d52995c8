"""Forests: tree positions from an inhomogeneous Poisson process, trees placed on the ground,
and the scene (leaves and their BVH) that echoes are computed from."""

from __future__ import annotations

from .forest import Forest
from .ipp import (
    PAPER_WINDOW,
    IPPWarning,
    RasterIntensity,
    SquaredExponentialMixture,
    UniformIntensity,
    estimate_lambda_max,
    integrate_intensity,
    paper_intensity,
    sample_ipp,
)
from .scene import Scene, as_scene

__all__ = [
    "PAPER_WINDOW",
    "Forest",
    "IPPWarning",
    "RasterIntensity",
    "Scene",
    "SquaredExponentialMixture",
    "UniformIntensity",
    "as_scene",
    "estimate_lambda_max",
    "integrate_intensity",
    "paper_intensity",
    "sample_ipp",
]
