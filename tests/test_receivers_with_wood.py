"""Receivers at their own places hear leaves only: with branches they are refused with an error
naming both, rather than heard wrongly (shading with receivers: tests/test_receivers_shading.py)."""

from __future__ import annotations

import pytest

import batecho
from batecho import Branches, Leaves, Poses, Scene, Sonar

LEAVES = Leaves([[3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.03])
TRUNK = Branches([[5.0, 0.0, -2.0]], [[5.0, 0.0, 2.0]], [0.1])
POSE = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def test_two_ears_in_a_scene_with_branches_are_refused_naming_both():
    ears = Sonar.binaural(0.02, ear_yaw_deg=20, beamwidth_deg=40)
    with pytest.raises(ValueError, match="receivers.*branches"):
        batecho.simulate(Scene(LEAVES, branches=TRUNK), ears, POSE)


def test_two_ears_in_a_leaf_scene_without_shading_still_hear():
    ears = Sonar.binaural(0.02, ear_yaw_deg=20, beamwidth_deg=40)
    echo = batecho.simulate(Scene(LEAVES), ears, POSE)
    assert echo.n_leaves.shape == (1, 2) and echo.n_leaves.sum() > 0
