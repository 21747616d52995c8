"""Bad input gets a clear Python exception naming the problem: never a panic, a crash or a
silent NaN; and nothing the caller passed is modified."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import batecho
from batecho import Beam, Leaves, Poses, Scene, Sonar, _core, simulate
from batecho.sonar.record import sonar_params

GOOD_C = np.array([[2.0, 0.0, 0.0], [3.0, 0.1, 0.0]])
GOOD_N = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
GOOD_R = np.array([0.02, 0.03])
AXIS = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_center_is_refused_naming_centers(bad):
    c = GOOD_C.copy()
    c[1, 2] = bad
    with pytest.raises(ValueError, match="centers must be finite"):
        Leaves(c, GOOD_N, GOOD_R)


def test_non_finite_normal_is_refused():
    n = GOOD_N.copy()
    n[0, 0] = np.nan
    with pytest.raises(ValueError, match="normals must be finite"):
        Leaves(GOOD_C, n, GOOD_R)


def test_zero_normal_is_refused_naming_the_leaf():
    n = GOOD_N.copy()
    n[1] = 0.0
    with pytest.raises(ValueError, match=r"leaf 1: normal .* has length 0"):
        Leaves(GOOD_C, n, GOOD_R)


@pytest.mark.parametrize("radius", [-0.01, 0.0])
def test_non_positive_radius_is_refused_naming_the_leaf(radius):
    r = GOOD_R.copy()
    r[1] = radius
    with pytest.raises(ValueError, match="leaf 1 has radius"):
        Leaves(GOOD_C, GOOD_N, r)


def test_nan_radius_is_refused():
    with pytest.raises(ValueError, match="radii must be finite"):
        Leaves(GOOD_C, GOOD_N, [0.02, np.nan])


def test_empty_arrays_are_refused():
    with pytest.raises(ValueError, match="at least one leaf"):
        Leaves(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


@pytest.mark.parametrize(
    "centers, normals, radii",
    [
        (np.zeros((2, 2)), GOOD_N, GOOD_R),
        (GOOD_C, GOOD_N[:1], GOOD_R),
        (GOOD_C, GOOD_N, GOOD_R[:1]),
        (GOOD_C.ravel(), GOOD_N, GOOD_R),
        (GOOD_C, GOOD_N, GOOD_R[:, None]),
    ],
)
def test_wrong_shapes_are_refused(centers, normals, radii):
    with pytest.raises(ValueError, match="shape|rows"):
        Leaves(centers, normals, radii)


@pytest.mark.parametrize(
    "centers", [GOOD_C.astype(complex), GOOD_C.astype(str), GOOD_C.astype(object), GOOD_C > 0]
)
def test_non_real_dtypes_are_refused_with_type_error(centers):
    with pytest.raises(TypeError, match="real numbers"):
        Leaves(centers, GOOD_N, GOOD_R)


def test_integer_arrays_are_accepted_as_reals():
    lv = Leaves(np.array([[2, 0, 0]]), np.array([[1, 0, 0]]), np.array([1]))
    assert lv.centers.dtype == np.float64


def test_leaf_at_the_sonar_position_is_refused_naming_leaf_and_pose():
    lv = Leaves([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], GOOD_N, GOOD_R)
    with pytest.raises(ValueError, match="leaf 0 .* from pose 0, closer than min_range_m"):
        simulate(lv, Sonar(), AXIS)


def test_leaf_closer_than_min_range_can_be_skipped_on_request():
    lv = Leaves([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]], GOOD_N, GOOD_R)
    echo = simulate(lv, Sonar(too_close="skip"), AXIS)
    assert echo.n_leaves[0] == 1 and np.isfinite(echo.impulse).all()


def test_band_above_nyquist_is_refused():
    with pytest.raises(ValueError, match="Nyquist"):
        Sonar(fs=150e3)


def test_a_hann_window_over_one_band_bin_is_refused():
    # the periodic Hann window of length 1 is 0: every echo would be silently zero
    with pytest.raises(ValueError, match="one band bin.*window='rect'"):
        Sonar(band_hz=(70e3, 70e3 + 1))


@pytest.mark.parametrize("bw", [0.0, -5.0, 180.0, 200.0, np.nan])
def test_beamwidth_outside_zero_to_180_is_refused(bw):
    with pytest.raises(ValueError, match="beamwidth_deg"):
        Sonar(beamwidth_deg=bw)


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(lobe="sphere"), "lobe"),
        (dict(lobe="cone"), "cone_half_angle_deg"),
        (dict(lobe="cone", cone_half_angle_deg=0.0), "cone_half_angle_deg"),
        (dict(leaf_model="rayleigh"), "leaf_model"),
        (dict(window="hamming"), "window"),
        (dict(band_hz=(80e3, 60e3)), "band"),
        (dict(band_hz=(0.0, 80e3)), "band"),
        (dict(n_samples=1), "n_samples"),
        (dict(sound_speed=-340.0), "sound_speed"),
        (dict(gain=0.0), "gain"),
        (dict(too_close="ignore"), "too_close"),
        (dict(beamwidth_deg=20.0, beam=Beam(beamwidth_deg=10.0)), "not both"),
        (dict(threshold_db=np.inf), "threshold_db"),
    ],
)
def test_bad_sonar_parameters_are_refused_naming_them(kw, match):
    with pytest.raises(ValueError, match=match):
        Sonar(**kw)


@pytest.mark.parametrize("spreading", ["False", "no", None, 2])
def test_a_spreading_that_is_not_true_or_false_is_refused(spreading):
    # bool("False") is True: the 1/r^2 would be kept silently
    with pytest.raises(TypeError, match="spreading"):
        Sonar(spreading=spreading)


@pytest.mark.parametrize(
    "kw",
    [
        dict(fs="400e3"),
        dict(sound_speed="340"),
        dict(gain=True),
        dict(threshold_db="20"),
        dict(band_hz=("60e3", "80e3")),
        dict(max_range_m="5"),
        dict(record_tail_s="0.001"),
        dict(min_ka="0.5"),
        dict(beamwidth_deg="30"),
        dict(beamwidth_deg=True),
    ],
    ids=lambda kw: next(iter(kw)),
)
def test_sonar_numbers_given_as_text_or_flags_are_refused_naming_them(kw):
    with pytest.raises(TypeError, match=next(iter(kw))):
        Sonar(**kw)


@pytest.mark.parametrize(
    "kw",
    [
        dict(beamwidth_deg="30"),
        dict(beamwidth_deg=True),
        dict(sigma_deg=10.0, rotation_deg="15"),
        dict(sigma_deg=10.0, center_deg=("5", "0")),
        dict(sigma_deg=10.0, amplitude="2"),
        dict(sigma_deg=10.0, amplitude=True),
    ],
    ids=lambda kw: list(kw)[-1] + "=" + repr(kw[list(kw)[-1]]),
)
def test_beam_numbers_given_as_text_or_flags_are_refused_naming_them(kw):
    # (text was kept and failed in math.radians naming nothing, "must be real number, not
    # str", or was kept as text: Beam(amplitude="2"); True was a 1 degree beam)
    with pytest.raises(TypeError, match=list(kw)[-1]):
        Beam(**kw)


def test_an_atmosphere_given_text_is_refused_naming_it():
    with pytest.raises(TypeError, match="temperature_c"):
        batecho.Atmosphere(temperature_c="20")


def test_n_samples_must_be_an_integer():
    with pytest.raises(TypeError, match="n_samples"):
        Sonar(n_samples=24000.5)


#: Sonar parameters as NumPy values and lists, as a parameter sweep or a TOML file gives them,
#: and the same parameters as Python numbers and tuples.
NUMPY_SONAR = dict(
    beam=Beam(sigma_deg=np.array([12.0, 8.0]), center_deg=[np.float32(5.0), 0.0]),
    fs=np.float32(400e3),
    n_samples=np.int64(24000),
    band_hz=np.array([60e3, 80e3]),
    gain=np.array(0.5),
    spreading=np.bool_(True),
    absorption=batecho.Atmosphere(temperature_c=np.float32(25.0)),
)
PYTHON_SONAR = dict(
    beam=Beam(sigma_deg=(12.0, 8.0), center_deg=(5.0, 0.0)),
    fs=400e3,
    n_samples=24000,
    band_hz=(60e3, 80e3),
    gain=0.5,
    spreading=True,
    absorption=batecho.Atmosphere(temperature_c=25.0),
)


def test_a_sonar_given_numpy_values_and_lists_equals_one_given_python_numbers():
    assert Sonar(**NUMPY_SONAR) == Sonar(**PYTHON_SONAR)


def test_a_sonar_given_numpy_values_and_lists_hashes_as_one_given_python_numbers():
    assert hash(Sonar(**NUMPY_SONAR)) == hash(Sonar(**PYTHON_SONAR))


def test_echoes_of_a_sonar_given_numpy_values_export_its_parameters(tmp_path):
    echoes = simulate(Leaves(GOOD_C, GOOD_N, GOOD_R), Sonar(**NUMPY_SONAR), AXIS)
    want = echoes.sonar.replace(**PYTHON_SONAR)
    assert json.loads(echoes.to_xarray().attrs["sonar_json"]) == sonar_params(want)
    echoes.to_mat(tmp_path / "echoes.mat")


@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(positions=[np.nan, 0, 0], forward=[1, 0, 0]), "positions must be finite"),
        (dict(positions=[0, 0, 0], forward=[0, 0, 0]), r"forward .* has length 0"),
        (dict(positions=[0, 0, 0], forward=[0, 0, 1]), "parallel to forward"),
        (dict(positions=np.zeros((0, 3)), forward=[1, 0, 0]), "at least one pose"),
        (dict(positions=[[0, 0, 0], [1, 0, 0]], forward=np.ones((3, 3))), "rows"),
    ],
)
def test_bad_poses_are_refused(kw, match):
    with pytest.raises(ValueError, match=match):
        Poses(**kw)


@pytest.mark.parametrize("rotations", [np.eye(3) * (1 + 1j), [["a"] * 3] * 3])
def test_rotations_that_are_not_real_numbers_are_refused_naming_rotations(rotations):
    # complex ones lost their imaginary part, with only a NumPy warning
    with pytest.raises(TypeError, match="rotations"):
        Poses.from_rotations([0.0, 0.0, 0.0], rotations)


@pytest.mark.parametrize("rotation", [2.0 * np.eye(3), np.diag([1.0, 1.0, -1.0])])
def test_poses_transformed_refuses_a_matrix_that_is_not_a_rotation(rotation):
    # as Leaves.transformed and Branches.transformed do: the move is rigid
    with pytest.raises(ValueError, match="proper rotation"):
        Poses([1.0, 0.0, 0.0], [1.0, 0.0, 0.0]).transformed(rotation)


def test_look_at_a_target_at_the_position_is_refused():
    with pytest.raises(ValueError, match="coincides"):
        batecho.look_at([1.0, 2.0, 3.0], [1.0, 2.0, 3.0])


def test_leaves_smaller_than_the_model_guard_are_refused_naming_the_leaf():
    lv = Leaves(GOOD_C, GOOD_N, [0.02, 1e-5])
    with pytest.raises(ValueError, match="leaf 1 has radius .* below min_ka"):
        simulate(lv, Sonar(), AXIS)


def test_leaves_and_poses_never_modify_or_keep_the_callers_arrays():
    c, n, r = GOOD_C.copy(), GOOD_N * 3.0, GOOD_R.copy()
    c0, n0, r0 = c.copy(), n.copy(), r.copy()
    lv = Leaves(c, n, r)
    np.testing.assert_array_equal(c, c0)
    np.testing.assert_array_equal(n, n0)  # normalised on a copy only
    np.testing.assert_array_equal(r, r0)
    c[:] = 99.0
    assert lv.centers[0, 0] == 2.0
    assert not lv.centers.flags.writeable
    pos, fwd = np.zeros(3), np.array([2.0, 0.0, 0.0])
    Poses(pos, fwd)
    np.testing.assert_array_equal(fwd, [2.0, 0.0, 0.0])


def test_simulate_refuses_wrong_argument_types():
    with pytest.raises(TypeError, match="sonar"):
        simulate(Leaves(GOOD_C, GOOD_N, GOOD_R), "sonar", AXIS)
    with pytest.raises(TypeError, match="poses"):
        simulate(Leaves(GOOD_C, GOOD_N, GOOD_R), Sonar(), np.zeros(3))
    with pytest.raises(ValueError, match="method"):
        simulate(Leaves(GOOD_C, GOOD_N, GOOD_R), Sonar(), AXIS, method="magic")


@pytest.mark.parametrize("method", [np.array(["exact"]), np.array(["exact", "fast"]), ["exact"]])
def test_a_method_that_is_not_a_string_is_refused_naming_method(method):
    # a one-element array passed the check and reached the core as an array
    with pytest.raises(ValueError, match="method must be one of"):
        simulate(Leaves(GOOD_C, GOOD_N, GOOD_R), Sonar(), AXIS, method=method)


def test_core_scene_refuses_non_unit_normals_instead_of_panicking():
    with pytest.raises(ValueError, match="not a finite unit vector"):
        _core.Scene(GOOD_C, GOOD_N * 2.0, GOOD_R)
    with pytest.raises(ValueError, match="differ in length"):
        _core.Scene(GOOD_C, GOOD_N[:1], GOOD_R)


@pytest.mark.parametrize("radius, r", [(1e-3, 0.05), (0.2, 0.05), (2.0, 9.0), (1e-3, 9.99)])
def test_extreme_but_valid_leaves_give_finite_output(radius, r):
    for model in ("paper", "physical_optics"):
        for n in ([1.0, 0, 0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]):
            echo = simulate(
                Leaves([[r, 0.0, 0.0]], [n], [radius]),
                Sonar(leaf_model=model, min_range_m=0.01),
                AXIS,
            )
            assert np.isfinite(echo.spectrum).all() and np.isfinite(echo.impulse).all()
            assert echo.n_leaves[0] == 1


def test_coordinates_beyond_the_bvh_range_are_refused():
    with pytest.raises(ValueError, match="beyond"):
        Leaves([[1e16, 0.0, 0.0]], [[1.0, 0, 0]], [0.02])


def test_scene_accepts_leaves_only():
    with pytest.raises(TypeError, match="Leaves"):
        Scene(np.zeros((3, 3)))


@pytest.mark.parametrize(
    "sonar, shown",
    [
        (dict(min_ka=1e300), "min_ka = 1.000e300"),
        (dict(min_range_m=1e300), "min_range_m = 1.000e300 m"),
    ],
)
def test_an_absurd_min_ka_or_min_range_is_named_in_few_digits(sonar, shown):
    leaf = Leaves([[0.0, 0.0, 3.0]], [[0.0, 0.0, 1.0]], [0.03])
    with pytest.raises(ValueError, match=shown) as err:
        simulate(Scene(leaf), Sonar(**sonar), Poses([0.0, 0, 0], [0.0, 0, 1], [1.0, 0, 0]))
    assert not re.search(r"\d{20}", str(err.value)), str(err.value)


def test_a_tiny_k_a_is_named_in_exponent_form_not_as_zero():
    leaf = Leaves([[0.0, 0.0, 3.0]], [[0.0, 0.0, 1.0]], [1e-7])
    with pytest.raises(ValueError, match=r"k a = \d\.\d{3}e-\d") as err:
        simulate(Scene(leaf), Sonar(), Poses([0.0, 0, 0], [0.0, 0, 1], [1.0, 0, 0]))
    assert "k a = 0.0000" not in str(err.value)


@pytest.mark.parametrize(
    ("kw", "needle"),
    [
        ({"scale": 1e300}, "scale=1e\\+300.*beyond 1e\\+15 m"),
        ({"translation": (1e20, 0.0, 0.0)}, "translation=.*beyond 1e\\+15 m"),
        ({"scale": 5e-324}, "scale=.*radii must be > 0"),
    ],
)
def test_leaves_transformed_refuses_leaves_moved_out_of_bounds_naming_the_transform(kw, needle):
    with pytest.raises(ValueError, match=needle):
        Leaves(GOOD_C, GOOD_N, GOOD_R).transformed(**kw)


@pytest.mark.parametrize("scale", ["2", True, None])
def test_leaves_transformed_refuses_a_scale_that_is_not_a_real_number_naming_it(scale):
    with pytest.raises(TypeError, match="scale must be a real number"):
        Leaves(GOOD_C, GOOD_N, GOOD_R).transformed(scale=scale)


@pytest.mark.parametrize("index", [True, None, np.array([[0, 1]])])
def test_leaves_indexed_by_something_adding_an_axis_is_refused_naming_the_index(index):
    with pytest.raises(IndexError, match="Leaves index must select leaves along one axis"):
        Leaves(GOOD_C, GOOD_N, GOOD_R)[index]


def test_leaves_concatenate_refuses_a_part_that_is_not_leaves_naming_it():
    with pytest.raises(TypeError, match="part 1 is int"):
        Leaves.concatenate([Leaves(GOOD_C, GOOD_N, GOOD_R), 3])
