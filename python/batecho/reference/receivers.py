"""The reference's receivers at their own places (docs/model.md §5a): where each receiver
is, which leaves each one hears (the bistatic lobe rule) and the incidence from the bisector of
the directions out and back.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from ..flight.poses import Poses
from ..sonar.beam import Beam
from ..sonar.sonar import Sonar
from ..trees.leaves import Leaves
from .leaves import _incidence
from .lobe import _angles, _one_way_gain, _reach_sq, _record_limit


def _receiver_position(poses: Poses, i: int, offset) -> np.ndarray:
    """p + (o_f d + o_l l + o_u u), componentwise in that order."""
    p, d, l_, u = poses.positions[i], poses.forward[i], poses.left[i], poses.up[i]
    return p + (offset[0] * d + offset[1] * l_ + offset[2] * u)


def _seen_from(leaves: Leaves, at: np.ndarray, beam: Beam, poses: Poses, i: int):
    """Range, unit direction, e . d and one-way gain of every leaf from the point ``at``, with
    the angles in pose i's frame."""
    r, e, ed, az, el = _angles(leaves.centers, at, poses, i)
    return r, e, ed, _one_way_gain(beam, az, el)


def _heard(leaves: Leaves, sonar: Sonar, poses: Poses, i: int):
    """For each receiver of pose i: the mask of counting leaves, the emitter's and the
    receiver's ranges and directions, and the two-way gain ``S_tx S_rx``.

    A leaf counts for a receiver when it is at least ``min_range_m`` from emitter and receiver,
    its delay range ``(r_tx + r_rx) / 2`` is within the record (and ``max_range_m``), and
    ``sqrt(r_tx r_rx) <= sqrt(K S_tx S_rx)`` (detectable rule) or it lies in the cone seen
    from the emitter and from the receiver (cone rule).
    """
    tx_beam = cast(Beam, sonar.beam)
    r_tx, e_tx, ed_tx, s_tx = _seen_from(leaves, poses.positions[i], tx_beam, poses, i)
    rxs = cast(tuple, sonar.receivers)
    views = []
    near = ~(r_tx >= sonar.min_range_m)
    for rx in rxs:
        at = _receiver_position(poses, i, rx.offset_m)
        beam = tx_beam if rx.beam is None else rx.beam
        views.append(_seen_from(leaves, at, beam, poses, i))
        near |= ~(views[-1][0] >= sonar.min_range_m)
    if near.any() and sonar.too_close == "raise":
        j = int(np.argmax(near))
        raise ValueError(f"leaf {j} is closer than min_range_m = {sonar.min_range_m} m to pose {i}")
    out = []
    for r_rx, e_rx, ed_rx, s_rx in views:
        G = s_tx * s_rx
        mask = (r_tx >= sonar.min_range_m) & (r_rx >= sonar.min_range_m)
        mask &= (r_tx + r_rx) / 2.0 <= _record_limit(sonar)
        if sonar.lobe == "cone":
            cos_h = math.cos(math.radians(cast(float, sonar.cone_half_angle_deg)))
            mask &= (ed_tx >= cos_h) & (ed_rx >= cos_h)
        else:
            with np.errstate(invalid="ignore"):
                mask &= np.sqrt(r_tx * r_rx) <= np.sqrt(_reach_sq(sonar) * G)
        out.append((mask, r_tx, e_tx, r_rx, e_rx, G))
    return out


#: Below this ``|e_tx + e_rx| = 2 cos(gamma / 2)`` (a bistatic angle within about 1e-4 rad of
#: 180 degrees) a leaf is forward scattering, at grazing incidence (docs/model.md §5a).
FORWARD_SCATTER_B = 1e-4


def _bisector_incidence(e_tx: np.ndarray, e_rx: np.ndarray, n: np.ndarray):
    """The incidence from the bisector b = (e_tx + e_rx) / |e_tx + e_rx| of the two directions:
    an approximation for small bistatic angles, exact at zero. |b| below
    ``FORWARD_SCATTER_B`` (a leaf on or next to the segment between emitter and receiver:
    forward scattering, no specular direction, b decided by rounding) is grazing incidence
    (beta = pi/2, cos = 0, sin = 1)."""
    b = e_tx + e_rx
    nb = np.sqrt(b[:, 0] * b[:, 0] + b[:, 1] * b[:, 1] + b[:, 2] * b[:, 2])
    zero = ~(nb >= FORWARD_SCATTER_B)
    with np.errstate(invalid="ignore", divide="ignore"):
        beta, cos_b, sin_b = _incidence(b / nb[:, None], n)
    beta = np.where(zero, np.pi / 2, beta)
    return beta, np.where(zero, 0.0, cos_b), np.where(zero, 1.0, sin_b)
