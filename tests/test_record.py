"""``n_samples="auto"``: the record holds exactly what the scene needs."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import frame_points, rel_err

from batecho import Leaves, Poses, Sonar, reference, simulate

AXIS = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def leaves_at(ranges, seed=0):
    rng = np.random.default_rng(seed)
    n = len(ranges)
    c = frame_points(
        AXIS, np.asarray(ranges, float), rng.uniform(-0.1, 0.1, n), rng.uniform(-0.1, 0.1, n)
    )
    return Leaves(c, rng.normal(size=(n, 3)), np.full(n, 0.02))


def test_auto_record_holds_the_farthest_counting_leaf_and_its_tail():
    sonar = Sonar(n_samples="auto")
    echo = simulate(leaves_at([1.0, 2.0, 3.4]), sonar, AXIS)
    n = echo.sonar.n_samples
    far = 3.4 / np.cos(0.15)  # at most this far off the axis
    assert n >= sonar.fs * (2 * 3.4 / sonar.sound_speed + sonar.record_tail_s)
    assert n < sonar.fs * (2 * far / sonar.sound_speed + sonar.record_tail_s) * 1.05 + 64
    assert n < 24_000


def test_auto_record_gives_the_echo_of_the_same_fixed_record():
    leaves = leaves_at([0.7, 2.2, 4.1, 6.0])
    auto = simulate(leaves, Sonar(n_samples="auto"), AXIS)
    fixed = simulate(leaves, Sonar(n_samples=auto.sonar.n_samples), AXIS)
    assert auto.spectrum.tobytes() == fixed.spectrum.tobytes()
    assert auto.impulse.shape == (1, auto.sonar.n_samples) == fixed.impulse.shape


def test_auto_record_reuses_its_resolved_sonar_and_so_its_plans_across_calls():
    leaves = leaves_at([0.7, 2.2, 4.1, 6.0])
    sonar = Sonar(n_samples="auto")
    first = simulate(leaves, sonar, AXIS, method="fast", tol=1e-6)
    again = simulate(leaves, sonar, AXIS, method="fast", tol=1e-6)
    assert again.sonar is first.sonar
    assert again.spectrum.tobytes() == first.spectrum.tobytes()
    assert sonar.resolve(first.sonar.n_samples) is first.sonar
    other = sonar.resolve(first.sonar.n_samples + 2)
    assert other is not first.sonar and other.n_samples == first.sonar.n_samples + 2


def test_auto_record_takes_the_farthest_leaf_over_all_poses():
    leaves = leaves_at([1.0, 9.0])
    poses = Poses([[0.0, 0, 0], [8.5, 0, 0]], [1.0, 0, 0])
    both = simulate(leaves, Sonar(n_samples="auto"), poses).sonar.n_samples
    second = simulate(leaves, Sonar(n_samples="auto"), poses[1]).sonar.n_samples
    assert both > second


def test_auto_record_matches_the_reference():
    leaves = leaves_at([0.5, 1.5, 2.5, 5.5], seed=3)
    got = simulate(leaves, Sonar(n_samples="auto"), AXIS)
    want = reference.simulate(leaves, Sonar(n_samples="auto"), AXIS)
    assert got.sonar.n_samples == want.sonar.n_samples
    assert rel_err(got.spectrum, want.spectrum) <= 1e-10


def test_auto_record_of_an_empty_lobe_is_the_tail_alone():
    echo = simulate(leaves_at([-3.0]), Sonar(n_samples="auto"), AXIS)
    assert echo.n_leaves[0] == 0 and not echo.impulse.any()
    assert echo.sonar.n_samples <= Sonar().fs * Sonar().record_tail_s + 256


def test_auto_record_with_a_cone_needs_a_range():
    with pytest.raises(ValueError, match="max_range_m"):
        Sonar(n_samples="auto", lobe="cone", cone_half_angle_deg=10.0)
    s = Sonar(n_samples="auto", lobe="cone", cone_half_angle_deg=10.0, max_range_m=30.0)
    assert simulate(leaves_at([25.0]), s, AXIS).sonar.record_range_m >= 25.0


def test_grid_quantities_of_an_auto_sonar_point_to_the_echoes():
    with pytest.raises(ValueError, match="echoes.sonar"):
        _ = Sonar(n_samples="auto").freqs
    with pytest.raises(ValueError, match="'auto'"):
        Sonar(n_samples="automatic")


@pytest.mark.parametrize("range_m", [np.nan, -5.0, np.inf, "5", True])
def test_a_record_length_for_a_range_that_is_not_a_distance_is_refused_naming_it(range_m):
    # (NaN was "a record of nan samples, more than the longest record", a negative range the
    # shortest record, and text was parsed)
    with pytest.raises((TypeError, ValueError), match=r"\brange_m"):
        Sonar().record_length_for(range_m)


@pytest.mark.parametrize("n", [np.nan, 1.7e5, "24000", True])
def test_resolve_takes_an_integer_record_length_naming_it(n):
    # (NaN raised "cannot convert float NaN to integer", and 1.7e5 was truncated to an int)
    with pytest.raises(TypeError, match="n_samples"):
        Sonar(n_samples="auto").resolve(n)
