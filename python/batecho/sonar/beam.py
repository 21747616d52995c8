"""Beampatterns: a one-way Gaussian beam with its -3 dB width, sigmas, rotation and centre
(docs/model.md §2), and the horseshoe bat's beamwidth against frequency."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import finite_scalar, keep_python_values, positive_scalar, real_array

__all__ = [
    "HALF_POWER_AMPLITUDE",
    "MIN_SIGMA_RAD",
    "Beam",
    "horseshoe_bat_beamwidth_deg",
    "sigma_from_beamwidth_deg",
]

#: The narrowest Gaussian width sigma (rad) of a beam, as the core's ``MIN_SIGMA``.
MIN_SIGMA_RAD = 1e-8

#: The one-way pattern is at -3 dB (amplitude 0.7079) at half the beamwidth.
HALF_POWER_AMPLITUDE = 0.7079


def sigma_from_beamwidth_deg(beamwidth_deg: float) -> float:
    """Gaussian width sigma (radians) of a full -3 dB one-way beamwidth (degrees)."""
    return (math.radians(beamwidth_deg) / 2.0) / math.sqrt(2.0 * -math.log(HALF_POWER_AMPLITUDE))


def horseshoe_bat_beamwidth_deg(f_khz: float) -> float:
    """Beamwidth (deg) of the horseshoe bat at ``f_khz`` kHz, the fit of Ming et al. (2017)."""
    f = float(f_khz)
    return 0.011333 * f * f * f - 2.3219 * f * f + 156.15 * f - 3402.7


@dataclass(frozen=True)
class Beam:
    """A one-way Gaussian beampattern ``S = A1 exp(-(a daz^2 + 2b daz del + c del^2))``.

    Give either ``beamwidth_deg`` (full -3 dB width, circular beam) or ``sigma_deg`` (one value,
    or ``(sigma_az, sigma_el)`` for an elliptical beam). ``rotation_deg`` rotates the ellipse,
    ``center_deg = (az0, el0)`` moves its centre, ``amplitude`` is A1.
    """

    beamwidth_deg: float | None = None
    sigma_deg: float | tuple[float, float] | None = None
    rotation_deg: float = 0.0
    center_deg: tuple[float, float] = (0.0, 0.0)
    amplitude: float = 1.0

    def __post_init__(self):
        keep_python_values(
            self, ("beamwidth_deg", "sigma_deg", "rotation_deg", "center_deg", "amplitude")
        )
        if self.beamwidth_deg is not None and self.sigma_deg is not None:
            raise ValueError("give beamwidth_deg or sigma_deg, not both")
        if self.beamwidth_deg is None and self.sigma_deg is None:
            raise ValueError("a Beam needs beamwidth_deg or sigma_deg")
        if self.beamwidth_deg is not None:
            bw = finite_scalar(self.beamwidth_deg, "beamwidth_deg", strict=True)
            if not 0.0 < bw < 180.0:
                raise ValueError(f"beamwidth_deg must be in (0, 180), got {bw}")
        else:
            s = np.atleast_1d(real_array(self.sigma_deg, "sigma_deg"))
            if s.shape not in ((1,), (2,)) or not np.all(np.isfinite(s)) or np.any(s <= 0):
                raise ValueError(
                    f"sigma_deg must be one or two finite values > 0, got {self.sigma_deg}"
                )
        narrow = min(self.sigmas_rad)
        if narrow < MIN_SIGMA_RAD:
            given = "beamwidth_deg" if self.beamwidth_deg is not None else "sigma_deg"
            raise ValueError(
                f"{given} = {getattr(self, given)!r} gives a Gaussian width of {narrow:.3g} rad, "
                f"below the narrowest beam, {MIN_SIGMA_RAD:g} rad (its exponent overflows)"
            )
        finite_scalar(self.rotation_deg, "rotation_deg", strict=True)
        try:
            az0, el0 = (finite_scalar(v, "center_deg", strict=True) for v in self.center_deg)
        except (TypeError, ValueError) as exc:
            if "center_deg" in str(exc):
                raise
            raise TypeError(
                f"center_deg must be (az0, el0) in degrees, got {self.center_deg!r}"
            ) from None
        if abs(az0) > 180 or abs(el0) > 90:
            raise ValueError(
                f"center_deg must have |az| <= 180 and |el| <= 90, got {self.center_deg}"
            )
        positive_scalar(self.amplitude, "amplitude", strict=True)

    @property
    def sigmas_rad(self) -> tuple[float, float]:
        """(sigma_x, sigma_y) in radians: widths along azimuth and elevation before rotation."""
        if self.beamwidth_deg is not None:
            s = sigma_from_beamwidth_deg(self.beamwidth_deg)
            return s, s
        sig = np.atleast_1d(np.asarray(self.sigma_deg, dtype=np.float64))
        sx = math.radians(float(sig[0]))
        sy = math.radians(float(sig[-1]))
        return sx, sy

    def _core_tuple(self):
        sx, sy = self.sigmas_rad
        return (
            float(self.amplitude),
            sx,
            sy,
            math.radians(self.rotation_deg),
            math.radians(self.center_deg[0]),
            math.radians(self.center_deg[1]),
        )

    def gain(self, az_rad, el_rad):
        """One-way gain at azimuth/elevation (radians), NumPy."""
        amp, sx, sy, th, az0, el0 = self._core_tuple()
        a = math.cos(th) ** 2 / (2 * sx * sx) + math.sin(th) ** 2 / (2 * sy * sy)
        b = -math.sin(2 * th) / (4 * sx * sx) + math.sin(2 * th) / (4 * sy * sy)
        c = math.sin(th) ** 2 / (2 * sx * sx) + math.cos(th) ** 2 / (2 * sy * sy)
        daz = np.asarray(az_rad) - az0
        daz = np.where(daz > np.pi, daz - 2 * np.pi, daz)
        daz = np.where(daz < -np.pi, daz + 2 * np.pi, daz)
        dl = np.asarray(el_rad) - el0
        return amp * np.exp(-(a * daz * daz + 2.0 * b * daz * dl + c * dl * dl))
