"""Branches as scatterers (docs/model.md §9): physical optics of a rigid finite cylinder with the
leaves' normalisation. At broadside the amplitude is (L/2) sqrt(k a / pi) times the near-field
factor D = (1 + a / (r cos(gamma)))^(-1/2); the delay is that of the near surface and the phase
the stationary-phase constant pi/4; the sin(x)/x pattern follows the tilt; end-on a branch is
far quieter; the pieces' rule does not change the echo beyond a stated tolerance; the Rust core
equals the reference and the fast method stays within tol; bad input is refused by name. (The
closed form against a direct quadrature of the Kirchhoff integral: tests/test_branches_po.py.)"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _helpers import rel_err
from _strategies import sonars
from hypothesis import given
from hypothesis import strategies as st

import batecho
from batecho import Branches, Leaves, Poses, Scene, Sonar, reference

ORIGIN = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
RECT = Sonar(beamwidth_deg=30.0, window="rect")


def wavenumbers(sonar: Sonar) -> np.ndarray:
    return 2.0 * np.pi * sonar.freqs / sonar.sound_speed


def tilted(r_near: float, a: float, length: float, gamma: float) -> Branches:
    """A cylinder whose near surface at its centre lies at range ``r_near`` on the x axis, its
    axis tilted by ``gamma`` from broadside, towards the sonar (in the x-z plane)."""
    u = np.array([math.sin(gamma), 0.0, math.cos(gamma)])
    centre = np.array([r_near, 0.0, 0.0]) + a * np.array([math.cos(gamma), 0.0, -math.sin(gamma)])
    return Branches([centre - 0.5 * length * u], [centre + 0.5 * length * u], [a])


def wood(branches: Branches, sonar: Sonar = RECT, pose: Poses = ORIGIN):
    return batecho.simulate(Scene(None, branches=branches), sonar, pose, method="exact")


# ------------------------------------------------------------------------- one piece


def test_at_broadside_the_amplitude_is_half_the_length_times_sqrt_ka_over_pi_times_d():
    r0, a, length = 8.0, 0.05, 0.011  # one piece
    e = wood(tilted(r0, a, length, 0.0))
    assert e.n_pieces.tolist() == [1]
    k = wavenumbers(RECT)
    # A = g G |f| D / r^2 with G = 1 on the axis: the leaves' normalisation, L = k |f|
    D = (1.0 + a / r0) ** -0.5
    want = RECT.gain * 0.5 * length * np.sqrt(k * a / np.pi) * D / r0**2
    np.testing.assert_allclose(np.abs(e.spectrum[0]), want, rtol=1e-12)


def test_the_delay_is_that_of_the_near_surface_and_the_phase_is_pi_over_4():
    r0, a, length = 2.0, 0.15, 0.005  # one piece
    e = wood(tilted(r0, a, length, 0.0))
    f = e.freqs
    # the near surface's range plus the piece's mean Fresnel lag l^2 cos^2(gamma) / (24 r)
    r = r0 + length**2 / (24.0 * r0)
    cycles = f * 2.0 * r / RECT.sound_speed
    # Y_k = A_k exp(j (-2 k r + pi/4)): the near surface's delay, psi = -pi/4
    phase = np.exp(1j * (np.pi / 4 - 2 * np.pi * (cycles - np.round(cycles))))
    assert rel_err(e.spectrum[0], np.abs(e.spectrum[0]) * phase) <= 1e-9
    env = e.envelope()[0]
    peak = e.ranges[np.argmax(env)]
    assert abs(peak - r0) < 1e-3  # the near surface, not the axis 15 cm behind it


@pytest.mark.parametrize("gamma_deg", [0.5, 1.5, 3.0, 3.5, 5.0, 12.0, 30.0])
def test_the_sinc_pattern_follows_the_tilt(gamma_deg):
    r0, a, length = 8.0, 0.05, 0.011  # one piece; k l sin(gamma) passes pi near 11 degrees
    g = math.radians(gamma_deg)
    br = tilted(r0, a, length, g)
    e = wood(br)
    assert e.n_pieces.tolist() == [1]
    # the reference point (the near surface at the centre) lies on the beam's axis at r0, where
    # G = 1, and the tilt seen from it is gamma
    sin_g, cos_g = math.sin(g), math.cos(g)
    k = wavenumbers(RECT)
    x = k * length * sin_g
    D = (1.0 + a / (r0 * cos_g)) ** -0.5
    want = RECT.gain * 0.5 * length * np.sqrt(k * a * cos_g / np.pi) * np.abs(np.sin(x) / x)
    want *= D / r0**2
    broadside = RECT.gain * 0.5 * length * np.sqrt(k * a / np.pi) / r0**2
    np.testing.assert_allclose(np.abs(e.spectrum[0]), want, rtol=1e-9, atol=1e-9 * broadside.max())


def test_end_on_a_branch_is_far_quieter_than_at_broadside():
    a, length = 0.05, 0.5
    broad = wood(tilted(2.0, a, length, 0.0))
    near_end_on = wood(tilted(2.0, a, length, math.radians(80.0)))
    energy = lambda e: float(np.sum(np.abs(e.spectrum) ** 2))
    assert energy(near_end_on) < 1e-3 * energy(broad)  # more than 30 dB quieter
    # exactly end-on only the flat end is lit, which the model leaves out: no echo
    end_on = wood(Branches([[2.0, 0.0, 0.0]], [[2.5, 0.0, 0.0]], [a]))
    assert end_on.n_pieces.tolist() == [0]
    assert not end_on.spectrum.any()


# -------------------------------------------------------------------- the piece rule


SEGMENTS = {
    "trunk": ([1.2, -0.3, -2.0], [1.6, 0.2, 3.0], 0.12),  # close by, across the beam
    "slanting": ([3.0, -1.0, 0.2], [6.0, 1.5, -0.4], 0.05),  # long, no specular point
    "steep": ([0.8, 0.0, 0.0], [2.0, 0.05, 0.9], 0.03),  # near, steeply tilted
}
PIECE_SONAR = Sonar(beamwidth_deg=40.0)


def broadside_twin(segment) -> Branches:
    """The same cylinder turned to broadside, its near surface as far as the segment's axis
    line lies from the sonar."""
    s, e, a = (np.asarray(x, dtype=np.float64) for x in segment)
    length = float(np.linalg.norm(e - s))
    axis_distance = float(np.linalg.norm(np.cross(s, e - s))) / length
    return tilted(axis_distance - float(a), float(a), length, 0.0)


@pytest.mark.parametrize("scale", [0.5, 0.25, 0.125])
@pytest.mark.parametrize("name", list(SEGMENTS))
def test_refining_the_pieces_moves_the_echo_by_under_a_thousandth_of_its_broadside_echo(
    scale, name
):
    br = Branches(*([x] for x in SEGMENTS[name]))
    coarse = wood(br, PIECE_SONAR)
    fine = wood(br, PIECE_SONAR.replace(branch_piece_scale=scale))
    assert fine.n_pieces[0] > coarse.n_pieces[0]
    twin = wood(broadside_twin(SEGMENTS[name]), PIECE_SONAR)
    moved = np.linalg.norm(fine.spectrum - coarse.spectrum)
    assert moved <= 1e-3 * np.linalg.norm(twin.spectrum)


@pytest.mark.parametrize("scale", [0.5, 0.25, 0.125])
def test_refining_the_pieces_moves_a_trunks_echo_by_under_a_thousandth(scale):
    br = Branches(*([x] for x in SEGMENTS["trunk"]))
    coarse = wood(br, PIECE_SONAR)
    fine = wood(br, PIECE_SONAR.replace(branch_piece_scale=scale))
    assert rel_err(coarse.spectrum, fine.spectrum) <= 1e-3


def test_a_long_branch_is_cut_into_pieces_no_longer_than_the_rule():
    # k_max l^2 / (4 r) <= pi / 512 at the near distance r, and l <= sigma r / 32
    sonar = Sonar(beamwidth_deg=40.0, lobe="cone", cone_half_angle_deg=80.0)
    br = Branches([[2.0, 0.0, -2.0]], [[2.0, 0.0, 2.0]], [0.05])
    e = wood(br, sonar)
    k_max = 2 * np.pi * sonar.freqs[-1] / sonar.sound_speed
    sigma = sonar.beam.sigmas_rad[0]
    r = 2.0 - 0.05
    longest = min(math.sqrt(4 * r * (math.pi / 512) / k_max), sigma * r / 32)
    assert e.n_pieces[0] == math.ceil(4.0 / longest)


# ---------------------------------------------------------- against the reference


@st.composite
def branch_cases(draw):
    sonar = draw(sonars())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    k = draw(st.integers(1, 12))
    reach = min(sonar.record_range_m, 9.0)
    start = np.column_stack(
        [rng.uniform(0.5, reach, k), rng.uniform(-2, 2, k), rng.uniform(-2, 2, k)]
    )
    d = rng.normal(size=(k, 3))
    d *= (rng.uniform(0.02, 2.0, k) / np.linalg.norm(d, axis=1))[:, None]
    radii = rng.uniform(0.01, 0.2, k)
    # a few joined into a skeleton, one exactly end-on, one at broadside
    start[k // 2 :] = np.where(rng.random((k - k // 2, 1)) < 0.5, start[k // 2 :], start[0] + d[0])
    if draw(st.booleans()):
        d[0] = start[0] / np.linalg.norm(start[0]) * 0.3
    leaves = None
    if draw(st.booleans()):
        n = draw(st.integers(1, 60))
        c = np.column_stack([rng.uniform(0.5, reach, n), rng.uniform(-2, 2, (n, 2))])
        leaves = Leaves(c, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.05, n))
    return sonar.replace(too_close="skip"), Scene(
        leaves, branches=Branches(start, start + d, radii)
    )


@given(branch_cases(), st.sampled_from([1e-3, 1e-6, 1e-9, 1e-12]))
def test_branch_echoes_equal_the_reference_and_the_fast_method_stays_within_tol(case, tol):
    sonar, scene = case
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    want = reference.simulate(scene, sonar, pose)
    got = batecho.simulate(scene, sonar, pose, method="exact")
    assert np.array_equal(got.n_pieces, want.n_pieces)
    # (the pieces of a segment cancel at their shared edges, so the sum can be far smaller
    # than its terms, and its rounding error relatively larger than a leaf sum's)
    assert rel_err(got.wood_spectrum, want.wood_spectrum) <= 1e-8
    assert rel_err(got.spectrum, want.spectrum) <= 1e-8
    for method in ("fast", "auto"):
        fast = batecho.simulate(scene, sonar, pose, method=method, tol=tol)
        assert rel_err(fast.spectrum, got.spectrum) <= tol


# ----------------------------------------------------------------------- bad input


def test_branches_copy_the_callers_arrays_and_leave_them_unchanged():
    s = np.array([[0.0, 0.0, 0.0]])
    e = np.array([[0.0, 0.0, 1.0]])
    r = np.array([0.1])
    br = Branches(s, e, r)
    s[0, 0] = 5.0
    assert br.starts[0, 0] == 0.0
    assert not br.starts.flags.writeable
    assert r.flags.writeable and s.flags.writeable


@pytest.mark.parametrize(
    ("args", "error", "needle"),
    [
        (([[0, 0, 0]], [[0, 0, 0]], [0.1]), ValueError, "branch 0 has zero length"),
        (([[0, 0, 0], [1, 1, 1]], [[0, 0, 1], [1, 1, 2]], [0.1, -1]), ValueError, "branch 1"),
        (([[0, np.nan, 0]], [[0, 0, 1]], [0.1]), ValueError, "starts must be finite"),
        (([[0, 0, 0]], [[0, 0, 1], [0, 0, 2]], [0.1]), ValueError, "ends has 2 rows"),
        (([[0, 0, 0]], [[0, 0, 1]], [0.1, 0.2]), ValueError, "radii must have shape"),
        (([[0, 0]], [[0, 0]], [0.1]), ValueError, "starts must have shape"),
        ((np.zeros((0, 3)), np.zeros((0, 3)), []), ValueError, "at least one segment"),
        ((["a", "b", "c"], [[0, 0, 1]], [0.1]), TypeError, "starts must hold real numbers"),
    ],
)
def test_bad_branches_are_refused_by_name(args, error, needle):
    with pytest.raises(error, match=needle):
        Branches(*args)


def test_a_scene_needs_leaves_or_branches():
    with pytest.raises(ValueError, match="needs leaves, branches, or both"):
        Scene(None)
    with pytest.raises(TypeError, match="branches must be None or batecho.Branches"):
        Scene(Leaves([[1, 0, 0]], [[1, 0, 0]], [0.02]), branches=[[0, 0, 0]])  # type: ignore[arg-type]


def test_a_branch_too_close_to_a_pose_is_named_or_left_out():
    br = Branches(
        [[0.005, -1.0, 0.0], [3.0, -1.0, 0.0]],
        [[0.005, 1.0, 0.0], [3.0, 1.0, 0.0]],
        [0.001 + 0.002, 0.05],
    )
    with pytest.raises(ValueError, match="branch 0"):
        wood(br, Sonar(min_ka=0.0))
    e = wood(br, Sonar(min_ka=0.0, too_close="skip"))
    assert e.n_pieces[0] > 0
    inside = Branches([[-1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.2])
    with pytest.raises(ValueError, match="lies inside branch 0"):
        wood(inside, Sonar())


def test_a_branch_thinner_than_min_ka_allows_is_refused_by_name():
    br = Branches(
        [[2.0, 0.0, -1.0], [2.0, 0.3, -1.0]], [[2.0, 0.0, 1.0], [2.0, 0.3, 1.0]], [0.05, 3e-4]
    )
    with pytest.raises(ValueError, match="branch 1 has radius"):
        wood(br, Sonar())


@pytest.mark.parametrize("ears", [False, True])
def test_a_trunk_far_longer_than_the_lobe_counts_the_reference_pieces(ears):
    # a 12 m trunk 2 m ahead of a narrow beam: the core skips whole spans of pieces outside the
    # lobe, and must count exactly the pieces the reference tests one by one
    trunk = Scene(None, branches=Branches([[2.0, 0.1, -6.0]], [[2.0, 0.1, 6.0]], [0.08]))
    sonar = Sonar(beamwidth_deg=20.0)
    if ears:
        sonar = Sonar.binaural(0.05, 10.0, beamwidth_deg=20.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.2])
    want = reference.simulate(trunk, sonar, pose)
    got = batecho.simulate(trunk, sonar, pose, method="exact")
    np.testing.assert_array_equal(got.n_pieces, want.n_pieces)
    assert np.min(got.n_pieces) > 0
    assert rel_err(got.wood_spectrum, want.wood_spectrum) <= 1e-8


def test_a_branch_radius_beyond_the_largest_coordinate_is_refused_naming_it():
    with pytest.raises(ValueError, match="radii must be at most 1e\\+15 m; branch 0"):
        Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [1e300])


@pytest.mark.parametrize(
    ("kw", "needle"),
    [
        ({"scale": 1e300}, "scale=1e\\+300"),
        ({"translation": (1e20, 0.0, 0.0)}, "beyond 1e\\+15 m"),
        ({"scale": 1e-300}, "zero length"),
    ],
)
def test_transformed_refuses_segments_moved_out_of_bounds_by_name(kw, needle):
    branches = Branches([[2.0, -1.0, 0.0]], [[2.0, 1.0, 0.0]], [0.05])
    with pytest.raises(ValueError, match=needle):
        branches.transformed(**kw)


def test_a_branch_whose_length_underflows_is_not_said_to_start_at_its_end():
    with pytest.raises(ValueError, match="zero length") as caught:
        Branches([[2.0, 0.0, 0.0]], [[2.0, 1e-200, 0.0]], [0.05])
    assert "equals" not in str(caught.value)


def test_a_pose_on_a_branchs_surface_is_said_to_be_0_m_from_it_not_minus_0():
    on_surface = Branches([[-1.0, 0.2, 0.0]], [[1.0, 0.2, 0.0]], [0.2])
    with pytest.raises(ValueError, match="lies inside branch 0 or on its surface") as err:
        wood(on_surface, Sonar())
    assert "-0.000" not in str(err.value)
    assert "0.000e0 m away" in str(err.value)
