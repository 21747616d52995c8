"""The reference's branches (docs/model.md §9): a branch cut into pieces short enough for the
phase and the beam, each piece a rigid cylinder in physical optics referred to its specular
point, monostatic and heard by receivers of their own, and the pieces' band spectrum.
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from .._geometry import dots
from ..flight.poses import Poses
from ..sonar.absorption import iso9613_alpha_db_per_m
from ..sonar.beam import Beam
from ..sonar.sonar import Sonar
from ..trees.branches import Branches
from ..trees.leaves import Leaves
from .lobe import _counting_points, _view
from .receivers import FORWARD_SCATTER_B, _heard, _receiver_position

# Section 9: branches ------------------------------------------------------------------------
#: The largest quadratic phase error across a branch piece, k l^2 / (4 r), at the band's top.
PIECE_PHASE = math.pi / 512.0
#: The largest share of the beam's Gaussian width a branch piece may span.
PIECE_BEAM_SHARE = 1.0 / 32.0
#: The most pieces one segment may be cut into for one pose.
MAX_PIECES = 1 << 20


def _sinc(x: np.ndarray) -> np.ndarray:
    """sin(x)/x, 1 at x = 0."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(x) < 1e-4, 1.0 - x * x / 6.0, np.sin(x) / np.where(x == 0, 1, x))


def _cylinder_po(k, a, length, cos_g, sin_g):
    """f = (l/2) sqrt(k a cos(gamma) / pi) sinc(k l sin(gamma)): the signed backscattering
    amplitude (m) of a rigid finite cylinder in physical optics, psi = -pi/4."""
    return 0.5 * length * np.sqrt(k * a * cos_g / math.pi) * _sinc(k * length * sin_g)


def _divergence(a, r, cos_g, cos_half_beta=1.0):
    """D = (1 + a / (r cos(beta/2) cos(gamma)))^(-1/2): the near-field factor of a cylinder's
    echo (docs/model.md §9). Round the circumference the sonar's spherical wave adds the path
    a^2 phi^2 / (2 r) each way to the plane wave's a phi^2 cos(gamma) / 2, so the stationary
    phase's width, and the echo, shrink by D; r is the reference point's range (the harmonic
    mean of the two for a receiver of its own), D -> 1 in the far field. Written as
    sqrt(x / (x + a)), x = r cos(beta/2) cos(gamma), which is 0, not a division by zero, at
    cos(gamma) = 0."""
    x = r * cos_half_beta * cos_g
    return np.sqrt(x / (x + a))


def _narrowest_sigma(sonar: Sonar) -> float:
    """The narrowest Gaussian width (rad) of the emitter's and every receiving beam."""
    tx = cast(Beam, sonar.beam)
    beams = [tx, tx if sonar.receiver is None else sonar.receiver]
    beams += [tx if rx.beam is None else rx.beam for rx in sonar.receivers or ()]
    return min(min(b._core_tuple()[1:3]) for b in beams)


