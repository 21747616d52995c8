"""Shading (docs/model.md §10): what lies between the sonar and a scatterer dims its echo.

A leaf disk crossed by the open segment from the sonar to a scatterer passes ``tau`` of the
sound pressure each way, so ``m`` crossings scale the echo by ``tau^(2m)``; a branch in the way
silences it when ``branches_block``.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._validate import finite_scalar, flag

#: The default one-way amplitude transmission past one leaf (docs/model.md §10): the mean
#: Fresnel-Kirchhoff amplitude on rays that cross an opaque 2.5 cm disk 2 m from the sonar and
#: 0.5 m in front of the scatterer at 70 kHz (0.63), rounded down. The lamina itself passes
#: about 1 % (the mass law), so what reaches past a leaf is what diffraction brings round it.
DEFAULT_LEAF_TRANSMISSION = 0.6


@dataclass(frozen=True)
class Shading:
    """Shading of echoes by the leaves and branches in the way (docs/model.md §10).

    ``leaf_transmission`` (tau, in [0, 1]): the one-way amplitude factor of each leaf disk the
    ray from the sonar to a scatterer crosses; the echo is scaled by ``tau^(2m)`` for ``m``
    crossings. ``branches_block``: a branch cylinder on the ray silences the scatterer.
    ``tau = 1`` with ``branches_block=False`` gives the unshaded echo bit for bit; with
    ``branches_block=True`` the branches still silence what lies behind them.

    Pass it as ``Sonar(shading=Shading())``; the default sonar does not shade (the paper's
    model).
    """

    leaf_transmission: float = DEFAULT_LEAF_TRANSMISSION
    branches_block: bool = True

    def __post_init__(self):
        t = finite_scalar(self.leaf_transmission, "leaf_transmission", strict=True)
        if not 0.0 <= t <= 1.0:
            raise ValueError(f"leaf_transmission must be in [0, 1], got {t!r}")
        object.__setattr__(self, "leaf_transmission", t)
        object.__setattr__(self, "branches_block", flag(self.branches_block, "branches_block"))

    def _core_tuple(self) -> tuple[float, bool]:
        return (self.leaf_transmission, self.branches_block)


__all__ = ["DEFAULT_LEAF_TRANSMISSION", "Shading"]
