"""A recorded flight: the vehicle's states at the recorded times, the reference they tracked
and the wind, with the body states and sonar poses at any pulse times within it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .._pickle import ReadOnlyOnLoading
from .._resources import BYTES_PER_POSE, check_memory
from .._validate import finite, finite_scalar, flag, positive_scalar, readonly, real_array
from .mount import SonarMount
from .poses import Poses
from .trajectories import Trajectory

__all__ = ["Flight"]


class Flight(ReadOnlyOnLoading):
    """A recorded flight: the states at ``times`` (k,) s and the reference they tracked.

    Arrays (read-only): ``positions``, ``velocities`` (k, 3) world; ``attitudes`` (k, 3, 3)
    body -> world; ``angular_velocities`` (k, 3) body rad/s; ``rotor_speeds`` (k, 4) rad/s;
    ``thrust`` (k,) N; ``reference_positions``, ``reference_velocities`` (k, 3);
    ``reference_yaw`` (k,) rad; ``wind`` (k, 3) m/s.
    """

    def __init__(
        self,
        quadrotor: Any,
        trajectory: Trajectory,
        times: np.ndarray,
        Y: np.ndarray,
        ref: dict[str, np.ndarray],
        wind: np.ndarray,
    ):
        self.quadrotor = quadrotor
        self.trajectory = trajectory
        self.times = readonly(np.ascontiguousarray(times))
        self.positions = readonly(np.ascontiguousarray(Y[:, 0:3]))
        self.velocities = readonly(np.ascontiguousarray(Y[:, 3:6]))
        self.attitudes = readonly(np.ascontiguousarray(Y[:, 6:15].reshape(-1, 3, 3)))
        self.angular_velocities = readonly(np.ascontiguousarray(Y[:, 15:18]))
        self.rotor_speeds = readonly(np.ascontiguousarray(Y[:, 18:22]))
        self.thrust = readonly(quadrotor.k_f * np.sum(self.rotor_speeds**2, axis=1))
        self.reference_positions = readonly(np.ascontiguousarray(ref["p"]))
        self.reference_velocities = readonly(np.ascontiguousarray(ref["v"]))
        self.reference_yaw = readonly(np.ascontiguousarray(ref["yaw"]))
        self.wind = readonly(np.ascontiguousarray(wind))

    def __len__(self) -> int:
        return len(self.times)

    def __repr__(self) -> str:
        return (
            f"Flight(k={len(self)}, t=[{self.times[0]:.6g}, {self.times[-1]:.6g}] s, "
            f"max error {self.position_error.max():.3g} m)"
        )

    @property
    def position_error(self) -> np.ndarray:
        """(k,) distance from the reference position, m."""
        return np.linalg.norm(self.positions - self.reference_positions, axis=1)

    @property
    def tilt_deg(self) -> np.ndarray:
        """(k,) angle between body z and world z, degrees."""
        return np.degrees(np.arccos(np.clip(self.attitudes[:, 2, 2], -1.0, 1.0)))

    def clearance(self, forest: Any, *, bark: bool = True) -> np.ndarray:
        """(k,) distance (m) from the body's centre at each recorded time to the nearest part
        of ``forest`` (a :class:`~batecho.Forest`, or anything with a ``clearance(points)``
        method such as a :class:`~batecho.Scene`): its leaf disks and, with ``bark``, its
        bark (docs/model.md §6)."""
        method = getattr(forest, "clearance", None)
        if not callable(method):
            raise TypeError(
                f"forest must be a batecho.Forest or Scene, got {type(forest).__name__}"
            )
        bark = flag(bark, "bark")
        if hasattr(forest, "bark"):
            return np.asarray(method(self.positions, bark=bark))
        return np.asarray(method(self.positions))

    def min_clearance(self, forest: Any, *, bark: bool = True) -> tuple[float, float]:
        """The flight's smallest clearance from ``forest`` (m) and the time (s) it occurs
        (see :meth:`clearance`)."""
        d = self.clearance(forest, bark=bark)
        i = int(np.argmin(d))
        return float(d[i]), float(self.times[i])

    def collision(self, forest: Any, radius_m: float, *, bark: bool = True) -> float | None:
        """The first recorded time (s) at which a drone of radius ``radius_m`` (a sphere about
        the body's centre) touches ``forest`` -- its clearance below ``radius_m`` -- or None if
        it never does."""
        r = finite_scalar(radius_m, "radius_m")
        if r < 0:
            raise ValueError(f"radius_m must be >= 0, got {r}")
        hit = np.flatnonzero(self.clearance(forest, bark=bark) < r)
        return float(self.times[hit[0]]) if hit.size else None

    def pulse_times(self, rate_hz: float, start: float | None = None) -> np.ndarray:
        """Times (s) of pulses at ``rate_hz`` Hz from ``start`` (default the first sample)
        to the end of the flight."""
        rate = positive_scalar(rate_hz, "rate_hz")
        t0 = float(self.times[0]) if start is None else finite_scalar(start, "start")
        t1 = float(self.times[-1])
        if not self.times[0] <= t0 <= t1:
            raise ValueError(f"start={t0} s is outside the flight [{self.times[0]}, {t1}] s")
        count = math.floor((t1 - t0) * rate + 1e-9) + 1
        check_memory(
            count * BYTES_PER_POSE,
            f"pulses at rate_hz = {rate:g} over {t1 - t0:g} s ({count:.3g} pulses, as poses)",
            "use a lower rate, or a part of the flight (start=)",
        )
        return t0 + np.arange(count) / rate

    def body_states(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        """Body positions (p, 3) (cubic Hermite in position and velocity) and attitudes
        (p, 3, 3) (SLERP) at times ``t`` within the flight."""
        tt = np.atleast_1d(finite(real_array(t, "pulse_times"), "pulse_times")).ravel()
        if tt.size == 0:
            raise ValueError("pulse_times is empty")
        lo, hi = self.times[0], self.times[-1]
        if tt.min() < lo - 1e-12 or tt.max() > hi + 1e-12:
            raise ValueError(f"pulse_times must lie within the flight [{lo}, {hi}] s")
        tt = np.clip(tt, lo, hi)
        from scipy.interpolate import CubicHermiteSpline
        from scipy.spatial.transform import Rotation, Slerp

        pos = CubicHermiteSpline(self.times, self.positions, self.velocities)(tt)
        rots = Slerp(self.times, Rotation.from_matrix(self.attitudes))(tt).as_matrix()
        return pos, rots

    def poses(self, pulse_times: Any, mount: SonarMount | None = None) -> Poses:
        """Sonar poses at ``pulse_times`` (s): the flown body pose with ``mount`` applied, so
        the body's bank and pitch tilt the beam."""
        pos, rots = self.body_states(pulse_times)
        return (SonarMount() if mount is None else mount).pose(pos, rots)
