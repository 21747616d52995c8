"""One validation story: what Leaves and Poses accept the core accepts; direction vectors
too short or long to normalise are refused at the door, naming the argument, the index and
the value; parameters whose echoes would overflow, and beams too narrow to evaluate, are
refused instead of giving inf, NaN or ZeroDivisionError."""

from __future__ import annotations

import numpy as np
import pytest
from _isolated import call_in_child
from hypothesis import given
from hypothesis import strategies as st

from batecho import Atmosphere, Beam, Leaves, Poses, Scene, Sonar, simulate
from batecho._validate import MAX_NORM, MIN_NORM

#: A refused call must answer within this (s): the checks come before any work.
PROMPT_S = 1.0

POSE = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
LEAF = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])


@pytest.mark.parametrize("length", [1e-160, 1e200, 0.0])
def test_a_leaf_normal_too_short_or_long_to_normalise_is_refused_naming_leaf_and_value(length):
    body = (
        f"batecho.Leaves([[2.0, 0, 0], [3.0, 0, 0]], [[1.0, 0, 0], [{length}, 0, 0]], [0.02, 0.02])"
    )
    r = call_in_child(body)
    assert r["raised"] == "ValueError", r
    assert "leaf 1: normal" in r["message"] and f"{length:.3g}" in r["message"], r
    assert r["elapsed_s"] < PROMPT_S, r


@pytest.mark.parametrize("which", ["forward", "up"])
@pytest.mark.parametrize("length", [1e-160, 1e200])
def test_a_pose_vector_too_short_or_long_is_refused_naming_pose_and_value(which, length):
    vec = {"forward": "[1.0, 0, 0]", "up": "[0, 0, 1.0]"}
    vec[which] = f"[0, 0, {length}]" if which == "up" else f"[{length}, 0, 0]"
    r = call_in_child(f"batecho.Poses([0.0, 0, 0], {vec['forward']}, {vec['up']})")
    assert r["raised"] == "ValueError", r
    assert f"pose 0: {which}" in r["message"] and f"{length:.3g}" in r["message"], r
    assert r["elapsed_s"] < PROMPT_S, r


lengths = st.floats(1e-300, 1e300).map(float) | st.sampled_from([MIN_NORM, MAX_NORM])
directions = st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))


@given(direction=directions, length=lengths)
def test_what_leaves_accept_the_core_accepts(direction, length):
    normal = np.array(direction) * length
    try:
        leaves = Leaves([[2.0, 0.0, 0.0]], [normal], [0.02])
    except ValueError as exc:
        assert "normal" in str(exc)
        return
    Scene(leaves)  # the core takes every normal Leaves made
    assert abs(np.linalg.norm(leaves.normals[0]) - 1.0) < 1e-15


@given(forward=directions, up=directions, length=lengths)
def test_what_poses_accept_the_core_accepts(forward, up, length):
    try:
        poses = Poses([0.0, 0.0, 0.0], np.array(forward) * length, np.array(up) * length)
    except ValueError as exc:
        assert "pose 0" in str(exc)
        return
    simulate(LEAF, Sonar(too_close="skip"), poses)  # the core takes every frame Poses made


def test_a_beam_too_narrow_to_evaluate_is_refused_naming_beamwidth():
    r = call_in_child("batecho.Beam(beamwidth_deg=1e-300).gain(0.0, 0.0)")
    assert r["raised"] == "ValueError" and "beamwidth_deg = 1e-300" in r["message"], r


@pytest.mark.parametrize(
    "make",
    [
        "simulate(LEAF, Sonar(gain=1e307), POSE)",
        "simulate(LEAF, Sonar(beam=Beam(sigma_deg=10, amplitude=1e160)), POSE)",
    ],
)
def test_echoes_that_would_overflow_are_refused_not_returned_as_nan(make):
    setup = (
        "import batecho\nfrom batecho import *\n"
        "LEAF = Leaves([[2.0, 0, 0]], [[1.0, 0, 0]], [0.02])\n"
        "POSE = Poses([0.0, 0, 0], [1.0, 0, 0])"
    )
    r = call_in_child(make, setup)
    assert r["raised"] == "ValueError" and "overflow" in r["message"], r


def test_a_leaf_radius_beyond_the_largest_coordinate_is_refused_naming_the_leaf():
    with pytest.raises(ValueError, match=r"radii must be at most 1e\+15 m; leaf 0 has 1e\+154"):
        Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [1e154])


@pytest.mark.parametrize("pressure", [1e-305, 0.0, 999.0, 2.1e5, 1e300])
def test_a_pressure_outside_the_absorption_formulas_range_is_refused(pressure):
    with pytest.raises(ValueError, match="pressure_pa must be in"):
        Atmosphere(pressure_pa=pressure)


def test_the_pressures_at_the_edges_of_the_range_give_finite_echoes():
    for p in (1e3, 2e5):
        e = simulate(LEAF, Sonar(absorption=Atmosphere(pressure_pa=p)), POSE)
        assert np.isfinite(e.impulse).all()


@pytest.mark.parametrize(
    "kwargs, named",
    [
        ({"threshold_db": "x"}, "threshold_db"),
        ({"band_hz": 5}, "band_hz"),
        ({"gain": None}, "gain"),
        ({"sound_speed": -1.0}, "sound_speed"),
        ({"threshold_db": 1e4}, "threshold_db"),
        ({"max_range_m": 0.0}, "max_range_m"),
    ],
)
def test_every_sonar_parameter_is_named_when_refused(kwargs, named):
    with pytest.raises((TypeError, ValueError), match=named):
        Sonar(**kwargs)


@pytest.mark.parametrize(
    "kwargs, named",
    [({"beamwidth_deg": 10, "center_deg": 5}, "center_deg"), ({"sigma_deg": "ab"}, "sigma_deg")],
)
def test_every_beam_parameter_is_named_when_refused(kwargs, named):
    with pytest.raises((TypeError, ValueError), match=named):
        Beam(**kwargs)


def test_an_entry_that_is_not_finite_is_named_by_plain_indices():
    with pytest.raises(ValueError, match=r"centers must be finite; entry \(1, 2\) is nan"):
        Leaves([[2.0, 0.0, 0.0], [3.0, 0.0, np.nan]], [[1.0, 0.0, 0.0]] * 2, [0.02, 0.02])


@pytest.mark.parametrize("f_khz", [70e3, -1.0, 40.0, 100.0])
def test_a_horseshoe_frequency_outside_its_fit_is_refused_naming_f_khz(f_khz):
    with pytest.raises(ValueError, match=r"f_khz .*48\.4 to 94\.3 kHz"):
        Sonar.horseshoe_bat(f_khz)


def test_a_horseshoe_frequency_of_nan_is_refused_naming_f_khz():
    with pytest.raises(ValueError, match="f_khz must be finite"):
        Sonar.horseshoe_bat(float("nan"))


def test_a_horseshoe_frequency_that_is_not_a_number_is_refused_naming_f_khz():
    with pytest.raises(TypeError, match="f_khz"):
        Sonar.horseshoe_bat("70")


def test_a_horseshoe_frequency_inside_its_fit_gives_the_fits_beamwidth():
    assert Sonar.horseshoe_bat(70.0).beamwidth_deg == pytest.approx(37.7, abs=0.05)
