"""batecho.dataset: spec validation, determinism across workers, restart after a kill,
refusal of foreign or corrupt stores, the xarray view, label consistency and the CLI."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")
xr = pytest.importorskip("xarray")

import batecho  # noqa: E402
from batecho.dataset import (  # noqa: E402
    DatasetError,
    DatasetSpec,
    Dist,
    SpecError,
    SpecMismatchError,
    draw_sample,
    generate,
    open_dataset,
    sample_seed,
    verify,
)
from batecho.dataset.cli import main as cli_main  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "dataset-small.toml"


def tiny_spec(**changes) -> DatasetSpec:
    """The example spec, shrunk: 12 samples of 3 pulses in chunks of 3, a 2.55 m record."""
    base = {
        "n_samples": 12,
        "pulses_per_sample": 3,
        "output.chunk_size": 3,
        "sonar.fs": 200e3,
        "sonar.n_samples": 3000,
        "poses.circle_radius_m": {"uniform": [4.5, 5.5]},
    }
    base.update(changes)
    return DatasetSpec.from_toml(EXAMPLE).with_values(base)


def load(store: Path) -> xr.Dataset:
    return xr.open_zarr(store).load()


def assert_same_data(a: Path, b: Path) -> None:
    """Every array of the two stores is bit-identical, and so is the stored spec."""
    ga = zarr.open_group(str(a), mode="r", use_consolidated=False)
    gb = zarr.open_group(str(b), mode="r", use_consolidated=False)
    assert sorted(ga.array_keys()) == sorted(gb.array_keys())
    for name in ga.array_keys():
        np.testing.assert_array_equal(ga[name][...], gb[name][...], err_msg=name)
    assert ga.attrs["spec_sha256"] == gb.attrs["spec_sha256"]


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[DatasetSpec, Path]:
    """The tiny spec generated uninterrupted in this process."""
    spec = tiny_spec()
    store = tmp_path_factory.mktemp("ref") / "ref.zarr"
    generate(spec, store, workers=1, progress=False)
    return spec, store


@pytest.fixture
def copy_of(reference, tmp_path) -> Path:
    dst = tmp_path / "copy.zarr"
    shutil.copytree(reference[1], dst)
    return dst


# -------------------------------------------------------------------------------- spec


def test_example_spec_round_trips_through_canonical_toml():
    spec = DatasetSpec.from_toml(EXAMPLE)
    again = DatasetSpec.from_toml_string(spec.to_toml())
    assert again == spec
    assert again.sha256 == spec.sha256
    assert spec.to_dict()["sonar"]["beamwidth_deg"] == {"choice": [20.0, 30.0, 40.0]}


def test_spec_rejects_unknown_key_and_names_it():
    with pytest.raises(SpecError, match=r"'bandwidth_hz' in \[sonar\]"):
        DatasetSpec.from_dict({"sonar": {"bandwidth_hz": [60e3, 80e3]}})


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"sonar.beamwidth_deg": {"uniform": [10.0, 200.0]}}, r"sonar\.beamwidth_deg must be"),
        ({"leaves.radius_mean_m": -0.01}, r"leaves\.radius_mean_m must be in \(0"),
        ({"sonar.band_hz": [60e3, 300e3]}, r"Nyquist"),
        ({"leaves.radius_min_m": 1e-4}, r"leaves\.radius_min_m .*\(k a >= 0\.5\)"),
        ({"scene.reuse": "pool", "scene.pool_size": 99}, r"scene\.pool_size = 99 exceeds"),
        ({"poses.path": "line", "poses.run_length_m": 20.0}, r"poses\.run_length_m"),
        ({"sonar.beamwidth_deg": {"normal": [30.0, 5.0]}}, r"unknown distribution 'normal'"),
        ({"n_samples": 2.5}, r"n_samples must be an integer"),
        ({"n_samples": 10**11}, r"n_samples = 100000000000: .* over batecho's memory limit"),
        ({"scene.kind": "jungle"}, r"scene\.kind must be one of"),
    ],
)
def test_spec_rejects_bad_values_naming_the_key(changes, match):
    with pytest.raises(SpecError, match=match):
        tiny_spec(**changes)


def test_dist_draws_stay_in_their_support():
    rng = np.random.default_rng(0)
    for d in (Dist.uniform(2.0, 3.0), Dist.loguniform(0.1, 10.0), Dist.choice(1.0, 5.0)):
        draws = np.array([d.draw(rng) for _ in range(200)])
        assert draws.min() >= d.low and draws.max() <= d.high


def test_sample_seed_is_child_i_of_the_spec_seed_spawn():
    spec = tiny_spec()
    children = np.random.SeedSequence(spec.seed).spawn(spec.n_samples)
    for i in (0, 5, spec.n_samples - 1):
        a = np.random.default_rng(sample_seed(spec, i)).random(4)
        b = np.random.default_rng(children[i]).random(4)
        np.testing.assert_array_equal(a, b)


# -------------------------------------------------------------------- determinism


def test_process_pool_gives_the_same_arrays_as_one_process(reference, tmp_path):
    spec, ref = reference
    report = generate(spec, tmp_path / "pool.zarr", workers=2, progress=False)
    assert report.runner == "2 local processes"
    assert_same_data(ref, tmp_path / "pool.zarr")


def test_two_worker_local_cluster_gives_the_same_arrays_as_one_process(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    spec, ref = reference
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={"RAYON_NUM_THREADS": "1"},
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        report = generate(spec, tmp_path / "dask.zarr", client=client, progress=False)
    assert report.runner.startswith("dask scheduler")
    assert_same_data(ref, tmp_path / "dask.zarr")


# ----------------------------------------------------------------- nothing lost/doubled

# The run to kill: in-process, slowed down after each chunk so the kill lands part-way.
_KILL_SCRIPT = """
import sys, time
import batecho.dataset.pipeline as gen
from batecho.dataset import DatasetSpec, generate

