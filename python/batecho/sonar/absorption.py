"""Atmospheric absorption of sound, ISO 9613-1:1993 (pure-tone formula), in NumPy."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import finite_scalar, keep_python_values


def iso9613_alpha_db_per_m(
    freq_hz, temperature_c=20.0, relative_humidity=50.0, pressure_pa=101_325.0
):
    """Absorption coefficient (dB/m) at ``freq_hz`` for the given air, ISO 9613-1 eq. (5)."""
    f = np.asarray(freq_hz, dtype=np.float64)
    T = temperature_c + 273.15
    T0, T01, pr = 293.15, 273.16, 101_325.0
    pa = pressure_pa / pr
    C = -6.8346 * (T01 / T) ** 1.261 + 4.6151
    h = relative_humidity * 10.0**C / pa  # molar concentration of water vapour, %
    frO = pa * (24.0 + 4.04e4 * h * (0.02 + h) / (0.391 + h))
    frN = (
        pa
        * (T / T0) ** -0.5
        * (9.0 + 280.0 * h * np.exp(-4.170 * ((T / T0) ** (-1.0 / 3.0) - 1.0)))
    )
    f2 = f * f
    return (
        8.686
        * f2
        * (
            1.84e-11 / pa * np.sqrt(T / T0)
            + (T / T0) ** -2.5
            * (
                0.01275 * np.exp(-2239.1 / T) / (frO + f2 / frO)
                + 0.1068 * np.exp(-3352.0 / T) / (frN + f2 / frN)
            )
        )
    )


#: The pressures :class:`Atmosphere` takes (Pa), as the core's.
MIN_PRESSURE_PA = 1e3
MAX_PRESSURE_PA = 2e5


@dataclass(frozen=True)
class Atmosphere:
    """Air for ISO 9613-1 absorption: temperature (deg C), relative humidity (%), pressure (Pa)."""

    temperature_c: float = 20.0
    relative_humidity: float = 50.0
    pressure_pa: float = 101_325.0

    def __post_init__(self):
        keep_python_values(self, ("temperature_c", "relative_humidity", "pressure_pa"))
        t = finite_scalar(self.temperature_c, "temperature_c", strict=True)
        if not -100.0 <= t <= 100.0:
            raise ValueError(f"temperature_c must be in [-100, 100], got {t}")
        h = finite_scalar(self.relative_humidity, "relative_humidity", strict=True)
        if not 0.0 <= h <= 100.0:
            raise ValueError(f"relative_humidity must be in [0, 100] %, got {h}")
        p = finite_scalar(self.pressure_pa, "pressure_pa", strict=True)
        if not MIN_PRESSURE_PA <= p <= MAX_PRESSURE_PA:
            raise ValueError(
                f"pressure_pa must be in [{MIN_PRESSURE_PA:g}, {MAX_PRESSURE_PA:g}] Pa (ISO "
                f"9613-1 covers air up to 200 kPa; below 1 kPa is beyond ~50 km), got {p}"
            )

    def alpha_db_per_m(self, freq_hz):
        """Absorption (dB/m, one way) at ``freq_hz``."""
        return iso9613_alpha_db_per_m(
            freq_hz, self.temperature_c, self.relative_humidity, self.pressure_pa
        )


__all__ = ["MAX_PRESSURE_PA", "MIN_PRESSURE_PA", "Atmosphere", "iso9613_alpha_db_per_m"]