def _max_piece_length(sonar: Sonar, sigma: float, r: float, k_max: float) -> float:
    """The longest piece at nearest distance r: scale min(sqrt(4 r PIECE_PHASE / k_max),
    PIECE_BEAM_SHARE sigma r), sigma the narrowest Gaussian width of the beams."""
    far = math.sqrt(4.0 * r * PIECE_PHASE / k_max)
    return sonar.branch_piece_scale * min(far, PIECE_BEAM_SHARE * sigma * r)


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from p to the segment a-b."""
    d, m = b - a, p - a
    dd = float(dots(d, d))
    t = min(max(float(dots(m, d)) / dd, 0.0), 1.0) if dd > 0 else 0.0
    q = m - t * d
    return math.sqrt(float(dots(q, q)))


def _cut(
    branches: Branches,
    j: int,
    p: np.ndarray,
    ears: list[np.ndarray],
    sonar: Sonar,
    sigma: float,
    k_max: float,
    too_close: list[tuple[int, float]],
    reach: float = math.inf,
):
    """Segment j cut into equal pieces, as lit from the emitter at p (docs/model.md §9): the
    number from the longest piece at the segment's nearest distance from the emitter or any
    receiver at ``ears``; then, for each piece not seen end-on from p, its centre c, the unit
    axis u, the length, and c - p's part sv along the axis and w across it with |w| = rho.
    Nothing when the segment lies farther than ``reach`` from all of them; a piece with p
    inside it is recorded in ``too_close``."""
    a, b, rad = branches.starts[j], branches.ends[j], float(branches.radii[j])
    near_tx = _segment_distance(p, a, b) - rad
    near = min([near_tx] + [_segment_distance(q, a, b) - rad for q in ears])
    if near > reach:
        return
    d = b - a
    lj = math.sqrt(float(dots(d, d)))
    u = d / lj
    longest = _max_piece_length(sonar, sigma, max(near, sonar.min_range_m), k_max)
    n = max(1, math.ceil(lj / longest))
    if n > MAX_PIECES:
        raise ValueError(f"branch {j} would need {n} pieces at {near:.3e} m from the sonar")
    pl = lj / n
    for q in range(n):
        c = a + ((2 * q + 1) / (2 * n)) * d
        v = c - p
        sv = float(dots(v, u))
        w = v - sv * u
        rho = math.sqrt(float(dots(w, w)))
        if not rho > rad:
            if abs(sv) <= 0.5 * pl:  # the pose inside the piece
                too_close.append((j, min(near_tx, 0.0)))
            continue  # (end-on from the emitter: only the flat end is lit, which is left out)
        yield c, u, pl, sv, w, rho


def _pieces(branches: Branches, sonar: Sonar, poses: Poses, i: int, k_max: float):
    """The counting branch pieces of pose i: segment, length, radius, cos and sin of the tilt,
    and the view of their reference points (mask applied): range, two-way gain."""
    p = poses.positions[i]
    sigma = _narrowest_sigma(sonar)
    seg, ref, length, radius, cg, sg = [], [], [], [], [], []
    too_close: list[tuple[int, float]] = []
    for j in range(len(branches)):
        rad = float(branches.radii[j])
        lit = _cut(branches, j, p, [], sonar, sigma, k_max, too_close, sonar.max_reach_m)
        for c, _, pl, sv, w, rho in lit:
            seg.append(j)
            ref.append(c - (rad / rho) * w)
            length.append(pl)
            radius.append(rad)
            # the tilt as seen from the reference point: the slope of the near surface
            # line's range there, so that adjacent pieces' edges meet in phase
            h = rho - rad
            rr = math.sqrt(sv * sv + h * h)
            cg.append(h / rr)
            sg.append(abs(sv) / rr)
    pts = np.array(ref).reshape(-1, 3)
    r, _, _, G = _view(pts, sonar, poses, i) if len(pts) else (np.zeros(0),) * 4
    close = ~(r >= sonar.min_range_m)
    too_close += [(seg[k], float(r[k])) for k in np.flatnonzero(close)]
    if too_close and sonar.too_close == "raise":
        j, dist = min(too_close)
        raise ValueError(
            f"branch {j} is {dist:.3e} m from pose {i}, closer than min_range_m = "
            f"{sonar.min_range_m} m"
        )
    mask = np.zeros(len(pts), dtype=bool)
    if len(pts):
        mask = _counting_points(pts, sonar, poses, i, "piece", check_close=False)[0]
    keep = np.flatnonzero(mask)
    arr = [np.asarray(x, dtype=np.float64)[keep] for x in (length, radius, cg, sg)]
    return (np.asarray(seg, dtype=np.int64)[keep], pts[keep], r[keep], G[keep], *arr)


def _wood_spectrum(
    sonar: Sonar, r, G, length, a, cg, sg, factor, f, w, bistatic=None
) -> np.ndarray:
    """The branch pieces' windowed band spectrum: amplitude g G f(k) D / r^2 times the shading
    factor (and absorption), D the near-field factor ``_divergence``, phase
    -2 k (r + l^2 cos^2(gamma) / (24 r)) + pi/4.

    Heard by a receiver of its own (``bistatic = (r_tx, r_rx, cos(beta/2))``, docs/model.md
    §9): ``r`` is the delay range (r_tx + r_rx)/2, the spreading r_tx r_rx, the factor
    f(k cos(beta/2)) with gamma from the bisector, and the Fresnel lag's range the harmonic
    mean 2 r_tx r_rx / (r_tx + r_rx), which is also D's range."""
    v = sonar.sound_speed
    k = 2.0 * np.pi * f / v
    Y = np.zeros(f.shape, dtype=np.complex128)
    alpha = None
    if sonar.absorption is not None:
        atm = sonar.absorption
        alpha = iso9613_alpha_db_per_m(f, atm.temperature_c, atm.relative_humidity, atm.pressure_pa)
    for q in range(len(r)):
        spread, k_eff, r_lag, cb = r[q] ** 2, k, r[q], 1.0
        if bistatic is not None:
            r_tx, r_rx, cb = (x[q] for x in bistatic)
            spread, k_eff, r_lag = r_tx * r_rx, k * cb, 2.0 * r_tx * r_rx / (r_tx + r_rx)
        A = sonar.gain * G[q] * factor[q] * _cylinder_po(k_eff, a[q], length[q], cg[q], sg[q])
        A = A * _divergence(a[q], r_lag, cg[q], cb)
        if sonar.spreading:
            A = A / spread
        if alpha is not None:
            A = A * 10.0 ** (-alpha * 2.0 * r[q] / 20.0)
        # the phase's range: the reference point's plus the piece's mean Fresnel lag
        # l^2 cos^2(gamma) / (24 r) (docs/model.md §9)
        lag = length[q] * length[q] * cg[q] * cg[q] / (24.0 * r_lag)
        cycles = f * (2.0 * (r[q] + lag) / v)
        Y += A * np.exp(1j * (-2.0 * np.pi * (cycles - np.round(cycles)) + np.pi / 4.0))
    return w * Y