def slow_write(*args, _write=gen.write_chunk):
    marker = _write(*args)
    time.sleep(0.2)
    return marker

gen.write_chunk = slow_write
spec = DatasetSpec.from_toml_string(open(sys.argv[1]).read())
generate(spec, sys.argv[2], workers=1, progress=False)
"""


def _markers(store: Path) -> np.ndarray | None:
    try:
        g = zarr.open_group(str(store), mode="r", use_consolidated=False)
        return np.asarray(g["chunk_checksum"][:])
    except Exception:
        return None


def test_killed_run_resumes_to_a_complete_store_identical_to_an_uninterrupted_one(tmp_path):
    spec = tiny_spec(n_samples=40, pulses_per_sample=2, **{"output.chunk_size": 2})
    (tmp_path / "spec.toml").write_text(spec.to_toml())
    store = tmp_path / "killed.zarr"
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILL_SCRIPT, str(tmp_path / "spec.toml"), str(store)],
        start_new_session=True,  # its own process group, killed whole
    )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            m = _markers(store)
            if m is not None and np.count_nonzero(m) >= 3:
                break
            time.sleep(0.005)
        assert proc.poll() is None, f"the run ended before it was killed (rc {proc.returncode})"
        os.killpg(proc.pid, signal.SIGKILL)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=30)
    done_at_kill = np.count_nonzero(_markers(store))
    assert 0 < done_at_kill < spec.n_chunks, "the run was not killed part-way"
    with pytest.raises(DatasetError, match="incomplete"):
        verify(store)

    report = generate(spec, store, workers=1, progress=False)
    assert report.chunks_skipped >= done_at_kill
    assert report.chunks_computed == spec.n_chunks - report.chunks_skipped
    verify(store)
    generate(spec, tmp_path / "whole.zarr", workers=1, progress=False)
    assert_same_data(store, tmp_path / "whole.zarr")


def test_chunk_written_but_not_marked_is_recomputed_on_resume(reference, copy_of):
    spec, ref = reference
    g = zarr.open_group(str(copy_of), mode="r+", use_consolidated=False)
    g["impulse"][3:6] = np.zeros((3, *g["impulse"].shape[1:]), dtype=np.float32)
    g["chunk_checksum"][1] = 0  # the crash came between the data and its marker
    report = generate(spec, copy_of, workers=1, progress=False)
    assert report.chunks_computed == 1 and report.chunks_skipped == spec.n_chunks - 1
    verify(copy_of)
    assert_same_data(ref, copy_of)


def test_rerun_on_a_complete_store_computes_nothing(reference, copy_of):
    report = generate(reference[0], copy_of, workers=2, progress=False)
    assert report.chunks_computed == 0 and report.samples_computed == 0


# --------------------------------------------------------------- refusing bad stores


def test_verify_accepts_a_complete_store(reference):
    report = verify(reference[1])
    assert report.n_samples == reference[0].n_samples and report.deep


def test_verify_refuses_a_zarr_store_not_made_by_batecho(tmp_path):
    g = zarr.open_group(str(tmp_path / "foreign.zarr"), mode="w")
    g.create_array("impulse", shape=(4, 10), dtype="float32")
    with pytest.raises(DatasetError, match="not a batecho dataset"):
        verify(tmp_path / "foreign.zarr")


def test_generate_refuses_to_write_into_a_foreign_zarr_store(tmp_path):
    g = zarr.open_group(str(tmp_path / "foreign.zarr"), mode="w")
    g.create_array("other", shape=(4,), dtype="float32")
    with pytest.raises(DatasetError, match="not a batecho dataset"):
        generate(tiny_spec(), tmp_path / "foreign.zarr", workers=1, progress=False)


def test_generate_refuses_a_directory_that_is_not_a_zarr_store(tmp_path):
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "readme.txt").write_text("keep me")
    with pytest.raises(DatasetError, match="not a zarr store"):
        generate(tiny_spec(), tmp_path / "notes", workers=1, progress=False)
    assert (tmp_path / "notes" / "readme.txt").read_text() == "keep me"


def test_verify_refuses_a_store_whose_spec_was_altered(copy_of):
    g = zarr.open_group(str(copy_of), mode="r+", use_consolidated=False)
    g.attrs["spec_toml"] = g.attrs["spec_toml"].replace("seed = 2017", "seed = 2018")
    with pytest.raises(DatasetError, match="does not match its SHA-256"):
        verify(copy_of)


def test_verify_refuses_a_store_with_a_chunk_missing(copy_of):
    chunk_files = sorted((copy_of / "impulse" / "c").glob("2/**/*"))
    files = [p for p in chunk_files if p.is_file()]
    assert files, "expected the impulse chunk 2 on disk"
    for p in files:
        p.unlink()
    with pytest.raises(DatasetError, match="chunk 2 .*does not match its checksum"):
        verify(copy_of)


def test_verify_refuses_a_store_with_altered_data(copy_of):
    g = zarr.open_group(str(copy_of), mode="r+", use_consolidated=False)
    g["n_leaves"][7, 0] = g["n_leaves"][7, 0] + 1
    with pytest.raises(DatasetError, match="chunk 2 .*does not match its checksum"):
        verify(copy_of)


def test_verify_refuses_an_incomplete_store(copy_of):
    g = zarr.open_group(str(copy_of), mode="r+", use_consolidated=False)
    g["chunk_checksum"][0] = 0
    with pytest.raises(DatasetError, match=r"incomplete: 1 of 4 chunks .*\[0\]"):
        verify(copy_of, deep=False)


def test_resume_with_a_different_spec_is_refused_naming_the_change(reference, copy_of):
    other = reference[0].with_values({"sonar.n_samples": 3200})
    with pytest.raises(SpecMismatchError, match=r"sonar\.n_samples: stored 3000, given 3200"):
        generate(other, copy_of, workers=1, progress=False)


# --------------------------------------------------------------------- the xarray view


def test_store_opens_in_xarray_with_named_dims_coords_and_units(reference):
    spec, store = reference
    ds = open_dataset(store)
    n, p = spec.n_samples, spec.pulses_per_sample
    assert ds["impulse"].dims == ("sample", "pulse", "time")
    assert ds["impulse"].shape == (n, p, spec.sonar.n_samples)
    assert ds["spectrum"].dims == ("sample", "pulse", "freq")
    assert ds["position"].dims == ("sample", "pulse", "xyz")
    assert ds["density_per_m3"].dims == ("sample",)
    assert ds["time"].attrs["units"] == "s" and ds["range"].attrs["units"] == "m"
    assert ds["freq"].attrs["units"] == "Hz" and ds["nearest_range_m"].attrs["units"] == "m"
    np.testing.assert_allclose(ds["time"].values, np.arange(spec.sonar.n_samples) / 200e3)
    np.testing.assert_allclose(ds["range"].values, 340.0 * ds["time"].values / 2)
    assert ds["freq"].values[0] == 60e3 and ds["freq"].values[-1] == 80e3
    assert ds["impulse"].chunks[0] == (3, 3, 3, 3)
    assert DatasetSpec.from_toml_string(ds.attrs["spec_toml"]) == spec
    assert ds.attrs["spec_sha256"] == spec.sha256


def test_crop_range_stores_only_that_part_of_the_record(tmp_path):
    spec = tiny_spec(n_samples=3, **{"sonar.crop_range_m": [1.0, 2.0]})
    generate(spec, tmp_path / "crop.zarr", workers=1, progress=False)
    ds = open_dataset(tmp_path / "crop.zarr")
    assert ds["range"].values.min() >= 1.0 and ds["range"].values.max() <= 2.0
    full = draw_sample(spec, 1).echoes
    t0, t1 = spec.sonar.time_slice()
    np.testing.assert_array_equal(
        ds["impulse"].values[1], full.impulse[:, t0:t1].astype(np.float32)
    )


# ------------------------------------------------------------------------------ labels


def test_stored_labels_agree_with_simulate_for_each_sample(reference):
    spec, store = reference
    ds = load(store)
    for i in (0, 4, 11):
        s = draw_sample(spec, i)
        echoes = batecho.simulate(s.scene.scene, s.sonar, s.poses)
        np.testing.assert_array_equal(ds["n_leaves"].values[i], echoes.n_leaves)
        np.testing.assert_array_equal(ds["impulse"].values[i], echoes.impulse.astype(np.float32))
        np.testing.assert_array_equal(ds["position"].values[i], s.poses.positions)
        leaves = s.scene.scene.leaves
        for k in range(spec.pulses_per_sample):
            idx = batecho.lobe_members(leaves, s.sonar, s.poses[k], search="brute_force")
            assert idx.size == ds["n_leaves"].values[i, k]
            if idx.size:
                d = np.linalg.norm(leaves.centers[idx] - s.poses.positions[k], axis=1)
                assert ds["nearest_range_m"].values[i, k] == d.min()
                assert d.min() <= spec.sonar.make(30.0).record_range_m
            else:
                assert np.isnan(ds["nearest_range_m"].values[i, k])
        assert ds["n_leaves_scene"].values[i] == len(leaves)
        assert ds["beamwidth_deg"].values[i] in (20.0, 30.0, 40.0)


def test_some_pulses_hear_leaves(reference):
    ds = load(reference[1])
    assert (ds["n_leaves"].values > 0).mean() > 0.5


def test_leaf_density_label_follows_the_drawn_density(reference):
    ds = load(reference[1])
    np.testing.assert_allclose(
        ds["leaf_density_per_m3"].values, ds["density_per_m3"].values, atol=1 / 144 + 1e-12
    )


def test_pooled_scenes_are_shared_by_consecutive_samples():
    spec = tiny_spec(**{"scene.reuse": "pool", "scene.pool_size": 3})
    assert [spec.scene_index(i) for i in range(12)] == [0] * 4 + [1] * 4 + [2] * 4
    a, b, c = draw_sample(spec, 4), draw_sample(spec, 7), draw_sample(spec, 8)
    np.testing.assert_array_equal(a.scene.scene.leaves.centers, b.scene.scene.leaves.centers)
    assert a.labels["density_per_m3"] != c.labels["density_per_m3"]


def test_random_poses_lie_in_the_scene_bounding_box():
    spec = tiny_spec(**{"poses.mode": "random", "poses.pitch_deg": {"uniform": [-20, 20]}})
    for i in range(4):
        s = draw_sample(spec, i)
        lo, hi = s.scene.bounds
        assert np.all(s.poses.positions >= lo) and np.all(s.poses.positions <= hi)
        assert np.all(np.abs(s.poses.forward[:, 2]) <= np.sin(np.radians(20)) + 1e-12)


def test_line_flight_runs_toward_the_scene_centre():
    spec = tiny_spec(
        **{"poses.path": "line", "poses.start_distance_m": 9.0, "poses.run_length_m": 4.0}
    )
    s = draw_sample(spec, 0)
    c = s.scene.center[:2]
    dist = np.linalg.norm(s.poses.positions[:, :2] - c, axis=1)
    np.testing.assert_allclose(dist, [9.0, 7.0, 5.0])


# ------------------------------------------------------------------------------ forest


def forest_spec(**changes) -> DatasetSpec:
    """A small forest: about 5 trees (one variant) on 10 m x 10 m, circled at 3 m altitude."""
    base = {
        "n_samples": 2,
        "pulses_per_sample": 2,
        "output.chunk_size": 1,
        "scene.kind": "forest",
        "scene.forest.intensity": "homogeneous",
        "scene.forest.intensity_scale": 0.05,
        "scene.forest.window_m": [0.0, 10.0, 0.0, 10.0],
        "scene.forest.variants": 1,
        "scene.forest.tree_params": {"trunk_height": {"uniform": [3.0, 5.0]}},
        "poses.altitude_m": 3.0,
        "poses.circle_radius_m": 6.2,
    }
    base.update(changes)
    return tiny_spec(**base)


def test_forest_spec_with_drawn_tree_params_round_trips_through_toml():
    spec = forest_spec()
    assert DatasetSpec.from_toml_string(spec.to_toml()) == spec
    assert spec.scene.forest.tree_params["trunk_height"] == Dist.uniform(3.0, 5.0)
    assert "tree_params = { trunk_height = { uniform = [3.0, 5.0] } }" in spec.to_toml()


def test_forest_dataset_generates_verifies_and_labels_its_draws(tmp_path):
    spec = forest_spec()
    generate(spec, tmp_path / "forest.zarr", workers=1, progress=False)
    verify(tmp_path / "forest.zarr")
    ds = load(tmp_path / "forest.zarr")
    assert (ds["n_trees"].values >= 1).all() and (ds["n_leaves_scene"].values > 0).all()
    h = ds["tree_trunk_height"].values
    assert ((h >= 3.0) & (h <= 5.0)).all()
    s = draw_sample(spec, 1)
    echoes = batecho.simulate(s.scene.scene, s.sonar, s.poses)
    np.testing.assert_array_equal(ds["n_leaves"].values[1], echoes.n_leaves)


def test_plain_progress_line_is_written_when_tqdm_is_missing(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # import fails
    generate(tiny_spec(n_samples=3), tmp_path / "p.zarr", workers=1, progress=True)
    assert "3/3 samples (100%)" in capsys.readouterr().err


# --------------------------------------------------------------------------------- CLI


def test_cli_generates_and_verifies_a_tiny_spec(tmp_path, capsys):
    spec_path = tmp_path / "tiny.toml"
    spec_path.write_text(tiny_spec(n_samples=4, pulses_per_sample=1).to_toml())
    out = tmp_path / "cli.zarr"
    assert cli_main(["generate", str(spec_path), str(out), "--workers", "1", "--quiet"]) == 0
    assert cli_main(["verify", str(out)]) == 0
    assert "OK - 4 samples" in capsys.readouterr().out


def test_cli_generate_takes_q_for_quiet_as_the_other_commands_do(tmp_path, capsys):
    spec_path = tmp_path / "tiny.toml"
    spec_path.write_text(tiny_spec(n_samples=2, pulses_per_sample=1).to_toml())
    assert (
        cli_main(["generate", str(spec_path), str(tmp_path / "q.zarr"), "--workers", "1", "-q"])
        == 0
    )
    assert "samples" not in capsys.readouterr().err  # (no progress bar)


def test_cli_verify_exits_1_naming_the_problem_on_a_corrupt_store(copy_of, capsys):
    g = zarr.open_group(str(copy_of), mode="r+", use_consolidated=False)
    g["chunk_checksum"][3] = 0
    assert cli_main(["verify", str(copy_of)]) == 1
    assert "incomplete" in capsys.readouterr().err


def test_cli_reports_a_bad_spec_file_with_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("n_samples = 4\n[sonar]\nfs = -1.0\n")
    assert cli_main(["generate", str(bad), str(tmp_path / "x.zarr"), "--quiet"]) == 2
    assert "sonar.fs must be in (0, inf]" in capsys.readouterr().err


def test_module_entry_point_runs_the_cli(tmp_path):
    spec_path = tmp_path / "tiny.toml"
    spec_path.write_text(tiny_spec(n_samples=2, pulses_per_sample=1).to_toml())
    out = tmp_path / "m.zarr"
    for argv in (["generate", str(spec_path), str(out), "--workers", "1"], ["verify", str(out)]):
        r = subprocess.run(
            [sys.executable, "-m", "batecho.dataset.cli", *argv],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert r.returncode == 0, r.stderr


# ------------------------------------------------------------------ wood and shading


def wood_spec(**changes) -> DatasetSpec:
    """A forest with its branches, shading sonar, 3 samples of 2 pulses."""
    base = {
        "n_samples": 3,
        "pulses_per_sample": 2,
        "output.chunk_size": 3,
        "scene.forest.branches": True,
        "sonar.shading": True,
        "sonar.leaf_transmission": 0.5,
    }
    base.update(changes)
    return forest_spec(**base)


def test_a_spec_without_wood_or_shading_keeps_its_canonical_text_and_layout():
    spec = tiny_spec()
    assert "shading" not in spec.to_toml() and "branches" not in spec.to_toml()
    names = [v.name for v in batecho.dataset.store.schema(spec)]
    assert "n_shaded" not in names and "nearest_wood_m" not in names
    assert "shading = false" in DatasetSpec().to_toml(full=True)
    assert DatasetSpec.from_toml_string(wood_spec().to_toml()) == wood_spec()


def test_branches_need_a_forest_scene():
    with pytest.raises(SpecError, match="scene.forest.branches"):
        tiny_spec(**{"scene.forest.branches": True})


def test_wood_and_shading_labels_agree_with_simulate_and_the_geometry(tmp_path):
    spec = wood_spec()
    generate(spec, tmp_path / "wood.zarr", workers=1, progress=False)
    verify(tmp_path / "wood.zarr")
    ds = load(tmp_path / "wood.zarr")
    for i in range(spec.n_samples):
        s = draw_sample(spec, i)
        assert s.sonar.shading == batecho.Shading(0.5, True)
        wood = s.scene.scene.branches
        assert wood is not None and len(wood) > 1000
        echoes = batecho.simulate(s.scene.scene, s.sonar, s.poses)
        np.testing.assert_array_equal(ds["n_shaded"].values[i], echoes.n_shaded)
        np.testing.assert_array_equal(ds["n_pieces"].values[i], echoes.n_pieces)
        for k in range(spec.pulses_per_sample):
            p = s.poses.positions[k]
            d = np.linalg.norm(wood.starts - p, axis=1).min()
            assert 0.0 < ds["nearest_wood_m"].values[i, k] <= d
    assert (ds["n_shaded"].values <= ds["n_leaves"].values).all()
    assert ds["n_shaded"].values.sum() > 0
    assert ds["nearest_wood_m"].attrs["units"] == "m"


def test_a_wooded_store_of_spectra_holds_the_woods_share_of_each(tmp_path):
    spec = wood_spec(
        n_samples=1, **{"output.chunk_size": 1, "output.spectrum": True, "output.dtype": "float64"}
    )
    generate(spec, tmp_path / "wood.zarr", workers=1, progress=False)
    verify(tmp_path / "wood.zarr")
    ds = load(tmp_path / "wood.zarr")
    echoes = draw_sample(spec, 0).echoes
    assert ds["wood_spectrum"].dims == ("sample", "pulse", "freq")
    assert np.any(echoes.wood_spectrum != 0.0)
    np.testing.assert_array_equal(ds["wood_spectrum"].values[0], echoes.wood_spectrum)


def test_a_store_of_spectra_without_branches_has_no_wood_spectrum():
    names = [v.name for v in batecho.dataset.store.schema(tiny_spec(**{"output.spectrum": True}))]
    assert "spectrum" in names and "wood_spectrum" not in names
