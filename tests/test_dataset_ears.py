"""Datasets with two ears and a call: the spec asks for them, the Zarr store gains a receiver
dimension and a ``received`` variable, and the stored arrays are the library's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from batecho.dataset import DatasetSpec, SpecError, draw_sample, generate, open_dataset, verify

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "dataset-small.toml"


def ears_spec(**changes) -> DatasetSpec:
    base = {
        "n_samples": 4,
        "pulses_per_sample": 2,
        "output.chunk_size": 2,
        "sonar.fs": 200e3,
        "sonar.n_samples": 3000,
        "sonar.ear_separation_m": 0.02,
        "sonar.ear_yaw_deg": 30.0,
        "call": {
            "kind": "linear_fm",
            "f_start_hz": 80e3,
            "f_end_hz": 60e3,
            "duration_s": 1e-3,
            "noise_rms": 1e-7,
        },
    }
    base.update(changes)
    return DatasetSpec.from_toml(EXAMPLE).with_values(base)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp("ears") / "ears.zarr"
    generate(ears_spec(), out, workers=1)
    return out


def test_the_store_has_a_receiver_dimension_and_the_received_call(store):
    ds = open_dataset(store)
    n, p = 4, 2
    assert ds["impulse"].dims == ("sample", "pulse", "receiver", "time")
    assert ds["impulse"].shape == (n, p, 2, 3000)
    assert ds["received"].dims == ("sample", "pulse", "receiver", "time")
    assert ds["spectrum"].dims == ("sample", "pulse", "receiver", "freq")
    assert ds["n_leaves"].dims == ("sample", "pulse", "receiver")
    assert ds["position"].dims == ("sample", "pulse", "xyz")
    assert ds["receiver"].values.tolist() == [0, 1]
    assert verify(store).n_samples == n  # (raises on any problem)


def test_the_stored_sample_is_the_librarys(store):
    spec = ears_spec()
    s = draw_sample(spec, 2)
    ds = open_dataset(store)
    assert s.sonar.n_receivers == 2
    assert np.array_equal(ds["impulse"].values[2], s.echoes.impulse.astype(np.float32))
    assert np.array_equal(ds["n_leaves"].values[2], s.echoes.n_leaves)
    assert s.received is not None
    assert np.array_equal(ds["received"].values[2], s.received.astype(np.float32))
    # the received call is the impulse response convolved with the call, plus the noise
    call = spec.call.make(s.sonar.fs)
    noise = s.received - s.echoes.received(call)
    assert 0.5e-7 < noise.std() < 1.5e-7


def test_one_ear_specs_keep_their_canonical_form():
    plain = DatasetSpec.from_toml(EXAMPLE)
    assert "ear_" not in plain.to_toml() and "[call]" not in plain.to_toml()
    assert "[call]" in ears_spec().to_toml()
    assert DatasetSpec.from_toml_string(ears_spec().to_toml()) == ears_spec()


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"sonar.ear_yaw_deg": 20.0, "sonar.ear_separation_m": None}, "only with"),
        ({"call": {"kind": "cf_fm", "duration_s": 1e-2, "f_cf_hz": 7e4}}, "fm_end_hz"),
        ({"call": {"kind": "linear_fm", "duration_s": 1e-3, "f_start_hz": 7e4}}, "f_end_hz"),
        (
            {"call": {"kind": "linear_fm", "duration_s": 1e-3, "f_start_hz": 2e5, "f_end_hz": 6e4}},
            "Nyquist",
        ),
    ],
)
def test_bad_ear_and_call_specs_are_refused_by_key(changes, match):
    with pytest.raises(SpecError, match=match):
        ears_spec(**changes)


def test_two_ears_in_a_forest_with_branches_store_each_ears_pieces(tmp_path):
    spec = ears_spec(
        **{
            "n_samples": 2,
            "output.chunk_size": 1,
            "scene.kind": "forest",
            "scene.forest.intensity": "homogeneous",
            "scene.forest.intensity_scale": 0.05,
            "scene.forest.window_m": [0.0, 10.0, 0.0, 10.0],
            "scene.forest.variants": 1,
            "scene.forest.tree_params": {"trunk_height": {"uniform": [3.0, 5.0]}},
            "scene.forest.branches": True,
            "poses.altitude_m": 3.0,
            "poses.circle_radius_m": 6.2,
        }
    )
    generate(spec, tmp_path / "wood.zarr", workers=1, progress=False)
    ds = open_dataset(tmp_path / "wood.zarr")
    assert ds["n_pieces"].dims == ("sample", "pulse", "receiver")
    assert ds["nearest_wood_m"].dims == ("sample", "pulse")
    s = draw_sample(spec, 1)
    assert np.array_equal(ds["n_pieces"].values[1], s.echoes.n_pieces)
    assert ds["n_pieces"].values.sum() > 0
