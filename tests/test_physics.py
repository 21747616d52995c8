"""Physical properties of the echo model, each checked on the Rust exact path."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import frame_points, rel_err
from hypothesis import given
from hypothesis import strategies as st

import batecho
from batecho import Leaves, Poses, Sonar, simulate


def one_leaf(r: float, normal=(1.0, 0.0, 0.0), radius: float = 0.02) -> Leaves:
    return Leaves([[r, 0.0, 0.0]], [normal], [radius])


AXIS = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


@pytest.mark.parametrize("r", [0.4, 1.0, 2.5, 6.0, 9.5])
def test_one_leaf_envelope_peaks_at_the_round_trip_delay(r):
    sonar = Sonar(beamwidth_deg=30.0)
    echo = simulate(one_leaf(r), sonar, AXIS)
    peak = int(np.argmax(echo.envelope()[0]))
    expected = 2.0 * r / sonar.sound_speed * sonar.fs
    assert abs(peak - expected) <= 1.0


@pytest.mark.parametrize("spreading, ratio", [(True, 0.25), (False, 1.0)])
def test_doubling_the_distance_on_the_axis_scales_the_amplitude(spreading, ratio):
    sonar = Sonar(beamwidth_deg=30.0, spreading=spreading)
    near = simulate(one_leaf(2.0), sonar, AXIS)
    far = simulate(one_leaf(4.0), sonar, AXIS)
    np.testing.assert_allclose(np.abs(far.spectrum), ratio * np.abs(near.spectrum), rtol=1e-12)
    np.testing.assert_allclose(
        np.abs(far.envelope()).max(), ratio * np.abs(near.envelope()).max(), rtol=1e-3
    )


@pytest.mark.parametrize(
    "where", [(-3.0, 0.0, 0.0), (3.0, 3.0, 0.0), (11.0, 0.0, 0.0), (0.5, 0.0, 3.0)]
)
def test_a_leaf_outside_the_lobe_gives_an_exactly_zero_echo(where):
    sonar = Sonar(beamwidth_deg=20.0)
    echo = simulate(Leaves([where], [[1.0, 0.0, 0.0]], [0.02]), sonar, AXIS)
    assert echo.n_leaves[0] == 0
    assert np.all(echo.spectrum == 0) and np.all(echo.impulse == 0)


@given(st.integers(0, 2**32 - 1), st.integers(1, 600), st.integers(1, 600))
def test_superposition_echo_of_union_is_sum_of_echoes(seed, na, nb):
    rng = np.random.default_rng(seed)
    sonar = Sonar(beamwidth_deg=40.0)

    def cloud(n):
        c = frame_points(
            AXIS, rng.uniform(0.5, 9.0, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)
        )
        return Leaves(c, rng.normal(size=(n, 3)), rng.uniform(0.005, 0.04, n))

    a, b = cloud(na), cloud(nb)
    union = simulate(Leaves.concatenate([a, b]), sonar, AXIS)
    ea, eb = simulate(a, sonar, AXIS), simulate(b, sonar, AXIS)
    assert union.n_leaves[0] == ea.n_leaves[0] + eb.n_leaves[0]
    assert rel_err(union.spectrum, ea.spectrum + eb.spectrum) <= 1e-12
    assert rel_err(union.impulse, ea.impulse + eb.impulse) <= 1e-12


def random_rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


@given(st.integers(0, 2**32 - 1))
def test_moving_scene_and_pose_together_leaves_the_echo_unchanged(seed):
    rng = np.random.default_rng(seed)
    sonar = Sonar(beamwidth_deg=35.0)
    n = 300
    # keep leaves well inside the lobe so that rounding cannot move one across its boundary
    c = frame_points(
        AXIS, rng.uniform(0.5, 6.0, n), rng.uniform(-0.15, 0.15, n), rng.uniform(-0.15, 0.15, n)
    )
    leaves = Leaves(c, rng.normal(size=(n, 3)), rng.uniform(0.005, 0.04, n))
    R, t = random_rotation(rng), rng.uniform(-50, 50, 3)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    moved_pose = Poses(R @ pose.positions[0] + t, R @ pose.forward[0], R @ pose.up[0])
    before = simulate(leaves, sonar, pose)
    after = simulate(leaves.transformed(R, t), sonar, moved_pose)
    assert after.n_leaves[0] == before.n_leaves[0] == n
    # rounding of ~1e-14 m in the moved ranges shifts phases by 2 k dr ~ 1e-10 rad
    assert rel_err(after.spectrum, before.spectrum) <= 1e-8


@pytest.mark.parametrize("radius", [0.002, 0.02, 0.1])
def test_physical_optics_leaf_at_normal_incidence_has_k_a_squared_over_two(radius):
    sonar = Sonar(
        beamwidth_deg=30.0, leaf_model="physical_optics", window="rect", gain=1.0, spreading=False
    )
    echo = simulate(one_leaf(3.0, normal=(-1.0, 0.0, 0.0), radius=radius), sonar, AXIS)
    k = 2 * np.pi * echo.freqs / sonar.sound_speed
    # A = g G L / k with G = 1 on the axis: |f| = L / k = k a^2 / 2
    np.testing.assert_allclose(np.abs(echo.spectrum[0]), k * radius**2 / 2, rtol=1e-13)


def test_paper_model_leaf_outshines_physical_optics_at_oblique_incidence():
    """The documented difference: at 30 degrees the paper fit is tens of dB brighter."""

    def level(model):
        sonar = Sonar(beamwidth_deg=30.0, leaf_model=model, window="rect")
        n = np.array([-np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0])
        return np.abs(simulate(one_leaf(3.0, normal=n), sonar, AXIS).spectrum).mean()

    assert 20 * np.log10(level("paper") / level("physical_optics")) > 10.0


def test_absorption_attenuates_by_iso9613_over_the_round_trip():
    base = Sonar(beamwidth_deg=30.0)
    wet = Sonar(beamwidth_deg=30.0, absorption=batecho.Atmosphere())
    r = 5.0
    a = simulate(one_leaf(r), base, AXIS).spectrum[0]
    b = simulate(one_leaf(r), wet, AXIS).spectrum[0]
    alpha = batecho.Atmosphere().alpha_db_per_m(base.freqs)
    mask = np.abs(a) > 0
    np.testing.assert_allclose(
        np.abs(b[mask]) / np.abs(a[mask]), 10 ** (-alpha[mask] * 2 * r / 20), rtol=1e-12
    )


def test_absorption_matches_model_md_values():
    alpha = batecho.Atmosphere().alpha_db_per_m(np.array([60e3, 70e3, 80e3]))
    np.testing.assert_allclose(alpha, [1.98, 2.29, 2.61], atol=0.01)


def test_hann_window_zeroes_the_first_band_bin_and_peaks_mid_band():
    sonar = Sonar()
    spec = np.abs(simulate(one_leaf(3.0), sonar, AXIS).spectrum[0])
    assert spec[0] == 0.0
    assert sonar.n_bins == 1201 and sonar.bins == (3600, 4800)


def test_the_grid_matches_model_md_defaults():
    sonar = Sonar()
    assert sonar.fs == 400e3 and sonar.n_samples == 24000
    assert sonar.delta_f == pytest.approx(400e3 / 24000)
    assert sonar.freqs[0] == 60e3 and sonar.freqs[-1] == 80e3
    assert sonar.record_range_m == pytest.approx(10.2)


def test_two_way_gain_at_half_the_beamwidth_is_minus_six_db():
    sonar = Sonar(
        beamwidth_deg=20.0, lobe="cone", cone_half_angle_deg=89.0, spreading=False, window="rect"
    )
    on = simulate(one_leaf(3.0), sonar, AXIS).spectrum
    off_c = frame_points(AXIS, [3.0], [np.radians(10.0)], [0.0])
    e = off_c[0] / 3.0
    off = simulate(Leaves(off_c, [e], [0.02]), sonar, AXIS).spectrum
    # G = S^2 = 0.7079^2 at half the beamwidth (-3 dB one way, -6 dB two way)
    np.testing.assert_allclose(np.abs(off) / np.abs(on), 0.7079**2, rtol=1e-12)
