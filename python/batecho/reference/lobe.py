"""The reference's beampattern, angles and lobe (docs/model.md §1-§3): the Gaussian
beampattern, each point's range, direction and angles in a pose's frame, and the rule that
decides which points count.

The lobe test is a threshold, and a point on its boundary is decided by the last bit of
``atan2`` and ``exp``. The Rust core calls the C library's ``atan2`` and ``exp``; NumPy's SIMD
versions may differ from it in the last bit. So the inputs of the decision use Python's
``math`` functions (the same C library), and boundary points are decided identically.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from .._geometry import dots, norms
from ..flight.poses import Poses
from ..sonar.beam import Beam
from ..sonar.sonar import Sonar
from ..trees.leaves import Leaves

_atan2 = np.frompyfunc(math.atan2, 2, 1)
_exp = np.frompyfunc(math.exp, 1, 1)


def _libm(f, *args) -> np.ndarray:
    return np.asarray(f(*args), dtype=np.float64).reshape(np.shape(args[0]))


# Section 2: the beampattern ----------------------------------------------------------------
def _sigma_from_beamwidth(beamwidth_deg: float) -> float:
    # sigma = (BW/2) / sqrt(2 (-ln 0.7079)), BW in radians
    return (math.radians(beamwidth_deg) / 2.0) / math.sqrt(2.0 * -math.log(0.7079))


def _one_way_gain(beam: Beam, az: np.ndarray, el: np.ndarray) -> np.ndarray:
    """S = A1 exp(-(a daz^2 + 2b daz del + c del^2))."""
    if beam.beamwidth_deg is not None:
        sx = sy = _sigma_from_beamwidth(beam.beamwidth_deg)
    else:
        s = np.atleast_1d(np.asarray(beam.sigma_deg, dtype=np.float64))
        sx, sy = math.radians(float(s[0])), math.radians(float(s[-1]))
    th = math.radians(beam.rotation_deg)
    st, ct, s2t = math.sin(th), math.cos(th), math.sin(2.0 * th)
    a = ct * ct / (2.0 * sx * sx) + st * st / (2.0 * sy * sy)
    b = -s2t / (4.0 * sx * sx) + s2t / (4.0 * sy * sy)
    c = st * st / (2.0 * sx * sx) + ct * ct / (2.0 * sy * sy)
    daz = az - math.radians(beam.center_deg[0])
    daz = np.where(daz > math.pi, daz - 2.0 * math.pi, daz)  # wrap to [-pi, pi]
    daz = np.where(daz < -math.pi, daz + 2.0 * math.pi, daz)
    dl = el - math.radians(beam.center_deg[1])
    q = a * daz * daz + 2.0 * b * daz * dl + c * dl * dl
    return float(beam.amplitude) * _libm(_exp, -q)


def _two_way_gain(sonar: Sonar, az: np.ndarray, el: np.ndarray) -> np.ndarray:
    s_tx = _one_way_gain(cast(Beam, sonar.beam), az, el)
    s_rx = s_tx if sonar.receiver is None else _one_way_gain(sonar.receiver, az, el)
    return s_tx * s_rx


# Section 1 and 3: angles and the lobe --------------------------------------------------------
def _angles(points: np.ndarray, at: np.ndarray, poses: Poses, i: int):
    """Range, unit direction, e . d, azimuth and elevation of every point from the point
    ``at``, the angles in pose i's frame."""
    d, u, l_ = poses.forward[i], poses.up[i], poses.left[i]
    dx = points - at
    r = norms(dx)
    with np.errstate(invalid="ignore", divide="ignore"):
        e = dx / r[:, None]
    ed, el_, eu = dots(e, d), dots(e, l_), dots(e, u)
    az = _libm(_atan2, el_, ed)
    el = _libm(_atan2, eu, np.sqrt(ed * ed + el_ * el_))
    return r, e, ed, az, el


def _view(points: np.ndarray, sonar: Sonar, poses: Poses, i: int):
    """Range, unit direction, e . d and two-way gain of every point (a leaf's centre, a branch
    piece's reference point) from pose i."""
    r, e, ed, az, el = _angles(points, poses.positions[i], poses, i)
    return r, e, ed, _two_way_gain(sonar, az, el)


def _reach_sq(sonar: Sonar) -> float:
    """K = r0^2 p0 / (10^(T/20) p_ref): a leaf counts out to r^2 <= K G."""
    return (
        sonar.r0_m
        * sonar.r0_m
        * sonar.p0_pa
        / (10.0 ** (sonar.threshold_db / 20.0) * sonar.p_ref_pa)
    )


def _record_limit(sonar: Sonar) -> float:
    record = sonar.sound_speed * cast(int, sonar.n_samples) / (2.0 * sonar.fs)
    return record if sonar.max_range_m is None else min(float(sonar.max_range_m), record)


def _counting(leaves: Leaves, sonar: Sonar, poses: Poses, i: int):
    """Boolean mask of counting leaves for pose i, with the view quantities."""
    return _counting_points(leaves.centers, sonar, poses, i, "leaf")


def _counting_points(
    points: np.ndarray, sonar: Sonar, poses: Poses, i: int, what: str, check_close: bool = True
):
    """Boolean mask of the counting points for pose i, with the view quantities; a point
    closer than min_range_m raises naming ``what`` and its index (with ``check_close`` and
    ``too_close="raise"``), or is left out."""
    r, e, ed, G = _view(points, sonar, poses, i)
    too_close = ~(r >= sonar.min_range_m)
    if too_close.any() and sonar.too_close == "raise" and check_close:
        j = int(np.argmax(too_close))
        raise ValueError(
            f"{what} {j} is {r[j]:.3e} m from pose {i}, closer than min_range_m = "
            f"{sonar.min_range_m} m"
        )
    mask = ~too_close & (r <= _record_limit(sonar))
    if sonar.lobe == "cone":
        mask &= ed >= math.cos(math.radians(cast(float, sonar.cone_half_angle_deg)))
    else:
        # r <= sqrt(r0^2 p0 G / (10^(T/20) p_ref))
        with np.errstate(invalid="ignore"):
            mask &= r <= np.sqrt(_reach_sq(sonar) * G)
    return mask, r, e, G
