"""Scene files: a scene, a sonar, a flight and the outputs wanted, described in TOML
(``batecho simulate SCENE.toml``; see ``examples/flight.toml`` and
:mod:`batecho.scenefile.schema` for every key)."""

from __future__ import annotations

from .file import SceneFile
from .flightplan import FlightPlan
from .run import (
    RunResult,
    SimulationSetup,
    check_clearance,
    run_scenefile,
    sample_indices,
    setup_scenefile,
    simulate_options,
    sonar_params,
)
from .schema import PLOTS, ScenefileError

__all__ = [
    "PLOTS",
    "FlightPlan",
    "RunResult",
    "SceneFile",
    "ScenefileError",
    "SimulationSetup",
    "check_clearance",
    "run_scenefile",
    "sample_indices",
    "setup_scenefile",
    "simulate_options",
    "sonar_params",
]
