"""Receivers of their own (docs/model.md §5a): a place in the sonar's frame and a receiving
pattern in that frame, and the two ears of :meth:`batecho.Sonar.binaural`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import point3
from .beam import Beam

#: The most receivers one sonar may have (the Rust core's limit).
MAX_RECEIVERS = 64


@dataclass(frozen=True)
class Receiver:
    """A receiver at ``offset_m = (forward, left, up)`` (m) from the emitter, in the sonar's
    frame (x forward, y left, z up), with its own one-way pattern ``beam`` (a :class:`Beam`
    in the sonar's frame: its ``center_deg`` is the direction the receiver faces). ``beam=None``
    hears with the emitter's pattern.

    A ``Receiver()`` sits at the emitter with the emitter's pattern: the monostatic case, with
    a receiver axis in the results.
    """

    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    beam: Beam | None = None

    def __post_init__(self):
        o = point3(self.offset_m, "offset_m")
        if float(np.linalg.norm(o)) > 1e6:
            raise ValueError(f"offset_m {tuple(o)} is farther than 1000 km from the emitter")
        object.__setattr__(self, "offset_m", tuple(float(v) for v in o))
        if self.beam is not None and not isinstance(self.beam, Beam):
            raise TypeError(f"beam must be None or a batecho.Beam, got {type(self.beam).__name__}")

    def _core_tuple(self):
        return (self.offset_m, None if self.beam is None else self.beam._core_tuple())

    @property
    def distance_m(self) -> float:
        """The receiver's distance from the emitter (m)."""
        return math.sqrt(sum(v * v for v in self.offset_m))


def binaural_receivers(
    separation_m: float, ear_yaw_deg: float, ear_pitch_deg: float, beam: Beam
) -> tuple[Receiver, Receiver]:
    """Two ears at ``±separation_m / 2`` along the left axis, each with ``beam``'s shape
    centred on ``(±ear_yaw_deg, ear_pitch_deg)``: turned outward by the yaw. Left ear first."""
    import dataclasses

    half = separation_m / 2.0
    left = Receiver(
        (0.0, half, 0.0), dataclasses.replace(beam, center_deg=(ear_yaw_deg, ear_pitch_deg))
    )
    right = Receiver(
        (0.0, -half, 0.0), dataclasses.replace(beam, center_deg=(-ear_yaw_deg, ear_pitch_deg))
    )
    return left, right


__all__ = ["MAX_RECEIVERS", "Receiver", "binaural_receivers"]