def _unit(v: np.ndarray) -> np.ndarray:
    return v / math.sqrt(float(dots(v, v)))


def _bistatic_sight(p_tx, p_rx, c, u, a: float, pl: float):
    """A piece (centre c, unit axis u, radius a, length pl) lit from the emitter at p_tx, as
    the receiver at p_rx hears it (docs/model.md §9): None when no specular point is lit for
    both, "inside" when the receiver is inside it, else the reference point c - a w/|w| (w the
    part of b = e_tx + e_rx across the axis, e the unit directions to c), cos and sin of the
    tilt from the bisector's broadside and cos(beta/2) of the bistatic angle, all from the
    directions to the reference point."""
    v = c - p_rx
    sv = float(dots(v, u))
    wr = v - sv * u
    if not math.sqrt(float(dots(wr, wr))) > a:
        return "inside" if abs(sv) <= 0.5 * pl else None
    b = _unit(c - p_tx) + _unit(c - p_rx)
    if not math.sqrt(float(dots(b, b))) >= FORWARD_SCATTER_B:
        return None
    w = b - float(dots(b, u)) * u
    rho = math.sqrt(float(dots(w, w)))
    if not rho > 0.0:
        return None
    ref = c - (a / rho) * w
    if not (float(dots(ref - p_tx, w)) > 0.0 and float(dots(ref - p_rx, w)) > 0.0):
        return None  # the two on opposite sides of the surface: forward scattering
    bb = _unit(ref - p_tx) + _unit(ref - p_rx)
    nb = math.sqrt(float(dots(bb, bb)))
    sb = float(dots(bb, u))
    h = bb - sb * u
    return ref, math.sqrt(float(dots(h, h))) / nb, abs(sb) / nb, min(0.5 * nb, 1.0)


def _pieces_heard(branches: Branches, sonar: Sonar, poses: Poses, i: int, k_max: float):
    """For each receiver of pose i, its counting branch pieces (docs/model.md §9): each
    segment cut once for all receivers at its nearest distance from the emitter or any
    receiver; each piece lit from the emitter referred to the point that makes r_tx + r_rx
    least for the receiver (``_bistatic_sight``), and kept when it passes the receiver's lobe
    test (§5a) there. Per receiver: (segment, r_tx, r_rx, G, length, radius, cos and sin of
    the tilt, cos(beta/2), reference point (n, 3))."""
    p = poses.positions[i]
    rxs = cast(tuple, sonar.receivers)
    sigma = _narrowest_sigma(sonar)
    at = [_receiver_position(poses, i, rx.offset_m) for rx in rxs]
    alone = [sonar.replace(receivers=(rx,)) for rx in rxs]  # (each receiver's lobe test)
    rows: list[list[tuple]] = [[] for _ in rxs]
    too_close: list[tuple[int, float]] = []
    for j in range(len(branches)):
        rad = float(branches.radii[j])
        for c, u, pl, _, _, _ in _cut(branches, j, p, at, sonar, sigma, k_max, too_close):
            for k, q_rx in enumerate(at):
                sight = _bistatic_sight(p, q_rx, c, u, rad, pl)
                if sight == "inside":
                    too_close.append((j, 0.0))
                    continue
                if sight is None:
                    continue
                ref, cg, sg, cb = sight
                r_tx = math.sqrt(float(dots(ref - p, ref - p)))
                r_rx = math.sqrt(float(dots(ref - q_rx, ref - q_rx)))
                if not (r_tx >= sonar.min_range_m and r_rx >= sonar.min_range_m):
                    too_close.append((j, min(r_tx, r_rx)))
                    continue
                one = Leaves(ref[None, :], np.array([[0.0, 0.0, 1.0]]), np.array([rad]))
                mask, _, _, _, _, G = _heard(one, alone[k], poses, i)[0]
                if mask[0]:
                    rows[k].append((j, r_tx, r_rx, float(G[0]), pl, rad, cg, sg, cb, ref))
    if too_close and sonar.too_close == "raise":
        j, dist = min(too_close)
        raise ValueError(
            f"branch {j} is {dist:.3e} m from pose {i} or a receiver, closer than min_range_m = "
            f"{sonar.min_range_m} m"
        )
    return [
        (
            *(
                np.array([r[c] for r in rs], dtype=np.int64 if c == 0 else np.float64)
                for c in range(9)
            ),
            np.array([r[9] for r in rs], dtype=np.float64).reshape(-1, 3),
        )
        for rs in rows
    ]
