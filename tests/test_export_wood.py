"""The exports carry the wood and the shading (docs/model.md §9, §10): with branches in the
scene the xarray Dataset and the MAT file hold ``wood_spectrum`` and ``n_pieces``, when the
sonar shades ``n_shaded``, each with a receiver dimension, read back as written; echoes
without branches or shading keep exactly the variables they had."""

from __future__ import annotations

import numpy as np
import pytest

import batecho
from batecho import Branches, Leaves, Poses, Scene, Shading, Sonar

POSES = Poses([[0.0, 0.0, 0.0], [0.4, 0.1, 0.0]], [[1.0, 0.0, 0.0], [1.0, 0.05, 0.0]])
SHADED = Sonar(beamwidth_deg=60.0, shading=Shading(leaf_transmission=0.6))

#: The Dataset's variables for echoes without branches or shading.
PLAIN_VARS = {"impulse", "spectrum", "n_leaves", "position", "forward", "up", "left"}


def grove() -> Scene:
    """Leaves 2-5 m ahead with a trunk among them."""
    rng = np.random.default_rng(7)
    c = np.column_stack([rng.uniform(2.0, 5.0, 40), rng.uniform(-0.8, 0.8, (40, 2))])
    leaves = Leaves(c, rng.normal(size=(40, 3)), rng.uniform(0.02, 0.05, 40))
    trunk = Branches([[3.5, 0.2, -2.0]], [[3.5, 0.2, 2.0]], [0.1])
    return Scene(leaves, branches=trunk)


@pytest.fixture(scope="module")
def wood():
    """Shaded echoes of the grove, one receiver at the emitter."""
    return batecho.simulate(grove(), SHADED, POSES)


@pytest.fixture(scope="module")
def wood_two_ears():
    """Shaded echoes of the grove heard by two ears."""
    return batecho.simulate(
        grove(), SHADED.replace(receivers=Sonar.binaural(0.02, 30.0).receivers), POSES
    )


@pytest.fixture(scope="module")
def leaves_only():
    """Echoes of the grove's leaves, no shading."""
    return batecho.simulate(grove().leaves, Sonar(beamwidth_deg=60.0), POSES)


def _zarr_round_trip(ds, path):
    import xarray as xr

    ds.to_zarr(path, consolidated=False)
    return xr.open_zarr(path, consolidated=False).load()


def test_the_dataset_of_leaves_without_shading_keeps_its_variables(leaves_only):
    assert set(leaves_only.to_xarray().data_vars) == PLAIN_VARS


def test_the_dataset_of_unshaded_wood_has_no_n_shaded():
    echoes = batecho.simulate(grove(), Sonar(beamwidth_deg=60.0), POSES)
    assert set(echoes.to_xarray().data_vars) == PLAIN_VARS | {"wood_spectrum", "n_pieces"}


def test_the_wood_spectrum_round_trips_through_zarr_with_dims_and_units(wood, tmp_path):
    assert wood.wood_spectrum is not None and np.any(wood.wood_spectrum != 0.0)
    back = _zarr_round_trip(wood.to_xarray(), tmp_path / "e.zarr")
    assert back["wood_spectrum"].dims == ("pose", "receiver", "frequency")
    assert back["wood_spectrum"].attrs["units"] == "1"
    np.testing.assert_array_equal(back["wood_spectrum"].values[:, 0], wood.wood_spectrum)


def test_n_pieces_round_trips_through_zarr(wood, tmp_path):
    assert np.all(wood.n_pieces > 0)
    back = _zarr_round_trip(wood.to_xarray(), tmp_path / "e.zarr")
    assert back["n_pieces"].dims == ("pose", "receiver")
    np.testing.assert_array_equal(back["n_pieces"].values[:, 0], wood.n_pieces)


def test_n_shaded_round_trips_through_zarr(wood, tmp_path):
    assert np.any(wood.n_shaded > 0)
    back = _zarr_round_trip(wood.to_xarray(), tmp_path / "e.zarr")
    assert back["n_shaded"].dims == ("pose", "receiver")
    np.testing.assert_array_equal(back["n_shaded"].values[:, 0], wood.n_shaded)


def test_two_ears_keep_each_receivers_wood_and_shading(wood_two_ears):
    ds = wood_two_ears.to_xarray()
    assert list(ds["receiver"].values) == ["left", "right"]
    np.testing.assert_array_equal(ds["wood_spectrum"].values, wood_two_ears.wood_spectrum)
    np.testing.assert_array_equal(ds["n_pieces"].values, wood_two_ears.n_pieces)
    np.testing.assert_array_equal(ds["n_shaded"].values, wood_two_ears.n_shaded)


def test_one_receivers_echoes_keep_its_wood(wood_two_ears):
    right = wood_two_ears.for_receiver(1)
    ds = right.to_xarray()
    assert list(ds["receiver"].values) == ["right"]
    np.testing.assert_array_equal(ds["wood_spectrum"].values[:, 0], right.wood_spectrum)


def test_the_mat_file_carries_the_wood_and_shading(wood_two_ears, tmp_path):
    from scipy.io import loadmat

    m = loadmat(wood_two_ears.to_mat(tmp_path / "e.mat"))
    np.testing.assert_array_equal(m["wood_spectrum"], wood_two_ears.wood_spectrum)
    np.testing.assert_array_equal(m["n_pieces"], wood_two_ears.n_pieces)
    np.testing.assert_array_equal(m["n_shaded"], wood_two_ears.n_shaded)


def test_the_mat_file_of_leaves_without_shading_has_no_wood_or_shading(leaves_only, tmp_path):
    from scipy.io import loadmat

    m = loadmat(leaves_only.to_mat(tmp_path / "e.mat"))
    assert not {"wood_spectrum", "n_pieces", "n_shaded"} & set(m)
