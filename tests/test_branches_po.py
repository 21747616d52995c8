"""Branch echoes against an independent physical-optics quadrature (docs/model.md §9): the
Kirchhoff integral over the lit side of a rigid cylinder, summed numerically on a converged
Gauss-Legendre grid, against the closed form (amplitude, sign, phase constant pi/4 at the near
surface) and against the library's spectrum of a long segment cut into pieces near the sonar.

Physical optics in the library's conventions (time factor exp(jwt): a delay tau is
exp(-jw tau), docs/model.md §5). A rigid body scatters p_s(x) = integral of p dG0/dn over its
surface, G0 = exp(-jkR)/(4 pi R), n the outward normal, with p = 2 p_i on the lit side and 0 in
its shadow. A point source at the sonar, p_i = exp(-jkR)/R, is heard back at the sonar with
dG0/dn = (jk + 1/R) |n.e| G0 on the lit side (e the unit vector from the sonar to the surface);
to leading order in 1/(kR), the model's own order,

    echo = (jk / 2 pi) integral_lit |n.e| exp(-2jkR) / R^2 dA,                          (1)

times the sonar's gain g and two-way beam gain G = S^2 (§2) where the beam is not flat. In the
far field R = r + e.(y - x0), so echo = f exp(-2jkr) / r^2 with

    f = (jk / 2 pi) integral_lit |n.e| exp(-2jk e.(y - x0)) dA,                          (2)

the library's f: A = g G |f| / r^2 and f = |f| exp(-j psi) (§5). For a flat disk at normal
incidence (2) is f = j k a^2 / 2: |f| = k a^2 / 2, L = k |f| = c^2 / 2 and psi = -pi/2, §4's
physical-optics leaf. That is the first check of the integral below.

The tolerances. Over a cylinder's lit half (2) factorises: l sinc(k l sin(gamma)) along the axis
(exact) times a cos(gamma) I(kappa), I = integral over |phi| < pi/2 of
cos(phi) exp(-j kappa (1 - cos(phi))), kappa = 2 k a cos(gamma). Hankel's expansion of J1 gives
I = sqrt(2 pi / kappa) exp(-j pi/4) (1 + 3j/(8 kappa) + O(kappa^-2)), and the shadow boundaries
add (2 / sqrt(2 pi)) kappa^-3/2 at most. The closed form is the leading term, so
f_PO / f_model = 1 + 3j/(8 kappa) + O(kappa^-3/2): the amplitude agrees to kappa^-3/2, the phase
is pi/4 plus 3/(8 kappa) to kappa^-3/2. Near the sonar the spherical wave adds the path
a^2 phi^2 / (2r) each way round the circumference, which shrinks the echo by
D = (1 + a / (r cos(gamma)))^(-1/2) (§9) and changes the O(1/kappa) terms' coefficients (up to
about 0.5 / (k a) measured at a / r = 0.27); there we allow the whole first neglected order,
1 / (k a cos(gamma)), with gamma the tilt at the echo's dominant point.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from scipy.special import j1, roots_legendre

import batecho
from batecho import Branches, Poses, Scene, Sonar, reference
from batecho.reference.branches import _cylinder_po
from batecho.reference.leaves import _leaf_physical_optics

ORIGIN = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])  # forward x, left y, up z
# every piece in front of the sonar counts; a flat spectrum window, so Y is the echo itself
SONAR = Sonar(beamwidth_deg=40.0, window="rect", lobe="cone", cone_half_angle_deg=89.0)
PSI_CYLINDER = -math.pi / 4  # docs/model.md §9
K_60KHZ = 2.0 * math.pi * 60e3 / SONAR.sound_speed


# ------------------------------------------------------------------------- quadrature


def gauss_panels(lo: float, hi: float, n_panels: int, order: int = 16):
    """Nodes and weights of composite Gauss-Legendre on [lo, hi]."""
    x, w = roots_legendre(order)
    edges = np.linspace(lo, hi, n_panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[:-1] + edges[1:])
    return (mid[:, None] + half[:, None] * x).ravel(), (half[:, None] * w).ravel()


def panels_for(phase_span_rad: float, per_panel_rad: float) -> int:
    """Enough panels of order 16 that each spans at most ``per_panel_rad`` of phase."""
    return max(4, math.ceil(phase_span_rad / per_panel_rad))


def po_far(k, pts, normals, dA, e, x0) -> complex:
    """(2): the far-field PO amplitude f (m) of the surface sampled by ``pts``, ``normals`` and
    area weights ``dA``, lit along the unit ``e`` (from the sonar), referred to ``x0``."""
    cos_i = -(normals @ e)
    lit = np.where(cos_i > 0.0, cos_i, 0.0)
    return complex(1j * k / (2.0 * np.pi) * np.sum(lit * np.exp(-2j * k * ((pts - x0) @ e)) * dA))


def disk_surface(a: float, n: np.ndarray, n_rho: int = 128, n_theta: int = 512):
    """A disk of radius a at the origin with unit normal n: GL in radius, the trapezoid rule
    (spectral for a periodic integrand) round it."""
    rho, w_rho = gauss_panels(0.0, a, n_rho // 16)
    theta = np.arange(n_theta) * (2.0 * np.pi / n_theta)
    e1 = np.cross(n, [0.3, 0.5, 0.7])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    R, T = (x.ravel() for x in np.meshgrid(rho, theta, indexing="ij"))
    pts = R[:, None] * (np.cos(T)[:, None] * e1 + np.sin(T)[:, None] * e2)
    dA = (np.repeat(rho * w_rho, n_theta)) * (2.0 * np.pi / n_theta)
    return pts, np.broadcast_to(n, pts.shape), dA


def cylinder_lit_half(k, a, length, u, centre, toward, per_panel_rad):
    """The side of a cylinder (unit axis u, radius a) facing the unit ``toward`` (across the
    axis), sampled for wavenumber k: the lit half |theta| < pi/2 of a plane wave from there."""
    side = np.cross(u, toward)
    theta, w_t = gauss_panels(-np.pi / 2, np.pi / 2, panels_for(2 * k * a, per_panel_rad))
    z, w_z = gauss_panels(-length / 2, length / 2, panels_for(2 * k * length, per_panel_rad))
    T, Z = (x.ravel() for x in np.meshgrid(theta, z, indexing="ij"))
    normals = np.cos(T)[:, None] * toward + np.sin(T)[:, None] * side
    pts = centre + Z[:, None] * u + a * normals
    return pts, normals, a * np.outer(w_t, w_z).ravel()


def two_way_gain(sonar: Sonar, d: np.ndarray) -> np.ndarray:
    """G = S^2 of §2 for directions d from the sonar at ORIGIN (the beam centred, unrotated)."""
    az = np.arctan2(d[..., 1], d[..., 0])
    el = np.arctan2(d[..., 2], np.hypot(d[..., 0], d[..., 1]))
    s_az, s_el = sonar.beam.sigmas_rad
    return np.exp(-(az**2 / s_az**2 + el**2 / s_el**2))


def po_echo(k: float, sonar: Sonar, start, end, a: float, per_panel_rad=2 * np.pi) -> complex:
    """(1) times g and G: the echo at wavenumber k of the segment start-end (radius a) heard by
    the sonar at ORIGIN, over the strip lit from there, |theta| < arccos(a / rho) about the
    perpendicular from the axis line (rho its length), the same strip all along the axis."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    length = float(np.linalg.norm(end - start))
    u = (end - start) / length
    centre = 0.5 * (start + end)
    w = centre - (centre @ u) * u
    rho = float(np.linalg.norm(w))
    toward, side = -w / rho, np.cross(u, -w / rho)
    lit = math.acos(a / rho)
    ranges = [np.linalg.norm(x) for x in (start, end)] + [rho - a]
    theta, w_t = gauss_panels(-lit, lit, panels_for(2 * k * a, per_panel_rad))
    span = 2 * k * (max(ranges) - min(ranges)) + 2 * k * a
    z, w_z = gauss_panels(-length / 2, length / 2, panels_for(span, per_panel_rad))
    total = 0j
    chunks = -(-z.size // 256)  # (a few MB at a time)
    for zs, wzs in zip(np.array_split(z, chunks), np.array_split(w_z, chunks), strict=True):
        n = np.cos(theta)[:, None, None] * toward + np.sin(theta)[:, None, None] * side
        n = np.broadcast_to(n, (theta.size, zs.size, 3))
        d = centre + zs[None, :, None] * u + a * n  # from the sonar at the origin
        R = np.linalg.norm(d, axis=-1)
        cos_i = np.maximum(-np.sum(n * d, axis=-1) / R, 0.0)
        integrand = cos_i * two_way_gain(sonar, d) * np.exp(-2j * k * R) / R**2
        total += np.sum(integrand * (a * np.outer(w_t, wzs)))
    return sonar.gain * 1j * k / (2.0 * np.pi) * total


# --------------------------------------------------------- the flat disk (normalisation)


def disk_ratio(beta: float, k: float = 1300.0, a: float = 0.02) -> tuple[complex, complex]:
    """The quadrature's f and the §4 physical-optics leaf's L exp(-j psi) / k at incidence
    beta (the normal +z faces the sonar)."""
    e = np.array([math.sin(beta), 0.0, -math.cos(beta)])
    f_po = po_far(k, *disk_surface(a, np.array([0.0, 0.0, 1.0])), e, np.zeros(3))
    c, cb, sb = (np.array(x) for x in (k * a, math.cos(beta), math.sin(beta)))
    L, psi = _leaf_physical_optics(c, np.array(beta), cb, sb)
    return f_po, complex(L / k * np.exp(-1j * psi))


def test_the_quadrature_of_a_disk_at_normal_incidence_is_j_k_a_squared_over_2():
    k, a = 1300.0, 0.02
    f_po, f_leaf = disk_ratio(0.0, k, a)
    # (a polynomial in the radius, which Gauss-Legendre integrates exactly)
    assert abs(f_po - 1j * k * a * a / 2) <= 1e-12 * k * a * a
    assert abs(f_leaf - f_po) <= 1e-12 * abs(f_po)  # the leaves' L = c^2/2, psi = -pi/2


@pytest.mark.parametrize("beta_deg", [1.0, 2.0, 3.0])
def test_on_its_main_lobe_the_disk_quadrature_is_the_physical_optics_leaf(beta_deg):
    f_po, f_leaf = disk_ratio(math.radians(beta_deg))  # 2 c sin(beta) below 3.83, J1's zero
    assert abs(f_leaf - f_po) <= 1e-10 * abs(f_po)


def test_beyond_the_first_zero_of_j1_the_disk_quadrature_changes_sign():
    beta = math.radians(5.0)  # x = 2 c sin(beta) = 4.53, J1's first sidelobe
    f_po, _ = disk_ratio(beta)
    x = 2.0 * 1300.0 * 0.02 * math.sin(beta)
    want = 1j * 1300.0 * 0.02**2 / 2 * math.cos(beta) * 2.0 * j1(x) / x  # negative
    assert abs(f_po - want) <= 1e-10 * abs(want)


@pytest.mark.xfail(
    strict=True,
    reason="the physical-optics leaf takes |2 J1(x)/x| with psi = -pi/2, as the model states "
    "it (docs/model.md §4); physical optics is signed, and between J1's first two zeros the "
    "echo's sign is flipped",
)
def test_beyond_the_first_zero_of_j1_the_physical_optics_leaf_changes_sign():
    f_po, f_leaf = disk_ratio(math.radians(5.0))
    assert abs(f_leaf - f_po) <= 1e-10 * abs(f_po)


# ------------------------------------------------ one cylinder in the far field, (2)


def far_cases():
    """(ka, kl, tilt): broadside, on the sinc's main lobe and first two sidelobes
    (k l sin(gamma) = 1.5, 4.49, 7.73), and steeper."""
    cases = []
    for ka in (10.0, 30.0, 100.0):
        for kl in (20.0, 100.0):
            for label, x in (("main lobe", 1.5), ("sidelobe 1", 4.49), ("sidelobe 2", 7.73)):
                cases.append(
                    pytest.param(ka, kl, math.asin(x / kl), id=f"ka{ka:g}-kl{kl:g}-{label}")
                )
            for g in (0.0, 20.0, 45.0, 60.0):
                cases.append(
                    pytest.param(ka, kl, math.radians(g), id=f"ka{ka:g}-kl{kl:g}-{g:g}deg")
                )
    return cases


@functools.cache
def far_ratio(ka: float, kl: float, gamma: float, per_panel_rad: float = 2 * np.pi):
    """f_PO / f_model for a cylinder in a random orientation (fixed seed), and kappa."""
    rng = np.random.default_rng(7)
    k = 1300.0
    a, length = ka / k, kl / k
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    m = np.cross(u, rng.normal(size=3))
    m /= np.linalg.norm(m)  # across the axis, towards the sonar
    e = -math.cos(gamma) * m + math.sin(gamma) * u  # from the sonar, tilted gamma from broadside
    centre = rng.normal(size=3)
    x0 = centre + a * m  # the near surface at the centre: the model's reference point
    surface = cylinder_lit_half(k, a, length, u, centre, m, per_panel_rad)
    f_po = po_far(k, *surface, e, x0)
    f_model = _cylinder_po(k, a, length, math.cos(gamma), math.sin(gamma))
    return f_po / (f_model * np.exp(-1j * PSI_CYLINDER)), 2.0 * ka * math.cos(gamma)


def test_the_cylinder_quadrature_is_converged():
    coarse, _ = far_ratio(100.0, 100.0, math.radians(60.0))
    fine, _ = far_ratio(100.0, 100.0, math.radians(60.0), per_panel_rad=np.pi / 2)
    assert abs(fine - coarse) <= 1e-10


@pytest.mark.parametrize(("ka", "kl", "gamma"), far_cases())
def test_the_amplitude_is_physical_optics_to_order_kappa_to_the_minus_three_halves(ka, kl, gamma):
    ratio, kappa = far_ratio(ka, kl, gamma)
    assert abs(abs(ratio) - 1.0) <= kappa**-1.5


@pytest.mark.parametrize(("ka", "kl", "gamma"), far_cases())
def test_the_phase_at_the_near_surface_is_pi_over_4_plus_hankels_3_over_8_kappa(ka, kl, gamma):
    # (also the sinc's sign: a sidelobe's pi would show here)
    ratio, kappa = far_ratio(ka, kl, gamma)
    assert abs(np.angle(ratio) - 3.0 / (8.0 * kappa)) <= kappa**-1.5


# ------------------------------------------------------------ the library's spectrum


def rust_simulate(scene, sonar, pose):
    return batecho.simulate(scene, sonar, pose, method="exact")


BOTH = [pytest.param(reference.simulate, id="reference"), pytest.param(rust_simulate, id="rust")]


def near_surface_piece(r_near: float, a: float, length: float, gamma: float):
    """A piece whose near surface at its centre lies at r_near on the beam's axis, its axis
    tilted by gamma from broadside in the x-z plane: (start, end, a)."""
    u = np.array([math.sin(gamma), 0.0, math.cos(gamma)])
    centre = np.array([r_near + a * math.cos(gamma), 0.0, -a * math.sin(gamma)])
    return centre - 0.5 * length * u, centre + 0.5 * length * u, a


def dominant_cos_tilt(start, end, a: float) -> float:
    """cos(gamma) at the echo's dominant point: the point of the near surface line nearest the
    sonar at ORIGIN (the specular point, or the nearer end where the segment holds none)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    u = (end - start) / np.linalg.norm(end - start)
    t = min(max(-(start @ u), 0.0), float(np.linalg.norm(end - start)))
    x = start + t * u
    along = x @ u
    across = math.sqrt(max(x @ x - along * along, 0.0)) - a
    return across / math.hypot(across, along)


# one piece 8 m ahead (k l <= 17 keeps it one): broadside, on the main lobe, and tilted so that
# the whole band lies on the sinc's first (negative) sidelobe, 3.5 <= k l sin(gamma) <= 4.7
ONE_PIECE = {
    "broadside": near_surface_piece(8.0, 0.05, 0.011, 0.0),
    "main lobe": near_surface_piece(8.0, 0.05, 0.011, math.radians(5.0)),
    "sidelobe 1": near_surface_piece(8.0, 0.05, 0.011, math.asin(3.5 / (K_60KHZ * 0.011))),
}


@functools.cache
def one_piece_quadrature(name: str):
    start, end, a = ONE_PIECE[name]
    k_band = 2.0 * np.pi * SONAR.freqs / SONAR.sound_speed
    bins = np.linspace(0, k_band.size - 1, 3).round().astype(int)
    return bins, np.array([po_echo(k, SONAR, start, end, a) for k in k_band[bins]])


@pytest.mark.parametrize("simulate", BOTH)
@pytest.mark.parametrize("name", list(ONE_PIECE))
def test_one_pieces_spectrum_has_the_quadratures_amplitude_to_kappa_to_the_minus_three_halves(
    simulate, name
):
    start, end, a = ONE_PIECE[name]
    echoes = simulate(Scene(None, branches=Branches([start], [end], [a])), SONAR, ORIGIN)
    assert echoes.n_pieces.tolist() == [1]
    bins, want = one_piece_quadrature(name)
    got = echoes.spectrum[0][bins]
    k = 2.0 * np.pi * echoes.freqs[bins] / SONAR.sound_speed
    kappa = 2.0 * k * a * dominant_cos_tilt(start, end, a)
    assert np.all(np.abs(np.abs(got / want) - 1.0) <= kappa**-1.5)


@pytest.mark.parametrize("simulate", BOTH)
@pytest.mark.parametrize("name", list(ONE_PIECE))
def test_one_pieces_spectrum_has_the_quadratures_phase_and_delay(simulate, name):
    # the near surface's delay and psi = -pi/4 in the library's time convention, to the first
    # order the closed form leaves out, 1/(k a cos(gamma)) (Hankel's 3/(8 kappa) among it; on
    # the sidelobe most of it is the piece's mean Fresnel lag, exact only at broadside). The
    # axis's delay would be 2 k a cos(gamma) = kappa (over 100 rad) off, psi = +pi/4 pi/2 off
    # and a sinc without its sign pi off.
    start, end, a = ONE_PIECE[name]
    echoes = simulate(Scene(None, branches=Branches([start], [end], [a])), SONAR, ORIGIN)
    bins, want = one_piece_quadrature(name)
    k = 2.0 * np.pi * echoes.freqs[bins] / SONAR.sound_speed
    dphi = np.angle(echoes.spectrum[0][bins] / want)
    assert np.all(np.abs(dphi) <= 1.0 / (k * a * dominant_cos_tilt(start, end, a)))


# long segments near the sonar, cut into hundreds of pieces, against one quadrature of the whole
# (without D the first three are 2.7 %, 12.8 % and 1.9 % off, beyond 1/(ka) at some bins)
SEGMENTS = {
    "thin, broadside, 1 m": ([1.0, 0.0, -0.6], [1.0, 0.0, 0.6], 0.05),
    "trunk, broadside, 0.55 m": ([0.7, 0.0, -0.4], [0.7, 0.0, 0.4], 0.15),
    "tilted across the beam": ([1.0, -0.2, -0.5], [1.3, 0.2, 0.5], 0.04),
    "no specular point": ([1.0, 0.1, 0.2], [1.6, 0.3, 0.6], 0.03),
}
SEGMENT_CASES = [
    pytest.param(name, simulate, id=f"{name}-{impl}")
    for name in SEGMENTS
    for impl, simulate in (("reference", reference.simulate), ("rust", rust_simulate))
]


def test_the_near_field_quadrature_is_converged():
    name = "thin, broadside, 1 m"
    start, end, a = SEGMENTS[name]
    _, k, coarse = segment_quadrature(name)  # (the grid the tests use: 2 pi per panel)
    fine = po_echo(k[-1], SONAR, start, end, a, per_panel_rad=np.pi)
    assert abs(fine - coarse[-1]) <= 1e-10 * abs(coarse[-1])


@functools.cache
def segment_quadrature(name: str):
    start, end, a = SEGMENTS[name]
    k_band = 2.0 * np.pi * SONAR.freqs / SONAR.sound_speed
    bins = np.linspace(0, k_band.size - 1, 3).round().astype(int)
    return bins, k_band[bins], np.array([po_echo(k, SONAR, start, end, a) for k in k_band[bins]])


@pytest.mark.parametrize(("name", "simulate"), SEGMENT_CASES)
def test_the_pieces_of_a_near_segment_sum_to_its_quadrature_to_order_1_over_ka(name, simulate):
    start, end, a = SEGMENTS[name]
    echoes = simulate(Scene(None, branches=Branches([start], [end], [a])), SONAR, ORIGIN)
    assert echoes.n_pieces[0] > 100  # not in the far field of the whole segment
    bins, k, want = segment_quadrature(name)
    got = echoes.spectrum[0][bins]
    tol = 1.0 / (k * a * dominant_cos_tilt(start, end, a))
    assert np.all(np.abs(got / want - 1.0) <= tol)


SPECULAR_CASES = [
    pytest.param(name, simulate, id=f"{name}-{impl}")
    for name in list(SEGMENTS)[:3]  # (the last has no specular point)
    for impl, simulate in (("reference", reference.simulate), ("rust", rust_simulate))
]


@pytest.mark.parametrize(("name", "simulate"), SPECULAR_CASES)
def test_with_a_specular_point_the_pieces_amplitude_is_the_quadratures_to_a_thousandth(
    name, simulate
):
    # kappa^-3/2 at the specular point (gamma = 0), plus the thousandth of a broadside echo to
    # which the pieces' rule holds a segment's echo (docs/model.md §9)
    start, end, a = SEGMENTS[name]
    echoes = simulate(Scene(None, branches=Branches([start], [end], [a])), SONAR, ORIGIN)
    bins, k, want = segment_quadrature(name)
    got = echoes.spectrum[0][bins]
    assert np.all(np.abs(np.abs(got / want) - 1.0) <= (2.0 * k * a) ** -1.5 + 1e-3)
