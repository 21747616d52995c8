"""The fast method keeps its promise: relative L2 error of the spectrum at most ``tol`` against
the exact method, on generated scenes with the same hard cases as the exact path (normal and
grazing incidence, lobe-boundary leaves, radii 1 mm - 20 cm, ranges 5 cm - record edge,
many leaves at one range); ``auto`` too; and the same leaves count for both."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import frame_points, kinked_leaf_at_the_top, rel_err
from _strategies import cases
from hypothesis import given
from hypothesis import strategies as st

import batecho
from batecho import Leaves, Poses, Sonar, simulate

TOLS = [1e-3, 1e-6, 1e-9, 1e-12]


def assert_within_tol(leaves, sonar, pose, tol, method="fast"):
    exact = simulate(leaves, sonar, pose, method="exact")
    fast = simulate(leaves, sonar, pose, method=method, tol=tol)
    assert np.array_equal(fast.n_leaves, exact.n_leaves)
    assert rel_err(fast.spectrum, exact.spectrum) <= tol
    return exact, fast


@given(cases(), st.sampled_from(TOLS))
def test_fast_is_within_tol_of_exact_on_generated_scenes(case, tol):
    sonar, pose, leaves = case
    assert_within_tol(leaves, sonar, pose, tol)


@given(cases(), st.sampled_from(TOLS))
def test_auto_is_within_tol_of_exact_on_generated_scenes(case, tol):
    sonar, pose, leaves = case
    assert_within_tol(leaves, sonar, pose, tol, method="auto")


@given(
    st.integers(0, 2**32 - 1), st.integers(200, 3000), st.floats(0.3, 9.5), st.sampled_from(TOLS)
)
def test_fast_is_within_tol_with_many_leaves_at_one_range(seed, n, r, tol):
    rng = np.random.default_rng(seed)
    sonar = Sonar(beamwidth_deg=40.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    az, el = rng.uniform(-0.2, 0.2, n), rng.uniform(-0.2, 0.2, n)
    centers = frame_points(pose, np.full(n, r), az, el)
    leaves = Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.005, 0.05, n))
    assert_within_tol(leaves, sonar, pose, tol)


@given(
    st.floats(0.003, 0.05),
    st.integers(1, 300),
    st.floats(0.5, 9.5),
    st.booleans(),
    st.sampled_from([1e-9, 1e-11]),
)
def test_fast_is_within_tol_for_a_kinked_leaf_with_a_tiny_live_part(radius, live, r, atm, tol):
    # One paper-model leaf near grazing incidence whose corner (cos(B(c) beta) turning
    # positive) lies in the band's top `live` bins: its live values are ~1e-4 of the factor's
    # scale, where the cosine's rounding is ~1e-12 of them. (Not at 1e-12: there the exact sum
    # itself errs by up to ~1e-12 on such a leaf against mpmath: 3 mm, 82 live bins, with
    # absorption: exact 1.24e-12, fast 6e-14, the two 1.3e-12 apart.)
    sonar = Sonar(beamwidth_deg=30.0, absorption=batecho.Atmosphere() if atm else None)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    assert_within_tol(kinked_leaf_at_the_top(sonar, radius, live, r), sonar, pose, tol)


@pytest.mark.parametrize("tol", TOLS)
@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"absorption": batecho.Atmosphere()},
        {"leaf_model": "physical_optics"},
        {"spreading": False},
        {"window": "rect", "beamwidth_deg": 60.0},
    ],
)
def test_fast_is_within_tol_on_the_canonical_box(tol, kw):
    from batecho.echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar

    leaves = canonical_leaf_box(np.random.default_rng(3))
    assert_within_tol(leaves, canonical_sonar(**kw), canonical_pose(), tol)


def test_fast_echo_of_an_empty_lobe_is_exactly_zero():
    leaves = Leaves([[-3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    e = simulate(leaves, Sonar(), Poses([0, 0, 0], [1, 0, 0]), method="fast", tol=1e-6)
    assert e.n_leaves[0] == 0 and not e.spectrum.any() and not e.impulse.any()


def test_fast_works_with_few_band_bins():
    sonar = Sonar(n_samples=1000, band_hz=(60e3, 62e3))  # 6 bins, fewer than the nodes
    assert sonar.n_bins < 10
    rng = np.random.default_rng(1)
    n = 300
    c = frame_points(
        Poses([0, 0, 0], [1, 0, 0]),
        rng.uniform(0.5, 0.8, n),
        rng.uniform(-0.3, 0.3, n),
        rng.uniform(-0.3, 0.3, n),
    )
    leaves = Leaves(c, rng.normal(size=(n, 3)), np.full(n, 0.02))
    assert_within_tol(leaves, sonar, Poses([0, 0, 0], [1, 0, 0]), 1e-9)


@pytest.mark.parametrize("tol", [0.0, -1e-3, 1.0, np.nan, 1e-14])
def test_fast_refuses_tolerances_outside_its_range(tol):
    leaves = Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    with pytest.raises(ValueError, match="tol"):
        simulate(leaves, Sonar(), Poses([0, 0, 0], [1, 0, 0]), method="fast", tol=tol)


def test_auto_below_the_fast_floor_is_exact():
    from batecho.echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar

    leaves = canonical_leaf_box(np.random.default_rng(8))
    exact = simulate(leaves, canonical_sonar(), canonical_pose(), method="exact")
    auto = simulate(leaves, canonical_sonar(), canonical_pose(), method="auto", tol=1e-15)
    assert auto.spectrum.tobytes() == exact.spectrum.tobytes()


# Bands wider than the paper's 60-80 kHz, where the node count of the fast path is calibrated
# (`WORST_CHEB` in rust/src/fast/plan.rs): up to f_hi / f_lo = 2 the calibration holds; beyond
# it the fast sum is taken at a thousandth of `tol`. The first three cases below went over
# `tol` (1.8, 8.5 and 4.6 times) before that rule.
POSE_X = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


@st.composite
def wide_band_cases(draw):
    """`cases()` with the band moved: its top at 40-150 kHz, f_hi / f_lo 1.1-12."""
    sonar, pose, leaves = draw(cases())
    f_hi = draw(st.floats(40e3, min(0.45 * sonar.fs, 150e3)))
    ratio = draw(st.floats(1.1, 12.0))
    # (min_ka 0: the strategy's millimetre leaves are below ka = 0.5 on a low band)
    return sonar.replace(band_hz=(max(f_hi / ratio, 5e3), f_hi), min_ka=0.0), pose, leaves


@given(wide_band_cases(), st.sampled_from(TOLS))
def test_fast_is_within_tol_on_bands_up_to_twelve_times_their_lowest_frequency(case, tol):
    sonar, pose, leaves = case
    assert_within_tol(leaves, sonar, pose, tol)


@given(wide_band_cases(), st.sampled_from(TOLS))
def test_auto_is_within_tol_on_bands_up_to_twelve_times_their_lowest_frequency(case, tol):
    sonar, pose, leaves = case
    assert_within_tol(leaves, sonar, pose, tol, method="auto")


def test_fast_sums_exactly_where_a_wide_band_tightens_tol_below_its_floor():
    rng = np.random.default_rng(3)
    n = 3000
    centers = np.c_[rng.uniform(1, 5, n), rng.uniform(-0.5, 0.5, (n, 2))]
    leaves = Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.03, n))
    sonar = Sonar(band_hz=(20e3, 100e3))
    exact = simulate(leaves, sonar, POSE_X, method="exact")
    fast = simulate(leaves, sonar, POSE_X, method="fast", tol=1e-11)
    assert np.array_equal(fast.spectrum, exact.spectrum)


def test_fast_sums_exactly_where_a_wide_band_would_work_below_1e_12():
    # (a band of ratio 2.6 worked at 1e-13, the floor, gave 1.16 tol at tol = 1e-12)
    leaves = Leaves(
        [
            [9.696712199459965, 1.3674645056874248, 0.6570675770750102],
            [9.326983159199761, 1.0088892911120002, 1.0706982069155893],
            [9.750286224819318, 0.9637244910031091, -0.3454327832075247],
        ],
        [
            [0.13620757572929826, -0.5799030432605631, -0.8032184987480586],
            [0.0885664758806422, 0.21369938611213113, -0.9728764318891593],
            [0.9945328575891573, 0.09830026010172223, -0.03523427364766634],
        ],
        [0.04667759378215695, 0.06912070656141801, 0.05604282518115299],
    )
    sonar = Sonar(
        beamwidth_deg=99.46020443152089,
        fs=400e3,
        n_samples=23923,
        band_hz=(44809.86058275266, 117282.06395990515),
        sound_speed=340.9221172243122,
        lobe="cone",
        cone_half_angle_deg=16.465834209362608,
        window="rect",
    )
    assert_within_tol(leaves, sonar, POSE_X, 1e-12)


def test_fast_names_the_tol_it_was_given_when_refusing_it():
    leaf = Leaves([[3.0, 0.1, 0.0]], [[1.0, 0.2, 0.0]], [0.02])
    with pytest.raises(ValueError, match=r"got 1e-14"):
        simulate(leaf, Sonar(band_hz=(20e3, 100e3)), POSE_X, method="fast", tol=1e-14)


def test_fast_is_within_tol_for_one_leaf_on_a_wide_low_band():
    leaf = Leaves(
        [[7.59339219856452, 0.3838605591924311, -1.54801922515559]],
        [[-0.4426848543133972, 1.017486474381074, -1.3066112595978296]],
        [0.011178520748408966],
    )
    assert_within_tol(leaf, Sonar(band_hz=(20e3, 100e3)), POSE_X, 1e-6)


def test_fast_is_within_tol_for_one_leaf_on_a_wide_band_with_air_absorption():
    sonar = Sonar(
        fs=250e3,
        band_hz=(10454.108615722813, 105024.30051228765),
        beamwidth_deg=115.0,
        window="rect",
        spreading=False,
        absorption=batecho.Atmosphere(),
    )
    leaf = Leaves(
        [[8.848031611753914, 2.3512201024704393, -2.548107166378146]],
        [[0.5578125377176493, 0.7415482315366199, -0.37276184497599507]],
        [0.08397402293016572],
    )
    assert_within_tol(leaf, sonar, POSE_X, 8.16e-3)


def test_fast_is_within_tol_for_branches_on_a_wide_band_with_air_absorption():
    rng = np.random.default_rng(17)
    r, az, el = rng.uniform(1, 8, 6), rng.uniform(-0.3, 0.3, 6), rng.uniform(-0.3, 0.3, 6)
    s = np.c_[r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)]
    wood = batecho.Branches(s, s + rng.normal(size=(6, 3)), rng.uniform(0.01, 0.1, 6))
    sonar = Sonar(
        beamwidth_deg=60,
        band_hz=(10e3, 110e3),
        fs=250e3,
        absorption=batecho.Atmosphere(),
        window="rect",
    )
    exact = simulate(batecho.Scene(None, branches=wood), sonar, POSE_X, method="exact")
    fast = simulate(batecho.Scene(None, branches=wood), sonar, POSE_X, method="fast", tol=1e-6)
    assert rel_err(fast.spectrum, exact.spectrum) <= 1e-6


# Known breaches, strict: each fails once the fast path keeps its promise there, and its mark
# is then to go. At 1e-12 and below the fast sum is near its floor (the exact sum's own
# rounding is about 1e-13 of a leaf at the reach).
@pytest.mark.xfail(strict=True, reason="fast at tol = 1e-12 is near its floor")
def test_fast_is_within_tol_at_1e_12_for_eight_shaded_leaves_near_the_sonar():
    leaves = Leaves(
        [
            [0.7363692263716181, 0.050947879532058364, -0.23043793802899726],
            [1.4811409437586893, 0.034357168483006406, 0.049322763786163355],
            [0.32792663250272497, 0.003492562328793473, -0.06180084451117054],
            [0.44850324324232, -0.04314362543517244, 0.06613542490089475],
            [1.1075534156217033, -0.04777472684388667, 0.4395336245363119],
            [0.3840783949901953, 0.13006878610721592, -0.10541067610288356],
            [0.4319808017846405, 0.061571619625148906, 0.05639461843647377],
            [0.2980966081212598, 0.0332179042466773, 0.009794555535404653],
        ],
        [
            [-0.12213863586566148, 0.9770938236199613, -0.17426937043726065],
            [0.032654819374805875, -0.9463883811125853, -0.3213762512487489],
            [0.9826471807723701, 0.010465623056804244, -0.18518906245819697],
            [0.5203798489459336, -0.6802755800455975, 0.5161685267474503],
            [0.06934935905100642, 0.9953696096813406, -0.06655829416406579],
            [0.9166953137150486, 0.3104403898796068, -0.25158788950238914],
            [0.9818282309091719, 0.1399431505312833, 0.12817659540315604],
            [0.10934187116641533, -0.8123128261160829, -0.5728806400439184],
        ],
        [
            0.04377203851778908,
            0.08280807200069126,
            0.004928584492307544,
            0.03432267077817049,
            0.11363702778936476,
            0.017227345927026762,
            0.017449962807584797,
            0.1389509344414232,
        ],
    )
    sonar = Sonar(
        beamwidth_deg=51.277280679067616,
        fs=400e3,
        n_samples=5633,
        band_hz=(59433.86511192767, 68026.14363201035),
        sound_speed=348.87832425689913,
        lobe="cone",
        cone_half_angle_deg=27.553898054071325,
        spreading=False,
        absorption=batecho.Atmosphere(
            temperature_c=21.2301965435099, relative_humidity=28.68388551475939
        ),
        shading=batecho.Shading(),
    )
    assert_within_tol(leaves, sonar, POSE_X, 1e-12)


@pytest.mark.xfail(strict=True, reason="the interpolants' floor is about 1.5e-13")
def test_fast_is_within_its_tightest_tol_for_a_leaf_at_the_reach():
    leaf = Leaves([[10.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    assert_within_tol(leaf, Sonar(), POSE_X, 1e-13)
