"""The ``batecho`` command line and scene files, end to end (in process and as a subprocess)."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

import batecho
from batecho.cli import main
from batecho.scenefile import SceneFile, ScenefileError, setup_scenefile, sonar_params

FIXTURES = Path(__file__).parent / "fixtures"
EXAMPLES = Path(__file__).parents[1] / "examples"

TINY = """\
seed = 3
[scene]
kind = "leaf_box"
density_per_m3 = 3.0

[sonar]
beamwidth_deg = 25

[flight]
path = "circle"
radius = 6.2
altitude = 0.0
heading = "center"
n_pulses = 5

[output]
plots = ["scene", "impulses", "echo_image", "spectrogram", "spectrum"]
sample_points = 2
dpi = 40
max_scene_points = 300
"""

NPZ_KEYS = {
    "spectrum", "freqs", "band_bins", "impulse", "times", "n_leaves", "positions", "forward",
    "up", "left", "pulse_times", "sample_indices", "tree_positions", "path_points", "seed",
    "config_toml", "config_json", "sonar_json", "scene_json", "batecho_version", "clearance_m",
    "min_clearance_m", "min_clearance_time_s",
}  # fmt: skip


def _write(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def _decodable(path: Path) -> bool:
    return path.stat().st_size > 0 and plt.imread(path).ndim == 3


# ------------------------------------------------------------------------------- demo


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "--out", str(out), "-q"]) == 0
    return out


def test_demo_writes_decodable_pngs(demo_out):
    names = ["canonical_impulse.png", "canonical_spectrum.png", "scene_3d.png", "impulses.png",
             "echo_image.png", "spectrogram.png"]  # fmt: skip
    assert all(_decodable(demo_out / n) for n in names)


def test_demo_npz_holds_what_is_needed_to_rerun_it(demo_out):
    with np.load(demo_out / "echoes.npz") as z:
        assert NPZ_KEYS - {"impulse"} <= set(z.files)
        assert int(z["seed"]) == 2017 and str(z["batecho_version"]) == batecho.__version__
        assert z["positions"].shape == (len(z["n_leaves"]), 3)


def test_demo_impulses_follow_from_the_stored_spectrum(demo_out):
    with np.load(demo_out / "echoes.npz") as z:
        sonar = batecho.Sonar(**_sonar_kwargs(json.loads(str(z["sonar_json"]))))
        k0, k1 = z["band_bins"]
        Y = np.zeros((1, sonar.n_samples // 2 + 1), complex)
        Y[0, k0 : k1 + 1] = z["spectrum"][0]
        pose = batecho.Poses(z["positions"][0], z["forward"][0], z["up"][0])
    y = 2 * np.fft.irfft(Y, sonar.n_samples)
    assert np.max(np.abs(y)) > 0 and pose is not None


def test_demo_toml_is_a_valid_scene_file(demo_out):
    sf = SceneFile.from_path(demo_out / "demo.toml")
    assert sf.seed == 2017 and sf.config["flight"]["path"] == "circle"


def _sonar_kwargs(d: dict) -> dict:
    from batecho import Beam

    kw = dict(d)
    for k in ("beam", "receiver"):
        if k in kw:
            kw[k] = Beam(**{a: tuple(v) if isinstance(v, list) else v for a, v in kw[k].items()})
    if "band_hz" in kw:
        kw["band_hz"] = tuple(kw["band_hz"])
    return kw


# ---------------------------------------------------------------------------- simulate


@pytest.fixture(scope="module")
def tiny_out(tmp_path_factory):
    d = tmp_path_factory.mktemp("tiny")
    scene = _write(d, TINY)
    out = d / "out"
    assert main(["simulate", str(scene), "--out", str(out), "-q"]) == 0
    return out


def test_simulate_writes_the_npz_keys(tiny_out):
    with np.load(tiny_out / "echoes.npz") as z:
        assert NPZ_KEYS <= set(z.files)
        assert z["impulse"].shape == (5, 24000) and z["spectrum"].shape == (5, 1201)


def test_simulate_writes_every_plot_asked_for(tiny_out):
    for n in ("scene_3d", "impulses", "echo_image", "spectrogram", "spectrum"):
        assert _decodable(tiny_out / f"{n}.png")


def test_simulate_npz_keeps_the_scene_file_and_sonar(tiny_out):
    with np.load(tiny_out / "echoes.npz") as z:
        assert str(z["config_toml"]) == TINY
        assert json.loads(str(z["sonar_json"]))["beamwidth_deg"] == 25
        assert json.loads(str(z["config_json"]))["flight"]["n_pulses"] == 5


def test_simulate_echoes_match_the_library(tiny_out):
    sf = SceneFile.from_string(TINY)
    st = setup_scenefile(sf)
    e = batecho.simulate(st.scene, st.sonar, st.plan.poses)
    with np.load(tiny_out / "echoes.npz") as z:
        np.testing.assert_array_equal(z["impulse"], e.impulse)


def test_simulate_as_a_subprocess(tmp_path):
    scene = _write(tmp_path, TINY.replace('"scene", "impulses", ', '"scene", '))
    out = tmp_path / "sub-out"
    r = subprocess.run(
        [sys.executable, "-m", "batecho", "simulate", str(scene), "--out", str(out), "-q"],
        capture_output=True, text=True, timeout=120, env=dict(os.environ, MPLBACKEND="Agg"),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "wrote" in r.stdout and _decodable(out / "scene_3d.png")
    assert (out / "echoes.npz").stat().st_size > 0


def test_simulate_seed_option_overrides_the_file(tmp_path):
    scene = _write(tmp_path, TINY)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "--seed", "9",
                 "--no-plots", "-q"]) == 0  # fmt: skip
    with np.load(tmp_path / "o" / "echoes.npz") as z:
        assert int(z["seed"]) == 9
    assert not list((tmp_path / "o").glob("*.png"))


def test_simulate_seed_option_is_the_seed_of_the_stored_scene_file(tmp_path):
    import tomllib

    scene = _write(tmp_path, TINY)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "--seed", "9",
                 "--no-plots", "-q"]) == 0  # fmt: skip
    with np.load(tmp_path / "o" / "echoes.npz") as z:
        assert tomllib.loads(str(z["config_toml"]))["seed"] == 9
        assert json.loads(str(z["config_json"]))["seed"] == 9


def test_a_scene_file_with_another_seed_keeps_the_rest_of_its_text():
    sf = SceneFile.from_string(TINY.replace("seed = 3", "seed = 3   # the draw"))
    assert sf.with_seed(9).text == TINY.replace("seed = 3", "seed = 9   # the draw")


def test_a_scene_file_without_a_seed_is_given_one_at_the_top():
    sf = SceneFile.from_string(TINY.replace("seed = 3\n", ""))
    again = sf.with_seed(9)
    assert again.text.startswith("seed = 9\n") and again.seed == 9 and sf.seed == 0


def test_example_leaf_box_toml_runs(tmp_path):
    assert main(["simulate", str(EXAMPLES / "leaf_box.toml"), "--out", str(tmp_path),
                 "--no-plots", "-q"]) == 0  # fmt: skip


def test_example_flight_toml_is_valid_and_builds():
    st = setup_scenefile(SceneFile.from_path(EXAMPLES / "flight.toml"))
    assert st.plan.flight is not None and len(st.plan.poses) > 100
    assert len(st.tree_positions) == 3


# --------------------------------------------------------------------------- flights


def test_kinematic_circle_is_the_papers_circle():
    st = setup_scenefile(SceneFile.from_string(TINY.replace("n_pulses = 5", "n_pulses = 15")))
    ref = batecho.circle(st.center_xy, 6.2, 0.0, n_points=15, heading="center")
    np.testing.assert_allclose(st.plan.poses.positions, ref.positions, atol=1e-12)
    np.testing.assert_allclose(st.plan.poses.forward, ref.forward, atol=1e-12)


def test_flown_circle_pulses_at_the_rate():
    text = TINY.replace("n_pulses = 5", 'mode = "flown"\nquadrotor = "research"\ndt = 0.005\n'
                        "speed = 4.0\npulse_rate_hz = 2.0")  # fmt: skip
    st = setup_scenefile(SceneFile.from_string(text))
    duration = 2 * math.pi * 6.2 / 4.0
    assert len(st.plan.poses) == math.floor(duration * 2.0) + 1
    assert st.plan.flight.position_error.max() < 0.1


def test_a_flown_flight_reports_its_smallest_clearance_over_every_step(tmp_path, capsys):
    text = TINY.replace("n_pulses = 5", 'mode = "flown"\nquadrotor = "research"\ndt = 0.005\n'
                        "speed = 4.0\npulse_rate_hz = 2.0")  # fmt: skip
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "out"), "--no-plots"]) == 0
    printed = capsys.readouterr().out
    with np.load(tmp_path / "out" / "echoes.npz") as z:
        least, when = float(z["min_clearance_m"]), float(z["min_clearance_time_s"])
        path, times = z["flight_positions"], z["flight_times"]
        pulses = z["clearance_m"]
    st = setup_scenefile(SceneFile.from_string(text))
    d = st.scene.clearance(path)
    assert least == float(d.min()) and when == float(times[np.argmin(d)])
    assert least <= float(pulses.min())
    assert f"min_clearance_m: {least:.3f} m at t = {when:.3f} s" in printed


def test_pulses_by_count_report_the_smallest_of_their_clearances(tiny_out):
    with np.load(tiny_out / "echoes.npz") as z:
        assert float(z["min_clearance_m"]) == float(z["clearance_m"].min())
        assert np.isnan(z["min_clearance_time_s"])


def test_line_with_mount_tilts_the_beam():
    text = TINY.replace(
        'path = "circle"\nradius = 6.2\naltitude = 0.0\nheading = "center"\nn_pulses = 5',
        'path = "line"\nstart = [-8.0, 0.0, 0.0]\ntarget = [5.5, 0.0, 0.0]\nn_pulses = 4\n'
        "[flight.mount]\npitch_deg = -10.0",
    )
    st = setup_scenefile(SceneFile.from_string(text))
    f = st.plan.poses.forward
    np.testing.assert_allclose(np.degrees(np.arcsin(f[:, 2])), -10.0, atol=1e-9)
    assert np.all(np.diff(st.plan.poses.positions[:, 0]) > 0)


def test_obj_scene_from_a_file_with_an_offset():
    obj = FIXTURES / "obj" / "groups.obj"
    text = TINY.replace(
        'kind = "leaf_box"\ndensity_per_m3 = 3.0',
        f'kind = "obj"\npath = "{obj.as_posix()}"\noffset = [1.0, 2.0, 3.0]',
    )
    st = setup_scenefile(SceneFile.from_string(text))
    ref = batecho.load_obj(obj).leaves.centers
    np.testing.assert_allclose(st.scene.leaves.centers, ref + [1.0, 2.0, 3.0], atol=1e-12)


def test_output_obj_writes_the_scene(tmp_path):
    scene = _write(tmp_path, TINY.replace("[output]", "[output]\nobj = true"))
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "--no-plots",
                 "-q"]) == 0  # fmt: skip
    assert batecho.load_obj(tmp_path / "o" / "scene.obj").n_leaves == round(3.0 * 9 * 4 * 4)


def _obj_scene_beside(tmp_path: Path, obj_text: str) -> Path:
    """tmp_path/tree.obj holding ``obj_text`` and a scene file beside it that loads it and
    asks for ``[output] obj = true``."""
    (tmp_path / "tree.obj").write_text(obj_text, encoding="utf-8")
    text = TINY.replace(
        'kind = "leaf_box"\ndensity_per_m3 = 3.0', 'kind = "obj"\npath = "tree.obj"'
    ).replace("[output]", "[output]\nobj = true")
    return _write(tmp_path, text.replace("[flight]", "[flight]\nallow_low_clearance = true"))


def test_output_obj_over_the_scenes_own_obj_file_is_refused_and_keeps_it(tmp_path, capsys):
    scene = _obj_scene_beside(tmp_path, (FIXTURES / "obj" / "groups.obj").read_text())
    (tmp_path / "tree.obj").rename(tmp_path / "scene.obj")
    scene.write_text(scene.read_text().replace("tree.obj", "scene.obj"), encoding="utf-8")
    before = (tmp_path / "scene.obj").read_bytes()
    assert main(["simulate", str(scene), "--out", str(tmp_path), "--no-plots", "-q"]) == 2
    assert "[output] obj = true would overwrite" in capsys.readouterr().err
    assert (tmp_path / "scene.obj").read_bytes() == before


def test_output_obj_over_a_material_library_of_the_scenes_obj_is_refused(tmp_path, capsys):
    obj = (FIXTURES / "obj" / "materials.obj").read_text()
    scene = _obj_scene_beside(tmp_path, obj.replace("mtllib materials.mtl", "mtllib scene.mtl"))
    mtl = (FIXTURES / "obj" / "materials.mtl").read_bytes()
    (tmp_path / "scene.mtl").write_bytes(mtl)
    assert main(["simulate", str(scene), "--out", str(tmp_path), "--no-plots", "-q"]) == 2
    assert "scene.mtl" in capsys.readouterr().err
    assert (tmp_path / "scene.mtl").read_bytes() == mtl


def test_output_obj_beside_an_obj_of_other_names_is_written(tmp_path):
    scene = _obj_scene_beside(tmp_path, (FIXTURES / "obj" / "materials.obj").read_text())
    (tmp_path / "materials.mtl").write_bytes((FIXTURES / "obj" / "materials.mtl").read_bytes())
    for _ in range(2):  # (a rerun overwrites its own scene.obj)
        assert main(["simulate", str(scene), "--out", str(tmp_path), "--no-plots", "-q"]) == 0
    assert batecho.load_obj(tmp_path / "scene.obj").n_leaves == 1


def test_sonar_params_round_trip_through_a_scene_file():
    sonar = batecho.Sonar(
        beam=batecho.Beam(sigma_deg=(10.0, 20.0), rotation_deg=15.0),
        threshold_db=15.0, leaf_model="physical_optics", band_hz=(55e3, 85e3),
        absorption=batecho.Atmosphere(temperature_c=25.0),
    )  # fmt: skip
    doc = {"scene": {"kind": "leaf_box"}, "sonar": sonar_params(sonar)}
    assert SceneFile.from_dict(doc).build_sonar() == sonar


# -------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (("radius = 6.2", "raduis = 6.2"), 'unknown key "raduis" (did you mean "radius"?)'),
        (("altitude = 0.0", "altitude = 1e16"), "[flight] a pulse is out of reach"),
        (('heading = "center"', 'heading = "velocity"\ntarget = [5.5, 0.0, 0.0]'),
         '[flight] target: only used with heading = "center" or "look_at"'),
        (("radius = 6.2", 'radius = "six"'), "[flight] radius: expected a number"),
        (("n_pulses = 5", "n_pulses = 5.5"), "[flight] n_pulses: expected an integer"),
        (('heading = "center"', 'heading = "north"'), "[flight] heading: 'north' is not one"),
        (("beamwidth_deg = 25", "beamwidth = 25"), '[sonar]: unknown key "beamwidth"'),
        (("beamwidth_deg = 25", "beamwidth_deg = 250"), "[sonar] beamwidth_deg must be in"),
        (("density_per_m3 = 3.0", "n_trees = 3"), '[scene] n_trees: not used with kind = "leaf'),
        (("seed = 3", "seed = 3\nsede = 4"), 'top level: unknown key "sede"'),
        (("dpi = 40", "dpi = 40 ="), "invalid TOML"),
        (('"spectrum"]', '"spectra"]'), "[output] plots: unknown plot 'spectra'"),
        (("[scene]\nkind", "[scenery]\nkind"), 'unknown key "scenery" (did you mean "scene"?)'),
        (('[scene]\nkind = "leaf_box"\ndensity_per_m3 = 3.0\n', ""), "missing table [scene]"),
    ],
)  # fmt: skip
def test_bad_scene_file_exits_2_naming_the_problem(tmp_path, capsys, edit, needle):
    assert edit[0] in TINY
    scene = _write(tmp_path, TINY.replace(edit[0], edit[1], 1))
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "-q"]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err and str(scene) in err


def test_missing_scene_file_exits_2(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "nope.toml")]) == 2
    assert "scene file not found" in capsys.readouterr().err


def test_missing_obj_file_names_the_key(tmp_path, capsys):
    text = TINY.replace('kind = "leaf_box"\ndensity_per_m3 = 3.0', 'kind = "obj"\npath = "x.obj"')
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    assert "[scene] path: OBJ file not found" in capsys.readouterr().err


def test_an_obj_path_that_is_a_folder_names_the_file_and_key(tmp_path, capsys):
    (tmp_path / "trees").mkdir()
    text = TINY.replace('kind = "leaf_box"\ndensity_per_m3 = 3.0', 'kind = "obj"\npath = "trees"')
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    assert "scene.toml: [scene] path: " in capsys.readouterr().err


def test_an_obj_whose_leaf_faces_are_all_degenerate_is_refused_saying_so(tmp_path, capsys):
    obj = "o trunk\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no leaf\nf 1 1 2\n"
    (tmp_path / "flat.obj").write_text(obj)
    box = 'kind = "leaf_box"\ndensity_per_m3 = 3.0'
    scene = _write(tmp_path, TINY.replace(box, 'kind = "obj"\npath = "flat.obj"'))
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "[scene] path: " in err and "its leaf faces are all degenerate" in err


def test_bad_scene_file_gives_no_traceback_in_a_subprocess(tmp_path):
    scene = _write(tmp_path, TINY.replace("radius = 6.2", "radius = [1, 2]"))
    r = subprocess.run(
        [sys.executable, "-m", "batecho", "simulate", str(scene), "--out", str(tmp_path / "o")],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2
    assert "[flight] radius: expected a number" in r.stderr and "Traceback" not in r.stderr


def test_a_reader_that_leaves_early_ends_the_dataset_output_quietly():
    # the reader closes its end before the command writes, as "| head -1" does sooner or later
    p = subprocess.Popen([sys.executable, "-m", "batecho", "dataset", "template"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    assert p.stdout is not None and p.stderr is not None
    p.stdout.close()
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 1, err
    assert err == ""


def test_scenefile_error_is_a_value_error():
    with pytest.raises(ScenefileError, match="missing key"):
        SceneFile.from_string("[scene]\ndensity_per_m3 = 1.0\n")


def test_bad_argument_exits_2(capsys):
    assert main(["paper", "table1", "--points", "1,x"]) == 2
    assert "expected integers" in capsys.readouterr().err


# ------------------------------------------------------------------------ other commands


def test_help_exits_0_with_examples(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert "batecho simulate examples/flight.toml" in out and "paper" in out


def test_version(capsys):
    assert main(["--version"]) == 0
    assert batecho.__version__ in capsys.readouterr().out


def test_dataset_without_its_module_gives_a_clear_error(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "batecho.dataset.cli", None)
    assert main(["dataset", "generate", "x.toml", "y.zarr"]) == 2
    assert "dataset command is not available" in capsys.readouterr().err


def test_dataset_command_is_hooked_in(capsys):
    try:
        import batecho.dataset.cli  # noqa: F401
    except ImportError as exc:
        pytest.skip(f"batecho.dataset is not importable here: {exc}")
    assert main(["dataset", "template"]) == 0
    assert "seed" in capsys.readouterr().out


def test_paper_table1_command(tmp_path, capsys):
    md, npz = tmp_path / "t1.md", tmp_path / "t1.npz"
    argv = ["paper", "table1", "--points", "1,5", "--trees", "1,2", "--repeats", "1",
            "--timing-runs", "1", "--out", str(md), "--npz", str(npz), "-q"]  # fmt: skip
    assert main(argv) == 0
    text = md.read_text()
    assert "| 5 |" in text and "(1.00;" in text
    with np.load(npz) as z:
        assert z["times_s"].shape == (2, 2, 1) and np.all(z["times_s"] > 0)


def test_figure_eight_looking_at_its_own_middle_is_refused(tmp_path, capsys):
    text = TINY.replace('path = "circle"\nradius = 6.2', 'path = "figure_eight"\nradius = 3.0')
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    assert "[flight] heading" in capsys.readouterr().err


def test_unknown_tree_parameter_names_the_table(tmp_path, capsys):
    text = TINY.replace(
        'kind = "leaf_box"\ndensity_per_m3 = 3.0', 'kind = "tree"\n[scene.tree]\nheight_m = 3.0'
    )
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "[scene.tree]" in err and "height_m" in err


def test_forest_scene_with_variants_and_given_positions():
    text = TINY.replace(
        'kind = "leaf_box"\ndensity_per_m3 = 3.0',
        'kind = "forest"\nmodel = "lsystem"\npositions = [[0.0, 0.0], [6.0, 0.0], [3.0, 5.0]]\n'
        "variants = 1",
    )
    st = setup_scenefile(SceneFile.from_string(text))
    np.testing.assert_allclose(st.center_xy, [3.0, 5.0 / 3.0])
    assert st.scene.n_leaves == 3 * st.scene_object.variants[0].n_leaves


def test_method_fast_in_a_scene_file_matches_the_exact_sum(tmp_path):
    from batecho.scenefile import run_scenefile

    exact = run_scenefile(SceneFile.from_string(TINY), tmp_path / "e", plots=False)
    fast = run_scenefile(
        SceneFile.from_string('method = "fast"\ntol = 1e-10\n' + TINY), tmp_path / "f", plots=False
    )
    a, b = fast.echoes.spectrum, exact.echoes.spectrum
    assert np.linalg.norm(a - b) <= 1e-9 * np.linalg.norm(b)


def test_unknown_method_names_the_key(tmp_path, capsys):
    scene = _write(tmp_path, 'method = "quick"\n' + TINY)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    assert "method: 'quick' is not one of" in capsys.readouterr().err


# -------------------------------------------------------------------------- clearance

THROUGH_A_TREE = """\
seed = 11
[scene]
kind = "tree"
[sonar]
beamwidth_deg = 20
too_close = "skip"
[flight]
path = "line"
start = [-9.0, 0.0, 5.0]
target = [0.0, 0.0, 5.0]
stop_distance = 0.5
heading = "look_at"
n_pulses = 10
[output]
plots = []
"""


def test_a_flight_through_a_tree_is_refused_naming_pulse_distance_margin_and_key(tmp_path, capsys):
    scene = _write(tmp_path, THROUGH_A_TREE)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "[flight] pulse 9 at (-0.50, 0.00, 5.00) m is" in err
    assert "min_clearance_m = 0.5 m" in err and "allow_low_clearance = true" in err
    assert not (tmp_path / "o" / "echoes.npz").exists()


def test_an_allowed_flight_through_a_tree_runs_with_a_one_line_warning(tmp_path, capsys):
    text = THROUGH_A_TREE.replace("n_pulses = 10", "n_pulses = 10\nallow_low_clearance = true")
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "batecho simulate: warning: pulse 9 at" in err and "Traceback" not in err
    with np.load(tmp_path / "o" / "echoes.npz") as z:
        assert z["clearance_m"].shape == (10,) and z["clearance_m"][-1] < 0.5


def test_an_obj_warning_is_one_line_without_the_source_line(tmp_path, capsys):
    text = TINY.replace(
        'kind = "leaf_box"\ndensity_per_m3 = 3.0',
        f'kind = "obj"\npath = "{(FIXTURES / "obj" / "missing_mtl.obj").as_posix()}"',
    ).replace("[flight]", "[flight]\nallow_low_clearance = true")
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    err = capsys.readouterr().err
    assert "batecho simulate: warning: " in err and "not found in the OBJ's folder" in err
    assert "ObjWarning" not in err and "load_obj(" not in err


def test_allowing_low_clearance_keeps_the_echoes_bits(tmp_path):
    from batecho.scenefile import run_scenefile

    text = THROUGH_A_TREE.replace("n_pulses = 10", "n_pulses = 10\nallow_low_clearance = true")
    with pytest.warns(batecho.ClearanceWarning, match="pulse 9"):
        res = run_scenefile(SceneFile.from_string(text), tmp_path, plots=False)
    st = res.setup
    e = batecho.simulate(st.scene, st.sonar, st.plan.poses, min_clearance_m=0)
    assert res.echoes.impulse.tobytes() == e.impulse.tobytes()


def test_a_smaller_margin_lets_a_flight_pass(tmp_path):
    text = THROUGH_A_TREE.replace("n_pulses = 10", "n_pulses = 10\nmin_clearance_m = 0.0")
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "-q", "--out", str(tmp_path / "o")]) == 0


@pytest.mark.parametrize(
    ("edit", "needle"),
    [
        (("n_pulses = 5", "n_pulses = 5\nmin_clearance_m = -1.0"), "min_clearance_m: must be >= 0"),
        (("radius = 6.2", 'radius = "clear"'), 'it needs [scene] kind = "forest" or "tree"'),
        (("radius = 6.2", 'radius = "wide"'), '[flight] radius: expected a number or "clear"'),
    ],
)  # fmt: skip
def test_bad_clearance_keys_are_refused_by_name(tmp_path, capsys, edit, needle):
    scene = _write(tmp_path, TINY.replace(edit[0], edit[1], 1))
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o"), "-q"]) == 2
    assert needle in capsys.readouterr().err


def test_a_clear_circle_keeps_the_margin_and_is_reported(tmp_path, capsys):
    text = THROUGH_A_TREE.replace('path = "line"', 'path = "circle"\nradius = "clear"').replace(
        "start = [-9.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 5.0]\nstop_distance = 0.5\n"
        'heading = "look_at"',
        'altitude = 5.0\nheading = "center"',
    )
    scene = _write(tmp_path, text)
    assert main(["simulate", str(scene), "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "circle: radius 6.20 m" in out and "clearance: every pulse at least" in out


@pytest.mark.parametrize("name", ["flight.toml", "leaf_box.toml", "straight_run.toml"])
def test_the_example_flights_keep_their_margin_from_leaves_and_bark(name):
    from batecho.scenefile import check_clearance

    st = setup_scenefile(SceneFile.from_path(EXAMPLES / name))
    margin = st.scenefile.config["flight"]["min_clearance_m"]
    assert margin == 0.5
    assert check_clearance(st).distance.min() >= margin


def test_the_demo_keeps_its_margin(demo_out):
    with np.load(demo_out / "echoes.npz") as z:
        assert z["clearance_m"].min() >= 0.5


# ------------------------------------------------------------------------- output paths


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_an_output_folder_that_is_a_file_is_refused_by_name(tmp_path, capsys):
    scene, afile = _write(tmp_path, TINY), _write(tmp_path, "", "afile")
    assert main(["simulate", str(scene), "--out", str(afile), "-q"]) == 2
    line = _one_line_error(capsys)
    assert str(afile) in line and "is a file, not a folder" in line


def test_an_output_folder_below_a_file_is_refused_naming_the_file(tmp_path, capsys):
    scene, afile = _write(tmp_path, TINY), _write(tmp_path, "", "afile")
    assert main(["simulate", str(scene), "--out", str(afile / "sub"), "-q"]) == 2
    assert f"{afile} is a file" in _one_line_error(capsys)


def test_an_output_folder_is_checked_before_the_scene_is_simulated(tmp_path, monkeypatch):
    def never(*args, **kwargs):
        raise AssertionError("simulated before the output folder was checked")

    monkeypatch.setattr("batecho.scenefile.run.setup_scenefile", never)
    scene, afile = _write(tmp_path, TINY), _write(tmp_path, "", "afile")
    assert main(["simulate", str(scene), "--out", str(afile / "sub"), "-q"]) == 2


def test_a_table1_file_below_a_file_is_refused_before_timing(tmp_path, monkeypatch, capsys):
    def never(*args, **kwargs):
        raise AssertionError("timed before the output file was checked")

    import importlib

    monkeypatch.setattr(importlib.import_module("batecho.paper.table1"), "table1", never)
    afile = _write(tmp_path, "", "afile")
    assert main(["paper", "table1", "--points", "1", "--trees", "1", "-q",
                 "--out", str(afile / "x.md")]) == 2  # fmt: skip
    assert f"{afile}: the output folder is a file" in _one_line_error(capsys)


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full (a full disk)")
def test_a_full_disk_is_one_line_naming_the_file(capsys):
    argv = ["paper", "table1", "--points", "1", "--trees", "1", "--repeats", "1",
            "--timing-runs", "1", "--out", "/dev/full", "-q"]  # fmt: skip
    assert main(argv) == 2
    line = _one_line_error(capsys)
    assert "/dev/full" in line and "No space left on device" in line


def test_a_file_system_error_exits_2_naming_the_path(tmp_path, monkeypatch, capsys):
    def unwritable(args):
        raise PermissionError(13, "Permission denied", str(tmp_path / "ro"))

    monkeypatch.setattr("batecho.cli.app.run_simulate", unwritable)
    assert main(["simulate", "x.toml"]) == 2
    line = _one_line_error(capsys)
    assert line == f"batecho simulate: error: {tmp_path / 'ro'}: Permission denied"


def test_a_bug_still_shows_its_traceback(monkeypatch):
    def bug(args):
        raise KeyError("a bug")

    monkeypatch.setattr("batecho.cli.app.run_simulate", bug)
    with pytest.raises(KeyError, match="a bug"):
        main(["simulate", "x.toml"])


# ----------------------------------------------------------------- scene files from Python


def test_run_scenefile_takes_the_path_of_a_scene_file(tmp_path):
    scene = _write(tmp_path, TINY.replace("plots = [", 'plots = []\n# ["'))
    res = batecho.run_scenefile(str(scene), tmp_path / "o")
    assert res.setup.scenefile.path == scene and (tmp_path / "o" / "echoes.npz").exists()


def test_run_scenefile_refuses_another_type_before_making_its_folder(tmp_path):
    with pytest.raises(TypeError, match="a SceneFile or the path of a scene file, got dict"):
        batecho.run_scenefile({"scene": {"kind": "leaf_box"}}, tmp_path / "o")  # type: ignore[arg-type]
    assert not (tmp_path / "o").exists()


def test_a_paper_figures_resolution_beyond_the_scene_file_cap_is_refused_up_front(tmp_path, capsys):
    assert main(["paper", "figures", "--dpi", "100000", "--out", str(tmp_path / "o")]) == 2
    assert "--dpi: at most 2400 dots per inch" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
