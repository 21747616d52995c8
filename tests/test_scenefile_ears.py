"""Scene files and the command line with two ears, a call and the exports: [sonar.binaural],
[[sonar.receivers]], [call] and [output] wav, mat, xarray; the flags --wav, --mat, --xarray."""

from __future__ import annotations

import numpy as np
import pytest

import batecho
from batecho.cli import main
from batecho.scenefile import SceneFile
from batecho.scenefile.run import sonar_params

EARS = """\
seed = 3
[scene]
kind = "leaf_box"
density_per_m3 = 2.0
[sonar]
beamwidth_deg = 30
[sonar.binaural]
separation_m = 0.02
ear_yaw_deg = 25
[call]
kind = "hyperbolic_fm"
f_start_hz = 85e3
f_end_hz = 55e3
duration_s = 1e-3
noise_rms = 1e-7
[flight]
path = "line"
start = [-4.0, 0.0, 0.0]
target = [1.0, 0.0, 0.0]
n_pulses = 3
heading = "look_at"
[output]
plots = ["binaural_impulses", "binaural_echo_images", "interaural", "impulses"]
sample_points = 2
"""


@pytest.fixture(scope="module")
def ears_out(tmp_path_factory):
    d = tmp_path_factory.mktemp("ears")
    (d / "ears.toml").write_text(EARS)
    out = d / "out"
    args = ["simulate", str(d / "ears.toml"), "--out", str(out), "-q", "--wav", "--mat"]
    assert main([*args, "--xarray"]) == 0
    return out


def test_a_two_ear_scene_file_writes_every_export_and_plot(ears_out):
    names = {p.name for p in ears_out.iterdir()}
    assert {"echoes.npz", "echoes.wav", "echoes.mat", "echoes.zarr"} <= names
    assert {"binaural_impulses.png", "binaural_echo_images.png", "interaural.png"} <= names


def test_the_npz_has_a_receiver_axis_and_the_received_call(ears_out):
    with np.load(ears_out / "echoes.npz") as z:
        assert z["spectrum"].shape == (3, 2, 1201) and z["n_leaves"].shape == (3, 2)
        assert z["received"].shape == z["impulse"].shape == (3, 2, 24000)
        assert z["receiver_offsets"].tolist() == [[0.0, 0.01, 0.0], [0.0, -0.01, 0.0]]
        assert z["call"].size == 400


def test_the_exports_hold_the_received_call(ears_out):
    import xarray as xr
    from scipy.io import loadmat, wavfile

    with np.load(ears_out / "echoes.npz") as z:
        received = z["received"]
    ds = xr.open_zarr(ears_out / "echoes.zarr").load()
    assert np.array_equal(ds["received"].values, received)
    assert np.array_equal(loadmat(ears_out / "echoes.mat")["received"], received)
    rate, data = wavfile.read(ears_out / "echoes.wav")
    assert rate == 40_000 and data.shape == (3 * 24000, 2)


def test_the_echoes_zarr_opens_with_xarray_without_a_warning(ears_out):
    import warnings

    import xarray as xr

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = xr.open_zarr(ears_out / "echoes.zarr")
    assert ds["impulse"].dims == ("pose", "receiver", "time")


def test_a_scene_file_with_receivers_matches_the_library():
    doc = {
        "scene": {"kind": "leaf_box", "density_per_m3": 1.0},
        "sonar": {
            "receivers": [
                {"offset_m": [0.0, 0.05, 0.0]},
                {"offset_m": [0.1, -0.05, 0.0], "beam": {"beamwidth_deg": 50.0}},
            ]
        },
    }
    sonar = SceneFile.from_dict(doc).build_sonar()
    want = batecho.Sonar(
        receivers=(
            batecho.Receiver((0.0, 0.05, 0.0)),
            batecho.Receiver((0.1, -0.05, 0.0), batecho.Beam(beamwidth_deg=50.0)),
        )
    )
    assert sonar == want
    # and the sonar's record is itself a valid [sonar] table
    back = SceneFile.from_dict({"scene": {"kind": "leaf_box"}, "sonar": sonar_params(want)})
    assert sonar_params(back.build_sonar()) == sonar_params(want)


def test_a_binaural_table_is_sonar_binaural():
    doc = {
        "scene": {"kind": "leaf_box"},
        "sonar": {
            "beamwidth_deg": 40.0,
            "binaural": {"separation_m": 0.03, "ear_yaw_deg": 20.0, "ear_pitch_deg": 5.0},
        },
    }
    assert SceneFile.from_dict(doc).build_sonar() == batecho.Sonar.binaural(
        0.03, 20.0, 5.0, beamwidth_deg=40.0
    )


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (("ear_yaw_deg = 25", ""), '[sonar.binaural]: missing key "ear_yaw_deg"'),
        (('kind = "hyperbolic_fm"', 'kind = "chirp"'), "[call] kind: 'chirp' is not one"),
        (("f_end_hz = 55e3", "fm_end_hz = 55e3"), '[call] fm_end_hz: not used with kind'),
        (("f_start_hz = 85e3", "f_start_hz = 250e3"), "[call] f_start_hz"),
        (("[sonar.binaural]", "[sonar.receiver]\nbeamwidth_deg = 20\n[sonar.binaural]"),
         "not both"),
        (('plots = ["binaural_impulses", ', 'plots = ["interaural"]\n#'), None),
    ],
)  # fmt: skip
def test_bad_two_ear_scene_files_are_refused_by_name(tmp_path, capsys, edit, needle):
    assert edit[0] in EARS
    text = EARS.replace(edit[0], edit[1], 1)
    if needle is None:  # the interaural plot without two ears
        text = text.replace("[sonar.binaural]\nseparation_m = 0.02\near_yaw_deg = 25\n", "")
        needle = '"interaural" needs two receivers'
    (tmp_path / "bad.toml").write_text(text)
    assert main(["simulate", str(tmp_path / "bad.toml"), "--out", str(tmp_path / "o"), "-q"]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err


def test_the_two_ears_example_is_valid_and_builds():
    from pathlib import Path

    sf = SceneFile.from_path(Path(__file__).parents[1] / "examples" / "two_ears.toml")
    sonar = sf.build_sonar()
    assert sonar.n_receivers == 2 and sf.build_call(sonar.fs) is not None


def test_the_two_ears_example_flies_clear_and_both_ears_hear_the_tree():
    from pathlib import Path

    from batecho.scenefile.run import check_clearance, setup_scenefile

    sf = SceneFile.from_path(Path(__file__).parents[1] / "examples" / "two_ears.toml")
    st = setup_scenefile(sf)
    cl = check_clearance(st)  # raises for a pulse closer than min_clearance_m
    assert cl.distance.min() >= sf.config["flight"]["min_clearance_m"]
    e = batecho.simulate(st.scene, st.sonar, st.plan.poses, method="fast", tol=1e-6)
    left, right = e.n_leaves.max(axis=0)
    assert 0 < left < right  # the tree is on the right
