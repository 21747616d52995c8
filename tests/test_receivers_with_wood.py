"""Receivers at their own places hear leaves only: with branches or shading they are refused
with an error naming both, in simulate and in dataset specs, rather than heard wrongly."""

from __future__ import annotations

import pytest

import batecho
from batecho import Branches, Leaves, Poses, Scene, Shading, Sonar

LEAVES = Leaves([[3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.03])
TRUNK = Branches([[5.0, 0.0, -2.0]], [[5.0, 0.0, 2.0]], [0.1])
POSE = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def test_two_ears_with_a_shading_sonar_are_refused_naming_both():
    ears = Sonar.binaural(0.02, ear_yaw_deg=20, beamwidth_deg=40, shading=Shading())
    with pytest.raises(ValueError, match="receivers.*shading"):
        batecho.simulate(Scene(LEAVES), ears, POSE)


def test_two_ears_in_a_scene_with_branches_are_refused_naming_both():
    ears = Sonar.binaural(0.02, ear_yaw_deg=20, beamwidth_deg=40)
    with pytest.raises(ValueError, match="receivers.*branches"):
        batecho.simulate(Scene(LEAVES, branches=TRUNK), ears, POSE)


def test_two_ears_in_a_leaf_scene_without_shading_still_hear():
    ears = Sonar.binaural(0.02, ear_yaw_deg=20, beamwidth_deg=40)
    echo = batecho.simulate(Scene(LEAVES), ears, POSE)
    assert echo.n_leaves.shape == (1, 2) and echo.n_leaves.sum() > 0


def test_a_dataset_spec_with_two_ears_and_shading_is_refused():
    from batecho.dataset import DatasetSpec, SpecError

    with pytest.raises(SpecError, match="ear_separation_m.*shading"):
        DatasetSpec.from_dict(
            {
                "n_samples": 2,
                "sonar": {"ear_separation_m": 0.02, "ear_yaw_deg": 20.0, "shading": True},
            }
        )
