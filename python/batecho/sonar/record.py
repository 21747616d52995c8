"""A sonar's parameters as plain data (JSON-able, and a valid ``[sonar]`` table of a scene
file): what the exports and the scene files record of it."""

from __future__ import annotations

import dataclasses
from typing import Any

from .beam import Beam
from .sonar import Sonar

__all__ = ["sonar_params"]


def _plain(v: Any) -> Any:
    """A Beam, Atmosphere or Receiver as a table of its set fields; tuples as lists."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {
            g.name: _plain(getattr(v, g.name))
            for g in dataclasses.fields(v)
            if getattr(v, g.name) is not None and not g.name.startswith("_")
        }
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def sonar_params(sonar: Sonar) -> dict[str, Any]:
    """A :class:`batecho.Sonar`'s parameters as a dict that is also a valid ``[sonar]`` table
    (None values left out; ``beam``/``receiver``/``absorption`` as sub-tables, ``receivers``
    as an array of tables)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(sonar):
        if f.name.startswith("_"):
            continue
        v = getattr(sonar, f.name)
        if v is None:
            continue
        out[f.name] = _plain(v)
    if sonar.beam is not None and sonar.beam.beamwidth_deg is not None:
        defaults = Beam(beamwidth_deg=sonar.beam.beamwidth_deg)
        if sonar.beam == defaults:
            out.pop("beam")
            out["beamwidth_deg"] = sonar.beam.beamwidth_deg
    return out
