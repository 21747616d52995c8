"""The NumPy reference: docs/model.md written out for clarity, not speed.

Plain NumPy and SciPy, a brute-force lobe test (no BVH, no Rust). ``simulate`` and
``lobe_members`` have the same signatures and results as ``batecho.simulate`` and
``batecho.lobe_members``, receivers at their own places included (docs/model.md §5a:
``_heard``, ``_bisector_incidence``, ``_simulate_heard``); the property tests hold the Rust
core to this module.

One deliberate detail: the lobe test is a threshold, and a leaf on its boundary is decided by
the last bit of ``atan2`` and ``exp``. The Rust core calls the C library's ``atan2`` and
``exp``; NumPy's SIMD versions may differ from it in the last bit. So the inputs of the
decision use Python's ``math`` functions (the same C library), and boundary leaves are decided
identically. Everything else is vectorised NumPy.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np
from scipy.special import erf, j1

from .echoes.simulate import Echoes
from .flight.poses import Poses
from .forest.scene import Scene
from .sonar.absorption import iso9613_alpha_db_per_m
from .sonar.beam import Beam
from .sonar.sonar import Sonar
from .trees.branches import Branches
from .trees.leaves import Leaves, as_leaves

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
def _view(points: np.ndarray, sonar: Sonar, poses: Poses, i: int):
    """Range, unit direction, azimuth, elevation and two-way gain of every point (a leaf's
    centre, a branch piece's reference point) from pose i."""
    p = poses.positions[i]
    d, u, l_ = poses.forward[i], poses.up[i], poses.left[i]
    dx = points - p
    r = np.sqrt(dx[:, 0] * dx[:, 0] + dx[:, 1] * dx[:, 1] + dx[:, 2] * dx[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        e = dx / r[:, None]
    ed = e[:, 0] * d[0] + e[:, 1] * d[1] + e[:, 2] * d[2]
    el_ = e[:, 0] * l_[0] + e[:, 1] * l_[1] + e[:, 2] * l_[2]
    eu = e[:, 0] * u[0] + e[:, 1] * u[1] + e[:, 2] * u[2]
    az = _libm(_atan2, el_, ed)
    el = _libm(_atan2, eu, np.sqrt(ed * ed + el_ * el_))
    G = _two_way_gain(sonar, az, el)
    return r, e, ed, G


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


# Section 5a: receivers at their own places -------------------------------------------------
def _receiver_position(poses: Poses, i: int, offset) -> np.ndarray:
    """p + (o_f d + o_l l + o_u u), componentwise in that order."""
    p, d, l_, u = poses.positions[i], poses.forward[i], poses.left[i], poses.up[i]
    return p + (offset[0] * d + offset[1] * l_ + offset[2] * u)


def _seen_from(leaves: Leaves, at: np.ndarray, beam: Beam, poses: Poses, i: int):
    """Range, unit direction, e . d and one-way gain of every leaf from the point ``at``, with
    the angles in pose i's frame (the same operations as ``_view``)."""
    d, u, l_ = poses.forward[i], poses.up[i], poses.left[i]
    dx = leaves.centers - at
    r = np.sqrt(dx[:, 0] * dx[:, 0] + dx[:, 1] * dx[:, 1] + dx[:, 2] * dx[:, 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        e = dx / r[:, None]
    ed = e[:, 0] * d[0] + e[:, 1] * d[1] + e[:, 2] * d[2]
    el_ = e[:, 0] * l_[0] + e[:, 1] * l_[1] + e[:, 2] * l_[2]
    eu = e[:, 0] * u[0] + e[:, 1] * u[1] + e[:, 2] * u[2]
    az = _libm(_atan2, el_, ed)
    el = _libm(_atan2, eu, np.sqrt(ed * ed + el_ * el_))
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


def lobe_members(
    scene: Any,
    sonar: Sonar,
    pose: Poses,
    *,
    search: str = "brute_force",
    receiver: int | None = None,
) -> np.ndarray:
    """Indices (ascending) of the leaves that count for one pose (for receiver ``receiver`` of
    a sonar with receivers of its own), by testing every leaf."""
    leaves = as_leaves(scene)
    if len(pose) != 1:
        raise ValueError(f"lobe_members takes one pose; got {len(pose)}")
    if sonar.receivers is not None:
        mask = _heard(leaves, sonar, pose, 0)[cast(int, receiver)][0]
    else:
        mask = _counting(leaves, sonar, pose, 0)[0]
    return np.flatnonzero(mask).astype(np.int64)


# Section 5: the frequency grid -------------------------------------------------------------
def _grid(sonar: Sonar):
    n, fs = cast(int, sonar.n_samples), sonar.fs
    df = fs / n
    k0 = math.floor(sonar.band_hz[0] / df + 0.5)  # round half up
    k1 = math.floor(sonar.band_hz[1] / df + 0.5)
    k = np.arange(k0, k1 + 1)
    f = k * fs / n
    M = k1 - k0 + 1
    if sonar.window == "hann":
        w = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(M) / M)  # periodic Hann
    else:
        w = np.ones(M)
    return k0, k1, f, w


# Section 4: leaf scattering ----------------------------------------------------------------
def _leaf_paper(c: np.ndarray, beta: np.ndarray, cos_b=None, sin_b=None):
    A = 0.5003 * c**2 + 0.6867
    B = 0.3999 * c ** (-0.9065) + 0.9979
    L = np.maximum(0.0, A * np.cos(B * beta))
    P = 0.9824 * c**0.3523 - 0.9459
    psi = erf(P * (1.57 - beta)) - 2.6343
    return L, psi


def _leaf_physical_optics(c: np.ndarray, beta: np.ndarray, cos_b: np.ndarray, sin_b: np.ndarray):
    # cos(beta) = |e . n| and sin(beta) = |e x n| from the geometry: the same values as the
    # cosine and sine of beta, but accurate at grazing incidence
    x = 2.0 * c * sin_b
    with np.errstate(invalid="ignore", divide="ignore"):
        jinc = np.where(x == 0.0, 1.0, 2.0 * j1(x) / x)  # 2 J1(x)/x, limit 1 at x = 0
    L = c**2 / 2.0 * cos_b * np.abs(jinc)
    return L, np.full_like(L, -np.pi / 2)


def _spectrum(sonar: Sonar, r, G, incidence, a, f, w, spread=None, chunk: int = 2048) -> np.ndarray:
    """Y_k = w_k sum_i A_ki exp(j phi_ki) over the band bins. ``r`` is the (delay) range, whose
    round trip ``2 r`` gives the phase and the absorption; ``spread`` is the spreading divisor
    (``r^2``, or ``r_tx r_rx`` for a receiver of its own)."""
    spread = r * r if spread is None else spread
    v = sonar.sound_speed
    k = 2.0 * np.pi * f / v
    model = _leaf_paper if sonar.leaf_model == "paper" else _leaf_physical_optics
    alpha = None
    if sonar.absorption is not None:
        atm = sonar.absorption
        alpha = iso9613_alpha_db_per_m(f, atm.temperature_c, atm.relative_humidity, atm.pressure_pa)
    beta, cos_b, sin_b = incidence
    Y = np.zeros(f.shape, dtype=np.complex128)
    for s in range(0, len(r), chunk):
        ri, Gi, bi, ci, si, ai, qi = (
            x[s : s + chunk, None] for x in (r, G, beta, cos_b, sin_b, a, spread)
        )
        c = k * ai
        L, psi = model(c, bi, ci, si)
        A = sonar.gain * Gi * L / k
        if sonar.spreading:
            A = A / qi
        if alpha is not None:
            A = A * 10.0 ** (-alpha * 2.0 * ri / 20.0)
        # phi = -2 k r - psi, with 2 k r reduced through the fractional part of f 2r / v
        cycles = f * (2.0 * ri / v)
        phi = -2.0 * np.pi * (cycles - np.round(cycles)) - psi
        Y += np.sum(A * np.exp(1j * phi), axis=0)
    return w * Y


def _incidence(e: np.ndarray, n: np.ndarray):
    """beta = angle(e, n) folded into [0, pi/2], via atan2(|e x n|, e . n); with
    cos(beta) = |e . n| and sin(beta) = |e x n|."""
    cx = e[:, 1] * n[:, 2] - e[:, 2] * n[:, 1]
    cy = e[:, 2] * n[:, 0] - e[:, 0] * n[:, 2]
    cz = e[:, 0] * n[:, 1] - e[:, 1] * n[:, 0]
    sin_b = np.sqrt(cx * cx + cy * cy + cz * cz)
    cos_b = e[:, 0] * n[:, 0] + e[:, 1] * n[:, 1] + e[:, 2] * n[:, 2]
    beta = np.arctan2(sin_b, cos_b)
    return np.minimum(beta, np.pi - beta), np.minimum(np.abs(cos_b), 1.0), np.minimum(sin_b, 1.0)


# Section 9: branches ------------------------------------------------------------------------
#: The largest quadratic phase error across a branch piece, k l^2 / (4 r), at the band's top.
PIECE_PHASE = math.pi / 512.0
#: The largest share of the beam's Gaussian width a branch piece may span.
PIECE_BEAM_SHARE = 1.0 / 32.0
#: The most pieces one segment may be cut into for one pose.
MAX_PIECES = 1 << 20


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise a . b, summed x, y, z in that order (as the Rust core does)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _sinc(x: np.ndarray) -> np.ndarray:
    """sin(x)/x, 1 at x = 0."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(x) < 1e-4, 1.0 - x * x / 6.0, np.sin(x) / np.where(x == 0, 1, x))


def _cylinder_po(k, a, length, cos_g, sin_g):
    """f = (l/2) sqrt(k a cos(gamma) / pi) sinc(k l sin(gamma)): the signed backscattering
    amplitude (m) of a rigid finite cylinder in physical optics, psi = -pi/4."""
    return 0.5 * length * np.sqrt(k * a * cos_g / math.pi) * _sinc(k * length * sin_g)


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
    dd = float(_dot(d, d))
    t = min(max(float(_dot(m, d)) / dd, 0.0), 1.0) if dd > 0 else 0.0
    q = m - t * d
    return math.sqrt(float(_dot(q, q)))


def _cut(
    branches: Branches,
    j: int,
    p: np.ndarray,
    near: float,
    sonar: Sonar,
    sigma: float,
    k_max: float,
    too_close: list[tuple[int, float]],
):
    """Segment j cut into equal pieces, as lit from the emitter at p (docs/model.md §9): the
    number n from the longest piece at ``near``, the segment's nearest distance from the
    emitter (and the receivers); then, for each piece not seen end-on from p, its centre c,
    the unit axis u, the length, and c - p's part sv along the axis and w across it with
    |w| = rho. A piece with p inside it is recorded in ``too_close``."""
    a, b, rad = branches.starts[j], branches.ends[j], float(branches.radii[j])
    near_tx = _segment_distance(p, a, b) - rad
    d = b - a
    lj = math.sqrt(float(_dot(d, d)))
    u = d / lj
    longest = _max_piece_length(sonar, sigma, max(near, sonar.min_range_m), k_max)
    n = max(1, math.ceil(lj / longest))
    if n > MAX_PIECES:
        raise ValueError(f"branch {j} would need {n} pieces at {near:.3e} m from the sonar")
    pl = lj / n
    for q in range(n):
        c = a + ((2 * q + 1) / (2 * n)) * d
        v = c - p
        sv = float(_dot(v, u))
        w = v - sv * u
        rho = math.sqrt(float(_dot(w, w)))
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
        near = _segment_distance(p, branches.starts[j], branches.ends[j]) - rad
        if near > sonar.max_reach_m:
            continue
        for c, _, pl, sv, w, rho in _cut(branches, j, p, near, sonar, sigma, k_max, too_close):
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
    """The branch pieces' windowed band spectrum: amplitude g G f(k) / r^2 times the shading
    factor (and absorption), phase -2 k (r + l^2 cos^2(gamma) / (24 r)) + pi/4.

    Heard by a receiver of its own (``bistatic = (r_tx, r_rx, cos(beta/2))``, docs/model.md
    §9): ``r`` is the delay range (r_tx + r_rx)/2, the spreading r_tx r_rx, the factor
    f(k cos(beta/2)) with gamma from the bisector, and the Fresnel lag's range the harmonic
    mean 2 r_tx r_rx / (r_tx + r_rx)."""
    v = sonar.sound_speed
    k = 2.0 * np.pi * f / v
    Y = np.zeros(f.shape, dtype=np.complex128)
    alpha = None
    if sonar.absorption is not None:
        atm = sonar.absorption
        alpha = iso9613_alpha_db_per_m(f, atm.temperature_c, atm.relative_humidity, atm.pressure_pa)
    for q in range(len(r)):
        spread, k_eff, r_lag = r[q] ** 2, k, r[q]
        if bistatic is not None:
            r_tx, r_rx, cb = (x[q] for x in bistatic)
            spread, k_eff, r_lag = r_tx * r_rx, k * cb, 2.0 * r_tx * r_rx / (r_tx + r_rx)
        A = sonar.gain * G[q] * factor[q] * _cylinder_po(k_eff, a[q], length[q], cg[q], sg[q])
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
    return v / math.sqrt(float(_dot(v, v)))


def _bistatic_sight(p_tx, p_rx, c, u, a: float, pl: float):
    """A piece (centre c, unit axis u, radius a, length pl) lit from the emitter at p_tx, as
    the receiver at p_rx hears it (docs/model.md §9): None when no specular point is lit for
    both, "inside" when the receiver is inside it, else the reference point c - a w/|w| (w the
    part of b = e_tx + e_rx across the axis, e the unit directions to c), cos and sin of the
    tilt from the bisector's broadside and cos(beta/2) of the bistatic angle, all from the
    directions to the reference point."""
    v = c - p_rx
    sv = float(_dot(v, u))
    wr = v - sv * u
    if not math.sqrt(float(_dot(wr, wr))) > a:
        return "inside" if abs(sv) <= 0.5 * pl else None
    b = _unit(c - p_tx) + _unit(c - p_rx)
    if not math.sqrt(float(_dot(b, b))) >= FORWARD_SCATTER_B:
        return None
    w = b - float(_dot(b, u)) * u
    rho = math.sqrt(float(_dot(w, w)))
    if not rho > 0.0:
        return None
    ref = c - (a / rho) * w
    if not (float(_dot(ref - p_tx, w)) > 0.0 and float(_dot(ref - p_rx, w)) > 0.0):
        return None  # the two on opposite sides of the surface: forward scattering
    bb = _unit(ref - p_tx) + _unit(ref - p_rx)
    nb = math.sqrt(float(_dot(bb, bb)))
    sb = float(_dot(bb, u))
    h = bb - sb * u
    return ref, math.sqrt(float(_dot(h, h))) / nb, abs(sb) / nb, min(0.5 * nb, 1.0)


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
        a, b, rad = branches.starts[j], branches.ends[j], float(branches.radii[j])
        near = min(_segment_distance(q, a, b) - rad for q in [p, *at])
        for c, u, pl, _, _, _ in _cut(branches, j, p, near, sonar, sigma, k_max, too_close):
            for k, q_rx in enumerate(at):
                sight = _bistatic_sight(p, q_rx, c, u, rad, pl)
                if sight == "inside":
                    too_close.append((j, 0.0))
                    continue
                if sight is None:
                    continue
                ref, cg, sg, cb = sight
                r_tx = math.sqrt(float(_dot(ref - p, ref - p)))
                r_rx = math.sqrt(float(_dot(ref - q_rx, ref - q_rx)))
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


# Section 10: shading -------------------------------------------------------------------------
def _disk_crossings(leaves: Leaves, origin: np.ndarray, w: np.ndarray, own: int) -> int:
    """How many leaf disks (all but ``own``) the open segment t w, 0 < t < 1, from the origin
    crosses: the plane's hit t = (n . v) / (n . w) in (0, 1), inside the radius or on the rim.
    A segment parallel to a disk's plane does not cross it."""
    v = leaves.centers - origin
    nrm = leaves.normals
    # (at extreme coordinates the products overflow to inf or NaN, which the tests below
    # reject as the Rust core does)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        nv = _dot(nrm, v)
        d = nrm[:, 0] * w[0] + nrm[:, 1] * w[1] + nrm[:, 2] * w[2]
        t = nv / d
        q = t[:, None] * w[None, :] - v
        hit = (d != 0.0) & (t > 0.0) & (t < 1.0) & (_dot(q, q) <= leaves.radii * leaves.radii)
    if own >= 0:
        hit[own] = False
    return int(hit.sum())


def _joined(branches: Branches) -> list[set[int]]:
    """For each segment, the others that share one of its end points bit for bit."""
    key = lambda x: tuple(np.asarray(x, dtype=np.float64).view(np.uint64).tolist())
    at: dict[tuple, set[int]] = {}
    for j in range(len(branches)):
        for pt in {key(branches.starts[j]), key(branches.ends[j])}:
            at.setdefault(pt, set()).add(j)
    return [
        (at[key(branches.starts[j])] | at[key(branches.ends[j])]) - {j}
        for j in range(len(branches))
    ]


def _blocked(branches: Branches, origin: np.ndarray, w: np.ndarray, spared: set[int]) -> bool:
    """Whether the open segment t w, 0 < t < 1, passes through the interior of a branch
    cylinder (any but those in ``spared``): some t where the point lies closer to the axis
    than the radius and strictly between the segment's end planes."""
    for j in range(len(branches)):
        if j in spared:
            continue
        d = branches.ends[j] - branches.starts[j]
        length = math.sqrt(float(_dot(d, d)))
        u = d / length
        s = branches.starts[j] - origin
        su = float(_dot(s, u))
        e0 = s - su * u
        c = float(_dot(e0, e0)) - float(branches.radii[j]) ** 2
        sw = float(_dot(w, u))
        e1 = w - sw * u
        qa, qb = float(_dot(e1, e1)), float(_dot(e0, e1))
        lo, hi = 0.0, 1.0
        if qa == 0.0:
            if not c < 0.0:
                continue
        else:
            disc = qb * qb - qa * c
            if not disc > 0.0:
                continue
            root = math.sqrt(disc)
            lo, hi = max(lo, (qb - root) / qa), min(hi, (qb + root) / qa)
        if sw == 0.0:
            if not 0.0 < -su < length:
                continue
        else:
            t0, t1 = su / sw, (su + length) / sw
            a, b = (t0, t1) if sw > 0.0 else (t1, t0)
            lo, hi = max(lo, a), min(hi, b)
        if lo < hi:
            return True
    return False


def _shading(
    leaves: Leaves | None,
    branches: Branches | None,
    sonar: Sonar,
    origin: np.ndarray,
    leaf_idx: np.ndarray,
    piece_seg: np.ndarray,
    piece_ref: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """tau^(2m) for each counting leaf and piece (0 where a branch blocks), by brute force."""
    sh = sonar.shading
    if sh is None:
        return np.ones(len(leaf_idx)), np.ones(len(piece_seg))
    tau = sh.leaf_transmission
    joined = _joined(branches) if branches is not None else []

    def factor(point: np.ndarray, own_leaf: int, spared: set[int]) -> float:
        w = point - origin
        if sh.branches_block and branches is not None and _blocked(branches, origin, w, spared):
            return 0.0
        m = 0 if leaves is None else _disk_crossings(leaves, origin, w, own_leaf)
        return 1.0 if m == 0 else (tau * tau) ** m

    assert leaves is not None or len(leaf_idx) == 0
    fl = [factor(cast(Leaves, leaves).centers[j], int(j), set()) for j in leaf_idx]
    fp = [factor(piece_ref[q], -1, {int(g)} | joined[g]) for q, g in enumerate(piece_seg)]
    return np.asarray(fl, dtype=np.float64), np.asarray(fp, dtype=np.float64)


def _two_way_factor(tau: float, m_out: int, m_back: int) -> float:
    """tau^(m_out + m_back) (docs/model.md §10), as (tau^2)^(s // 2), times tau for odd s."""
    s = m_out + m_back
    even = 1.0 if s < 2 else (tau * tau) ** (s // 2)
    return even * tau if s % 2 else even


def _heard_shading(
    leaves: Leaves | None,
    branches: Branches | None,
    sonar: Sonar,
    tx: np.ndarray,
    at: np.ndarray,
    leaf_idx: np.ndarray,
    piece_seg: np.ndarray,
    piece_ref: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """For the leaves ``leaf_idx`` and the pieces (segments ``piece_seg``, reference points
    ``piece_ref`` (n, 3)) heard by the receiver at ``at`` from the emitter at ``tx``, by brute
    force (docs/model.md §10): tau^(m_out + m_back), m_out the leaf disks the open segment from
    the emitter to the leaf's centre (the piece's reference point) crosses, m_back those the
    segment from the receiver crosses (a leaf's own disk apart), and 0 where a branch blocks
    either (with ``branches_block``; a piece's own segment and those joined to it apart)."""
    sh = sonar.shading
    if sh is None:
        return np.ones(len(leaf_idx)), np.ones(len(piece_seg))
    tau = sh.leaf_transmission
    joined = _joined(branches) if branches is not None else []

    def factor(point: np.ndarray, own_leaf: int, spared: set[int]) -> float:
        m = []
        for origin in (tx, at):
            w = point - origin
            if sh.branches_block and branches is not None and _blocked(branches, origin, w, spared):
                return 0.0
            m.append(0 if leaves is None else _disk_crossings(leaves, origin, w, own_leaf))
        return _two_way_factor(tau, m[0], m[1])

    assert leaves is not None or len(leaf_idx) == 0
    fl = [factor(cast(Leaves, leaves).centers[j], int(j), set()) for j in leaf_idx]
    fp = [factor(piece_ref[q], -1, {int(g)} | joined[g]) for q, g in enumerate(piece_seg)]
    return np.asarray(fl, dtype=np.float64), np.asarray(fp, dtype=np.float64)


def leaf_sights(scene: Any, sonar: Sonar, pose: Poses, *, branches_block: bool = True):
    """For each counting leaf of one pose (ascending index): the other leaf disks its ray
    crosses and whether a branch blocks it, by testing every leaf and branch."""
    from .echoes.simulate import LeafSights

    leaves, branches = _parts(scene)
    if leaves is None:
        raise ValueError("leaf_sights needs a scene with leaves")
    idx = np.flatnonzero(_counting(leaves, sonar, pose, 0)[0])
    origin = pose.positions[0]
    crossings = np.zeros(idx.size, dtype=np.int64)
    blocked = np.zeros(idx.size, dtype=bool)
    for q, j in enumerate(idx):
        w = leaves.centers[j] - origin
        crossings[q] = _disk_crossings(leaves, origin, w, int(j))
        if branches_block and branches is not None:
            blocked[q] = _blocked(branches, origin, w, set())
    return LeafSights(idx.astype(np.int64), crossings, blocked)


def _parts(scene: Any) -> tuple[Leaves | None, Branches | None]:
    """The leaves and branches of a Scene, Leaves, or anything with ``.leaves``."""
    if isinstance(scene, Scene):
        return scene.leaves, scene.branches
    return as_leaves(scene), None


def simulate(scene: Any, sonar: Sonar, poses: Poses, method: str = "exact") -> Echoes:
    """Echoes of ``scene`` for every pose, straight from docs/model.md (``method`` is ignored: the
    reference is always the exact sum). Branches (§9) and shading (§10) by brute force."""
    leaves, branches = _parts(scene)
    if not isinstance(sonar, Sonar) or not isinstance(poses, Poses):
        raise TypeError("simulate(scene, sonar: Sonar, poses: Poses)")
    if sonar.is_auto:
        # the record holds the farthest counting scatterer of any pose plus the pulse tail
        provisional = sonar.resolve(sonar._provisional_n())
        k_top = 2.0 * np.pi * _grid(provisional)[2][-1] / sonar.sound_speed
        far = 0.0
        for i in range(len(poses)):
            if leaves is not None and sonar.receivers is not None:
                for mask, r_tx, _, r_rx, _, _ in _heard(leaves, provisional, poses, i):
                    far = max(far, float(((r_tx + r_rx) / 2.0)[mask].max(initial=0.0)))
            elif leaves is not None:
                mask, r, _, _ = _counting(leaves, provisional, poses, i)
                far = max(far, float(r[mask].max(initial=0.0)))
            if branches is not None and sonar.receivers is not None:
                for pc in _pieces_heard(branches, provisional, poses, i, k_top):
                    far = max(far, float(((pc[1] + pc[2]) / 2.0).max(initial=0.0)))
            elif branches is not None:
                rp = _pieces(branches, provisional, poses, i, k_top)[2]
                far = max(far, float(rp.max(initial=0.0)))
        sonar = sonar.resolve(sonar.record_length_for(far))
    k0, k1, f, w = _grid(sonar)
    k_lo = 2.0 * np.pi * f[0] / sonar.sound_speed
    k_top = 2.0 * np.pi * f[-1] / sonar.sound_speed
    for name, parts in (("leaf", leaves), ("branch", branches)):
        if parts is not None and sonar.min_ka > 0:
            ka = k_lo * parts.radii
            if ka.min() < sonar.min_ka:
                raise ValueError(f"{name} {int(np.argmin(ka))} has k a = {ka.min():.4g} < min_ka")
    n = cast(int, sonar.n_samples)
    if sonar.receivers is not None:
        return _simulate_heard(leaves, branches, sonar, poses, k0, k1, f, w)
    spectra = np.zeros((len(poses), len(f)), dtype=np.complex128)
    wood = np.zeros_like(spectra) if branches is not None else None
    impulses = np.zeros((len(poses), n))
    counts = np.zeros(len(poses), dtype=np.int64)
    n_pieces = np.zeros(len(poses), dtype=np.int64)
    n_shaded = np.zeros(len(poses), dtype=np.int64)
    for i in range(len(poses)):
        idx = np.zeros(0, dtype=np.int64)
        if leaves is not None:
            mask, r, e, G = _counting(leaves, sonar, poses, i)
            idx = np.flatnonzero(mask)
        pc = (np.zeros(0, dtype=np.int64), np.zeros((0, 3)), *([np.zeros(0)] * 6))
        if branches is not None:
            pc = _pieces(branches, sonar, poses, i, k_top)
        seg, ref, rp, Gp, lp, ap, cg, sg = pc
        fl, fp = _shading(leaves, branches, sonar, poses.positions[i], idx, seg, ref)
        counts[i], n_pieces[i] = idx.size, seg.size
        n_shaded[i] = int((fl != 1.0).sum())
        if idx.size:
            leaves = cast(Leaves, leaves)
            beta = _incidence(e[idx], leaves.normals[idx])
            spectra[i] = _spectrum(sonar, r[idx], G[idx] * fl, beta, leaves.radii[idx], f, w)
        if wood is not None:
            wood[i] = _wood_spectrum(sonar, rp, Gp, lp, ap, cg, sg, fp, f, w)
            spectra[i] += wood[i]
        full = np.zeros(n // 2 + 1, dtype=np.complex128)
        full[k0 : k1 + 1] = spectra[i]
        impulses[i] = 2.0 * np.fft.irfft(full, n)
    return Echoes(
        spectrum=spectra,
        freqs=f,
        impulse=impulses,
        times=np.arange(n) / sonar.fs,
        n_leaves=counts,
        sonar=sonar,
        poses=poses,
        wood_spectrum=wood,
        n_pieces=n_pieces,
        n_shaded=n_shaded,
    )


def _simulate_heard(
    leaves: Leaves | None, branches: Branches | None, sonar: Sonar, poses: Poses, k0, k1, f, w
) -> Echoes:
    """Every receiver's echoes (docs/model.md §5a): the amplitude ``g S_tx S_rx L / (k r_tx
    r_rx)``, the phase ``-k (r_tx + r_rx) - psi``, absorption over ``r_tx + r_rx``, the
    incidence from the bisector; with branches, each receiver's pieces (§9); with shading,
    times tau^(m_out + m_back) (§10)."""
    n = cast(int, sonar.n_samples)
    n_rx = len(cast(tuple, sonar.receivers))
    spectra = np.zeros((len(poses), n_rx, len(f)), dtype=np.complex128)
    wood = np.zeros_like(spectra) if branches is not None else None
    impulses = np.zeros((len(poses), n_rx, n))
    counts = np.zeros((len(poses), n_rx), dtype=np.int64)
    n_pieces = np.zeros((len(poses), n_rx), dtype=np.int64)
    n_shaded = np.zeros((len(poses), n_rx), dtype=np.int64)
    rxs = cast(tuple, sonar.receivers)
    k_top = 2.0 * np.pi * f[-1] / sonar.sound_speed
    for i in range(len(poses)):
        heard = _heard(leaves, sonar, poses, i) if leaves is not None else [None] * n_rx
        pieces = _pieces_heard(branches, sonar, poses, i, k_top) if branches else [None] * n_rx
        for j, (hd, pc) in enumerate(zip(heard, pieces, strict=True)):
            idx = np.zeros(0, dtype=np.int64)
            if hd is not None:
                mask, r_tx, e_tx, r_rx, e_rx, G = hd
                idx = np.flatnonzero(mask)
                counts[i, j] = idx.size
            seg, ref = (pc[0], pc[9]) if pc is not None else (idx[:0], np.zeros((0, 3)))
            at = _receiver_position(poses, i, rxs[j].offset_m)
            fl, fp = _heard_shading(leaves, branches, sonar, poses.positions[i], at, idx, seg, ref)
            n_shaded[i, j] = int((fl != 1.0).sum())
            if hd is not None and idx.size:
                G = G.copy()
                G[idx] = G[idx] * fl
                leaves = cast(Leaves, leaves)
                beta = _bisector_incidence(e_tx[idx], e_rx[idx], leaves.normals[idx])
                r = (r_tx[idx] + r_rx[idx]) / 2.0
                spread = r_tx[idx] * r_rx[idx]
                spectra[i, j] = _spectrum(
                    sonar, r, G[idx], beta, leaves.radii[idx], f, w, spread=spread
                )
            if wood is not None and pc is not None:
                _, pr_tx, pr_rx, pG, pl, pa, pcg, psg, pcb, _ = pc
                n_pieces[i, j] = pl.size
                wood[i, j] = _wood_spectrum(
                    sonar,
                    (pr_tx + pr_rx) / 2.0,
                    pG,
                    pl,
                    pa,
                    pcg,
                    psg,
                    fp,
                    f,
                    w,
                    bistatic=(pr_tx, pr_rx, pcb),
                )
                spectra[i, j] += wood[i, j]
            full = np.zeros(n // 2 + 1, dtype=np.complex128)
            full[k0 : k1 + 1] = spectra[i, j]
            impulses[i, j] = 2.0 * np.fft.irfft(full, n)
    return Echoes(
        spectrum=spectra,
        freqs=f,
        impulse=impulses,
        times=np.arange(n) / sonar.fs,
        n_leaves=counts,
        sonar=sonar,
        poses=poses,
        wood_spectrum=wood,
        n_pieces=n_pieces,
        n_shaded=n_shaded,
    )


# Section 6: clearance ----------------------------------------------------------------------
def point_disk_distance(
    p: np.ndarray, c: np.ndarray, n: np.ndarray, a: np.ndarray | float
) -> np.ndarray:
    """Distance from points ``p`` to disks (centre ``c``, unit normal ``n``, radius ``a``),
    broadcast row by row (``(..., 3)`` arrays).

    ``d = p - c``, height ``h = d . n``, in-plane part ``q = d - h n`` of length ``rho``: the
    nearest disk point is ``c + q`` if ``rho <= a`` (distance ``|h|``), else the rim point
    ``c + a q / rho`` (distance ``sqrt(h^2 + (rho - a)^2)``). Written in the Rust core's order
    of operations (no FMA), so both give the same bits.
    """
    d = p - c
    h = d[..., 0] * n[..., 0] + d[..., 1] * n[..., 1] + d[..., 2] * n[..., 2]
    q = d - h[..., None] * n
    rho = np.sqrt(q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    t = rho - a
    return np.where(rho <= a, np.abs(h), np.sqrt(h * h + t * t))


def point_cylinder_distance(
    p: np.ndarray, a: np.ndarray, u: np.ndarray, length: np.ndarray | float, r: np.ndarray | float
) -> np.ndarray:
    """Distance from points ``p`` to solid capped cylinders (axis from ``a`` along the unit
    ``u`` for ``length``, radius ``r``; 0 inside), broadcast row by row.

    ``d = p - a``, axial ``s = d . u``, distance from the axis ``rho = |d - s u|``; the axial
    excess ``e = max(-s, s - length, 0)`` and radial ``t = max(rho - r, 0)`` give
    ``sqrt(e^2 + t^2)``. Written in the Rust core's order of operations."""
    d = p - a
    s = d[..., 0] * u[..., 0] + d[..., 1] * u[..., 1] + d[..., 2] * u[..., 2]
    q = d - s[..., None] * u
    rho = np.sqrt(q[..., 0] * q[..., 0] + q[..., 1] * q[..., 1] + q[..., 2] * q[..., 2])
    e = np.maximum(np.maximum(-s, s - length), 0.0)
    t = np.maximum(rho - r, 0.0)
    return np.sqrt(e * e + t * t)


def _nearest(dist_fn, n: int, pts: np.ndarray, chunk: int) -> tuple[np.ndarray, np.ndarray]:
    """Per point, the least of ``dist_fn(points (m,1,3)) -> (m, n)`` and its first index."""
    dist = np.full(len(pts), np.inf)
    index = np.zeros(len(pts), dtype=np.int64)
    step = max(1, chunk // max(n, 1))
    for s in range(0, len(pts), step):
        d = dist_fn(pts[s : s + step, None, :])
        k = np.argmin(d, axis=1)  # the first of equal minima: the smallest index
        dist[s : s + step] = d[np.arange(len(k)), k]
        index[s : s + step] = k
    return dist, index


def clearance(scene: Any, points: Any, chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Per point (n, 3), the distance (m) to the nearest leaf disk or branch cylinder of
    ``scene`` and its index: the leaf's (the smallest among equally near leaves), or
    ``-1 - j`` for branch ``j`` (a leaf first at equal distance), by testing every one."""
    leaves, branches = _parts(scene)
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    dist = np.full(len(pts), np.inf)
    index = np.zeros(len(pts), dtype=np.int64)
    if leaves is not None:
        c, nv, a = leaves.centers, leaves.normals, leaves.radii
        dist, index = _nearest(
            lambda q: point_disk_distance(q, c[None], nv[None], a[None]), len(c), pts, chunk
        )
    if branches is not None:
        st = branches.starts
        d = branches.ends - st
        length = np.sqrt(_dot(d, d))
        u = d / length[:, None]
        r = branches.radii
        wd, wi = _nearest(
            lambda q: point_cylinder_distance(q, st[None], u[None], length[None], r[None]),
            len(r),
            pts,
            chunk,
        )
        wood = wd < dist
        dist = np.where(wood, wd, dist)
        index = np.where(wood, -1 - wi, index)
    return dist, index


__all__ = [
    "clearance",
    "leaf_sights",
    "lobe_members",
    "point_cylinder_distance",
    "point_disk_distance",
    "simulate",
]
