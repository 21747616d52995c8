"""Wood and shading in scene files: ``[scene] branches = true`` gives the trees' woody skeletons
(``Forest.scene(branches=True)``), which echo in the run and are written to ``echoes.npz`` with
the shading counts; the key is refused where there are no trees, and off by default."""

from __future__ import annotations

import numpy as np
import pytest

from batecho.scenefile import SceneFile, ScenefileError, run_scenefile, setup_scenefile

FOREST = """\
seed = 4
[scene]
kind = "forest"
model = "lsystem"
positions = [[0.0, 0.0], [5.0, 0.0]]
variants = 1
{branches}
[sonar]
beamwidth_deg = 40
[sonar.shading]
leaf_transmission = 0.5

[flight]
path = "circle"
radius = 7.0
altitude = 3.0
heading = "center"
n_pulses = 3

[output]
plots = []
"""


def forest(branches: str = "") -> SceneFile:
    return SceneFile.from_string(FOREST.format(branches=branches))


def test_branches_true_puts_the_trees_skeletons_in_the_scene():
    with_wood = setup_scenefile(forest("branches = true"))
    assert with_wood.scene.branches is not None and len(with_wood.scene.branches) > 10
    assert with_wood.scene.branches == with_wood.scene_object.scene(branches=True).branches


def test_without_the_key_the_scene_holds_leaves_alone():
    assert setup_scenefile(forest()).scene.branches is None
    assert setup_scenefile(forest("branches = false")).scene.branches is None


def test_a_run_with_branches_writes_the_woods_echo_and_the_shading_counts(tmp_path):
    res = run_scenefile(forest("branches = true"), tmp_path, plots=False)
    with np.load(tmp_path / "echoes.npz") as f:
        assert f["n_pieces"].shape == (3,) and f["n_pieces"].sum() > 0
        assert f["wood_spectrum"].shape == res.echoes.spectrum.shape
        assert np.abs(f["wood_spectrum"]).max() > 0
        np.testing.assert_array_equal(f["n_shaded"], res.echoes.n_shaded)


def test_branches_in_a_leaf_box_are_refused_naming_the_key():
    text = '[scene]\nkind = "leaf_box"\ndensity_per_m3 = 3.0\nbranches = true\n'
    with pytest.raises(ScenefileError, match=r"\[scene\] branches.*leaf_box"):
        SceneFile.from_string(text)


def test_branches_must_be_a_boolean():
    with pytest.raises(ScenefileError, match="branches"):
        forest('branches = "yes"')
