"""Tests for batecho.trees (reference tree, grow_tree, grow_lsystem_tree, load_tree), the
reference tree generator tools/make_reference_tree.py, and batecho.treeplots.plot_tree."""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import math
import sys
import warnings
from pathlib import Path

import matplotlib
import numpy as np
import pytest
from scipy.spatial import cKDTree

matplotlib.use("Agg")

import batecho
from batecho._resources import SlowWarning
from batecho.trees import (
    DEFAULT_LEAF_PATTERNS,
    REFERENCE_TREE,
    Tree,
    grow_lsystem_tree,
    grow_tree,
    load_reference,
    load_tree,
)
from batecho.trees.branching import trunk_branching
from batecho.trees.objfile import load_obj

ROOT = Path(__file__).resolve().parents[1]
GENERATOR = ROOT / "tools" / "make_reference_tree.py"
DATA_FILES = ("reference_tree.obj", "reference_tree.mtl", "reference_tree.json")
ZERO = {"length_sd": 0.0, "bend_sd_deg": 0.0, "droop_deg": 0.0, "slide_sd": 0.0}


def _generator_module():
    name = "_batecho_make_reference_tree"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, GENERATOR)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod  # dataclasses look their module up while the file runs
        spec.loader.exec_module(mod)
    return sys.modules[name]


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def generated(tmp_path_factory) -> Path:
    """The generator's output, written once into a temporary folder."""
    out = tmp_path_factory.mktemp("reference_a")
    assert _generator_module().main(["--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def tree() -> Tree:
    return grow_tree(np.random.default_rng(11))


@pytest.fixture(scope="module")
def zero_tree() -> Tree:
    return grow_tree(np.random.default_rng(5), **ZERO)


@pytest.fixture(scope="module")
def lsys_tree() -> Tree:
    return grow_lsystem_tree(np.random.default_rng(3))


# ---------------------------------------------------------------------------------------------
# The shipped reference tree and its generator
# ---------------------------------------------------------------------------------------------


def test_generator_writes_identical_bytes_twice(generated, tmp_path):
    assert _generator_module().main(["--out", str(tmp_path)]) == 0
    for name in DATA_FILES:
        assert (tmp_path / name).read_bytes() == (generated / name).read_bytes(), name


def test_shipped_reference_files_equal_the_generator_output(generated):
    for name in DATA_FILES:
        shipped = REFERENCE_TREE.parent / name
        assert _sha(shipped) == _sha(generated / name), (
            f"{shipped} differs from what tools/make_reference_tree.py writes; regenerate it"
        )


def test_shipped_reference_obj_is_at_most_3_mb():
    assert REFERENCE_TREE.stat().st_size <= 3_000_000


def test_shipped_reference_loads_with_1e4_to_5e4_leaves():
    mesh = load_obj(REFERENCE_TREE)
    assert 10_000 <= mesh.n_leaves <= 50_000


def test_shipped_reference_is_6_to_10_m_tall():
    lo, hi = load_obj(REFERENCE_TREE).bounds()
    assert lo[2] == pytest.approx(0.0, abs=1e-9)
    assert 6.0 <= hi[2] - lo[2] <= 10.0


def test_shipped_reference_has_named_trunk_branch_and_leaf_groups():
    mesh = load_obj(REFERENCE_TREE)
    names = set(mesh.group_names)
    branches = sorted(n for n in names if n.startswith("branch_"))
    assert "trunk" in names
    assert len(branches) >= 5
    assert {f"leaves_{b}" for b in branches} <= names
    leaf_names = {mesh.group_names[g] for g in np.unique(mesh.leaf_groups)}
    bark_names = {mesh.group_names[g] for g in np.unique(mesh.bark_face_groups)}
    assert leaf_names == {f"leaves_{b}" for b in branches}
    assert bark_names == {"trunk", *branches}


def test_shipped_reference_leaf_radii_are_about_2_5_cm():
    r = load_obj(REFERENCE_TREE).leaves.radii
    assert r.mean() == pytest.approx(0.025, abs=0.001)
    assert r.std() == pytest.approx(0.005, abs=0.001)


def test_reference_structure_comes_from_the_json_sidecar():
    ref = load_reference()
    mesh = load_obj(REFERENCE_TREE)
    assert ref.structure == "json"
    assert len(ref.branches) == len([n for n in mesh.group_names if n.startswith("branch_")])
    assert sum(len(b.leaf_radii) for b in ref.branches) == mesh.n_leaves
    for b in ref.branches:
        assert np.hypot(*b.base[:2]) < 1e-9  # axes start on the trunk axis
        assert b.n_units > 0 and (b.unit_anchors <= b.length + 1e-9).all()


def test_reference_tree_as_tree_reproduces_the_obj_leaves():
    mesh = load_obj(REFERENCE_TREE)
    t = load_reference().tree()
    a = np.sort(t.leaves.centers.view("f8,f8,f8"), axis=0)
    b = np.sort(mesh.leaves.centers.view("f8,f8,f8"), axis=0)
    assert np.array_equal(a, b)


# ---------------------------------------------------------------------------------------------
# grow_tree
# ---------------------------------------------------------------------------------------------


def test_grow_tree_same_seed_gives_identical_tree(tree):
    again = grow_tree(np.random.default_rng(11))
    assert np.array_equal(again.leaves.centers, tree.leaves.centers)
    assert np.array_equal(again.leaves.normals, tree.leaves.normals)
    assert np.array_equal(again.bark_vertices, tree.bark_vertices)
    assert np.array_equal(again.bark_faces, tree.bark_faces)


def test_grow_tree_int_seed_equals_generator_seed(tree):
    assert np.array_equal(grow_tree(11).leaves.centers, tree.leaves.centers)


def test_grow_tree_params_reproduce_the_tree(tree):
    gen = np.random.default_rng()
    gen.bit_generator.state = tree.params["rng_state"]
    assert np.array_equal(grow_tree(gen).leaves.centers, tree.leaves.centers)


def test_grow_tree_different_seeds_give_different_trees(tree):
    other = grow_tree(np.random.default_rng(12))
    assert other.leaves.centers.shape != tree.leaves.centers.shape or not np.allclose(
        other.leaves.centers, tree.leaves.centers
    )


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_grow_tree_is_6_to_10_m_tall_by_default(seed):
    assert 6.0 <= grow_tree(seed).height <= 10.0


def test_grow_tree_leaf_count_is_plausible(tree):
    assert 8_000 <= tree.n_leaves <= 40_000
    assert (tree.leaf_branch >= 0).all()
    assert set(np.unique(tree.leaf_branch)) == set(range(len(tree.branch_names)))


def test_grow_tree_normals_are_unit_and_radii_positive(tree):
    assert np.allclose(np.linalg.norm(tree.leaves.normals, axis=1), 1.0, atol=1e-12)
    assert (tree.leaves.radii > 0).all()
    assert np.isfinite(tree.leaves.centers).all()


def test_grow_tree_bark_faces_index_vertices_and_groups_are_named(tree):
    assert tree.bark_faces.dtype == np.int64
    assert tree.bark_faces.min() >= 0 and tree.bark_faces.max() < len(tree.bark_vertices)
    assert tree.bark_group_names == ("trunk", *tree.branch_names)
    assert set(np.unique(tree.bark_groups)) == set(range(len(tree.bark_group_names)))


def test_grow_tree_branches_start_at_lsystem_points_on_the_trunk(tree):
    lay = tree.layout
    assert len(lay) == len(tree.branch_names)
    for axis, origin in zip(lay.axes, lay.origins, strict=True):
        assert np.allclose(axis[0], origin)
    assert np.allclose(lay.origins[:, :2], 0.0)


def _kabsch(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Best rotation R with b ~ a R^T (both centred), and the largest residual."""
    h = a.T @ b
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, float(np.abs(a @ r.T - b).max())


def test_zero_randomisation_moves_each_reference_branch_rigidly(zero_tree):
    ref = load_reference()
    lay = zero_tree.layout
    for i in range(len(lay)):
        tpl = ref.branches[lay.reference_index[i]]
        grown = zero_tree.leaves.centers[zero_tree.leaf_branch == i] - lay.origins[i]
        r, resid = _kabsch(tpl.leaf_centers - tpl.base, grown)
        assert resid < 1e-9
        assert np.linalg.det(r) == pytest.approx(1.0)
        assert np.allclose(r @ tpl.chord, lay.directions[i], atol=1e-12)
        n = zero_tree.leaves.normals[zero_tree.leaf_branch == i]
        assert np.allclose(tpl.leaf_normals @ r.T, n, atol=1e-12)


def test_zero_randomisation_keeps_each_branch_upper_side_up(zero_tree):
    # the transport turns the azimuth, then the polar angle: heights above the chord, measured
    # in the vertical plane through it, are kept (no roll about the branch)
    ref = load_reference()
    lay = zero_tree.layout

    def up_of(d):
        u = np.array([0.0, 0.0, 1.0]) - d[2] * d
        return u / np.linalg.norm(u)

    for i in range(len(lay)):
        tpl = ref.branches[lay.reference_index[i]]
        h_ref = (tpl.leaf_centers - tpl.base) @ up_of(tpl.chord)
        grown = zero_tree.leaves.centers[zero_tree.leaf_branch == i] - lay.origins[i]
        assert np.allclose(grown @ up_of(lay.directions[i]), h_ref, atol=1e-9)


def test_length_scale_moves_each_tip_that_many_times_farther_along_the_axis(zero_tree):
    longer = grow_tree(np.random.default_rng(5), **ZERO, length_scale=1.2)
    a, b = zero_tree.layout, longer.layout
    assert np.allclose(b.origins, a.origins)
    assert np.allclose(b.tips - b.origins, 1.2 * (a.tips - a.origins), atol=1e-12)
    assert np.allclose(b.length_scales, 1.2)


def test_length_scale_keeps_sub_branches_their_size(zero_tree):
    longer = grow_tree(np.random.default_rng(5), **ZERO, length_scale=1.2)
    for c in np.unique(zero_tree.leaf_cluster)[::7]:
        m = zero_tree.leaf_cluster == c
        a = zero_tree.leaves.centers[m]
        b = longer.leaves.centers[m]
        assert np.allclose(a - a.mean(axis=0), b - b.mean(axis=0), atol=1e-12)


def test_droop_bends_each_axis_down_by_the_given_tip_angle_keeping_its_length(zero_tree):
    bent = grow_tree(np.random.default_rng(5), **{**ZERO, "droop_deg": 30.0})
    for a0, a1 in zip(zero_tree.layout.axes, bent.layout.axes, strict=True):
        l0 = np.linalg.norm(np.diff(a0, axis=0), axis=1)
        l1 = np.linalg.norm(np.diff(a1, axis=0), axis=1)
        assert l1.sum() == pytest.approx(l0.sum(), rel=1e-3)  # arcs for segments: chords
        d0 = (a0[-1] - a0[-2]) / l0[-1]
        d1 = (a1[-1] - a1[-2]) / l1[-1]
        # the last segment's chord turns by the bend at its middle: 30 (1 - 1/(2 m)) degrees,
        # a little less where the axis is not in the bending plane
        m = len(l0)
        turn = math.degrees(math.acos(np.clip(d0 @ d1, -1, 1)))
        assert 30.0 * (1 - 1 / (2 * m)) - 2.5 <= turn <= 30.0 * (1 - 1 / (2 * m)) + 1e-6
        assert d1[2] < d0[2]  # downwards
        assert a1[-1, 2] < a0[-1, 2]


def test_bend_turns_bark_and_leaves_with_the_axis_keeping_units_rigid(zero_tree):
    bent = grow_tree(np.random.default_rng(5), **{**ZERO, "droop_deg": 25.0})
    for c in np.unique(zero_tree.leaf_cluster)[::5]:
        m = zero_tree.leaf_cluster == c
        a, b = zero_tree.leaves.centers[m], bent.leaves.centers[m]
        r, resid = _kabsch(a - a.mean(axis=0), b - b.mean(axis=0))
        assert resid < 1e-9
        na, nb = zero_tree.leaves.normals[m], bent.leaves.normals[m]
        assert np.allclose(na @ r.T, nb, atol=1e-9)


def test_slide_moves_sub_branches_rigidly_leaving_the_axes(zero_tree):
    slid = grow_tree(np.random.default_rng(5), **{**ZERO, "slide_sd": 0.2})
    for a0, a1 in zip(zero_tree.layout.axes, slid.layout.axes, strict=True):
        assert np.allclose(a0, a1)
    moved = 0
    clusters = np.unique(zero_tree.leaf_cluster)
    for c in clusters:
        m = zero_tree.leaf_cluster == c
        a, b = zero_tree.leaves.centers[m], slid.leaves.centers[m]
        da = np.linalg.norm(a[:, None] - a[None], axis=2)
        db = np.linalg.norm(b[:, None] - b[None], axis=2)
        assert np.abs(da - db).max() < 1e-9
        moved += np.linalg.norm(a.mean(axis=0) - b.mean(axis=0)) > 1e-3
    assert moved >= 0.8 * len(clusters)


def test_leaves_stay_close_to_their_own_branch_bark():
    t = grow_tree(np.random.default_rng(7), bend_sd_deg=40.0, slide_sd=0.3, length_sd=0.3)
    for i, name in enumerate(t.branch_names):
        g = t.bark_group_names.index(name)
        v = t.bark_vertices[np.unique(t.bark_faces[t.bark_groups == g])]
        d, _ = cKDTree(v).query(t.leaves.centers[t.leaf_branch == i])
        assert d.max() < 0.2


def test_random_branch_choice_uses_reference_branches_at_random():
    t = grow_tree(np.random.default_rng(1), branch_choice="random", n_branches=30)
    assert len(np.unique(t.layout.reference_index)) > 3


def test_grow_tree_accepts_a_user_obj_reference(tmp_path, lsys_tree):
    path = lsys_tree.to_obj(tmp_path / "mine.obj")
    ref = load_reference(path)
    assert ref.structure == "derived"
    assert len(ref.branches) == len(lsys_tree.branch_names)
    with pytest.warns(UserWarning, match="wood is silent"):
        t = grow_tree(np.random.default_rng(0), reference=path, trunk_height=2.0)
    assert t.n_leaves > 0.5 * lsys_tree.n_leaves
    assert np.allclose(np.linalg.norm(t.leaves.normals, axis=1), 1.0)


def test_derived_reference_with_zero_randomisation_is_rigid(tmp_path, lsys_tree):
    ref = load_reference(lsys_tree.to_mesh())
    with pytest.warns(UserWarning, match="wood is silent"):
        t = grow_tree(np.random.default_rng(0), reference=ref, **ZERO)
    for i in range(len(t.layout)):
        tpl = ref.branches[t.layout.reference_index[i]]
        grown = t.leaves.centers[t.leaf_branch == i] - t.layout.origins[i]
        _, resid = _kabsch(tpl.leaf_centers - tpl.base, grown)
        assert resid < 1e-9


@pytest.mark.parametrize(
    "kwargs",
    [
        {"length_sd": -0.1},
        {"length_scale": 0.0},
        {"length_scale": float("nan")},
        {"bend_sd_deg": -1.0},
        {"slide_sd": float("inf")},
        {"trunk_height": -3.0},
        {"n_branches": 0},
        {"branch_choice": "tallest"},
        {"base": (0.0, 0.0)},
    ],
)
def test_grow_tree_rejects_bad_parameters(kwargs):
    with pytest.raises(ValueError):
        grow_tree(0, **kwargs)


@pytest.mark.parametrize("kwargs", [{"droop_deg": 1e300}, {"bend_sd_deg": 1e300}])
def test_grow_tree_refuses_a_bend_too_large_for_float64_naming_the_bend_parameters(kwargs):
    # such a bend once overflowed as it was squared, and every branch came out NaN
    with pytest.raises(ValueError, match="droop_deg and bend_sd_deg"):
        grow_tree(0, **kwargs)


@pytest.mark.parametrize("kwargs", [{"length_sd": 1e3}, {"length_scale": 1e-323}])
def test_grow_tree_refuses_branch_lengths_beyond_float64_naming_the_length_parameters(kwargs):
    with pytest.raises(ValueError, match="length_scale and length_sd"):
        grow_tree(0, **kwargs)


@pytest.mark.parametrize("grow", [grow_tree, grow_lsystem_tree])
def test_a_negative_seed_is_refused_naming_rng(grow):
    with pytest.raises(ValueError, match="rng must be a non-negative int seed"):
        grow(-1)


def test_a_tree_of_a_billion_branches_is_refused_before_it_grows():
    with pytest.raises(MemoryError, match=r"n_branches = 1000000000 .* memory limit"):
        grow_tree(0, n_branches=10**9)


def test_a_tree_whose_branching_takes_minutes_warns_before_it_grows():
    with warnings.catch_warnings():
        warnings.simplefilter("error", SlowWarning)
        with pytest.raises(SlowWarning, match=r"n_branches = 3000 takes about \d+ min"):
            grow_tree(0, n_branches=3000)


def test_a_trunk_branching_of_minutes_warns_before_it_starts():
    with warnings.catch_warnings():
        warnings.simplefilter("error", SlowWarning)
        with pytest.raises(SlowWarning, match=r"n_branches = 100000 takes about \d+ min"):
            trunk_branching(0, n_branches=10**5)


# ---------------------------------------------------------------------------------------------
# grow_lsystem_tree
# ---------------------------------------------------------------------------------------------


def test_lsystem_tree_defaults_are_model_md_section_7():
    p = inspect.signature(grow_lsystem_tree).parameters
    assert p["n_levels"].default == 4
    assert p["contraction"].default == 0.62
    assert p["branching_angle_deg"].default == 50.0
    assert p["initial_length"].default == 2.0
    assert p["leaf_nodes_per_branch"].default == 4
    assert p["centre_contraction"].default == 0.826
    assert p["leaves_per_node"].default == 4
    assert p["leaf_radius_mean"].default == 0.025
    assert p["leaf_radius_sd"].default == 0.005


def test_lsystem_tree_leaves_come_in_clusters_of_four_per_node(lsys_tree):
    counts = np.bincount(lsys_tree.leaf_cluster)
    assert (counts == 4).all()
    # a cluster's leaves sit within petiole + radius of one node
    reach = 2 * (0.03 + lsys_tree.leaves.radii.max())
    for c in range(0, len(counts), 97):
        p = lsys_tree.leaves.centers[lsys_tree.leaf_cluster == c]
        assert np.linalg.norm(p[:, None] - p[None], axis=2).max() <= reach


def test_lsystem_tree_has_four_leaf_nodes_per_branch(lsys_tree):
    # levels 1..4 with 3 laterals + a centre branch per node: 4 + 16 + 64 + 256 branches
    assert lsys_tree.n_leaves == (4 + 16 + 64 + 256) * 4 * 4


def test_lsystem_leaf_radii_are_normal_2_5_cm_sd_0_5_cm_and_positive():
    r = np.concatenate([grow_lsystem_tree(s).leaves.radii for s in range(4)])
    assert (r > 0).all()
    assert r.mean() == pytest.approx(0.025, abs=0.0003)
    assert r.std() == pytest.approx(0.005, abs=0.0003)


def test_lsystem_tree_same_seed_identical_and_plausible_height(lsys_tree):
    again = grow_lsystem_tree(np.random.default_rng(3))
    assert np.array_equal(again.leaves.centers, lsys_tree.leaves.centers)
    assert 5.0 <= lsys_tree.height <= 10.0


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"laterals_per_node": 50}, "laterals_per_node = 50"),
        ({"n_levels": 30}, "n_levels = 30"),
        ({"n_levels": 10**9}, "n_levels = 1000000000"),
    ],
)
def test_an_lsystem_tree_too_large_for_memory_is_refused_before_it_grows(kwargs, named):
    with pytest.raises(MemoryError, match=rf"{named} .* leaves\) needs about .* memory limit"):
        grow_lsystem_tree(1, **kwargs)


def test_an_lsystem_tree_of_minutes_warns_before_it_grows():
    with warnings.catch_warnings():
        warnings.simplefilter("error", SlowWarning)
        with pytest.raises(SlowWarning, match=r"n_levels = 2500 .* takes about \d+ min"):
            grow_lsystem_tree(1, laterals_per_node=0, n_levels=2500)


def test_an_lsystem_tree_whose_widths_underflow_is_refused_naming_width_contraction():
    with pytest.raises(ValueError, match=r"width_contraction\*\*n_levels = .* leaves float64"):
        grow_lsystem_tree(1, laterals_per_node=0, n_levels=1600)


def test_an_lsystem_tree_whose_segments_shrink_below_a_nanometre_is_refused_naming_n_levels():
    with pytest.raises(
        ValueError, match=r"contraction\*\*n_levels = 2.0 \* 0.62\*\*500 gives segments"
    ):
        grow_lsystem_tree(1, laterals_per_node=0, n_levels=500)


def test_lsystem_tree_rejects_bad_parameters():
    with pytest.raises(ValueError):
        grow_lsystem_tree(0, contraction=-0.5)
    with pytest.raises(ValueError):
        grow_lsystem_tree(0, leaf_radius_sd=float("nan"))
    with pytest.raises(ValueError):
        grow_lsystem_tree(0, initial_length=0.0)


# ---------------------------------------------------------------------------------------------
# Tree methods, load_tree
# ---------------------------------------------------------------------------------------------


def test_tree_obj_round_trip_keeps_leaves_and_bark(tree, tmp_path):
    path = tree.to_obj(tmp_path / "tree.obj")
    with pytest.warns(batecho.ObjWarning, match="wood is silent"):
        back = load_tree(path)
    assert back.n_leaves == tree.n_leaves
    assert np.allclose(back.leaves.centers, tree.leaves.centers, atol=1e-9)
    assert np.allclose(back.leaves.radii, tree.leaves.radii, rtol=1e-9)
    tri0 = tree.bark_vertices[tree.bark_faces]
    tri1 = back.bark_vertices[back.bark_faces]
    assert tri0.shape == tri1.shape and np.allclose(tri0, tri1, atol=1e-12)
    assert back.branch_names == tree.branch_names
    assert np.array_equal(back.leaf_branch, tree.leaf_branch)


def test_load_tree_refuses_a_file_without_leaf_faces_naming_the_file_and_patterns(tmp_path):
    path = tmp_path / "bark.obj"
    path.write_text("o trunk\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.warns(batecho.ObjWarning, match="no leaf faces"):
        with pytest.raises(ValueError, match="bark.obj: no leaf faces") as err:
            load_tree(path)
    assert str(list(DEFAULT_LEAF_PATTERNS)) in str(err.value)


def test_load_tree_refusing_a_file_whose_leaf_faces_are_all_degenerate_says_so(tmp_path):
    path = tmp_path / "flat.obj"
    path.write_text("o trunk\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no leaf\nf 1 1 2\n")
    with pytest.warns(batecho.ObjWarning, match="degenerate"):
        with pytest.raises(ValueError, match="flat.obj: its leaf faces are all degenerate") as err:
            load_tree(path)
    assert "leaf_patterns" not in str(err.value)


@pytest.mark.parametrize("trunk_pattern", [None, 3, b"trunk"])
def test_load_tree_refuses_a_trunk_pattern_that_is_not_a_str_naming_it(tmp_path, trunk_pattern):
    path = tmp_path / "leaf.obj"
    path.write_text("g leaf\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(TypeError, match="trunk_pattern must be a str"):
        load_tree(path, trunk_pattern=trunk_pattern)


def _bare_tree(leaves, bark_vertices, bark_faces):
    n = len(leaves)
    return Tree(leaves, bark_vertices, bark_faces, None, (), np.full(n, -1), np.full(n, -1))


def test_tree_refuses_bark_vertices_that_are_not_finite(lsys_tree):
    with pytest.raises(ValueError, match="bark_vertices must be finite"):
        _bare_tree(lsys_tree.leaves, np.full((3, 3), np.nan), [[0, 1, 2]])


def test_tree_refuses_bark_faces_that_are_not_integers(lsys_tree):
    with pytest.raises(TypeError, match="bark_faces must hold integer indices"):
        _bare_tree(lsys_tree.leaves, np.eye(3), [[0.5, 1.2, 2.9]])


def test_the_trees_guide_states_the_default_leaf_patterns_and_refusal_of_a_leafless_file():
    guide = " ".join((ROOT / "docs" / "guide" / "trees.md").read_text().split())
    named = ", ".join(f'"{p}"' for p in DEFAULT_LEAF_PATTERNS[:-1])
    assert f'{named} or "{DEFAULT_LEAF_PATTERNS[-1]}"' in guide
    assert "`load_tree` refuses it" in guide


def test_load_tree_assigns_leaves_to_nearest_branch_without_names(tmp_path, lsys_tree):
    path = batecho.write_obj(
        tmp_path / "plain.obj",
        lsys_tree.bark_vertices,
        lsys_tree.bark_faces,
        lsys_tree.leaves,
        bark_groups=lsys_tree.bark_groups,
        bark_group_names=lsys_tree.bark_group_names,
    )
    with pytest.warns(batecho.ObjWarning):
        back = load_tree(path)
    agree = np.mean(back.leaf_branch == lsys_tree.leaf_branch)
    assert agree > 0.95


def test_transformed_turns_about_the_base_and_moves(tree):
    moved = tree.transformed(90.0, (1.0, 2.0, 0.0), scale=2.0)
    c = tree.leaves.centers - tree.base
    expect = tree.base + 2.0 * np.column_stack([-c[:, 1], c[:, 0], c[:, 2]]) + [1.0, 2.0, 0.0]
    assert np.allclose(moved.leaves.centers, expect)
    assert np.allclose(moved.leaves.radii, tree.leaves.radii)  # leaf size is kept
    assert np.allclose(moved.leaves.normals[:, 2], tree.leaves.normals[:, 2])
    big = tree.transformed(90.0, (1.0, 2.0, 0.0), scale=2.0, scale_leaves=True)
    assert big.height == pytest.approx(2.0 * tree.height)
    assert np.allclose(moved.base, tree.base + [1.0, 2.0, 0.0])


def test_bounds_contain_all_leaves_and_bark(tree):
    lo, hi = tree.bounds()
    pts = np.concatenate([tree.leaves.centers, tree.bark_vertices])
    assert (pts >= lo - 1e-12).all() and (pts <= hi + 1e-12).all()


# ---------------------------------------------------------------------------------------------
# Echoes end to end
# ---------------------------------------------------------------------------------------------


def test_sonar_circling_a_grown_tree_hears_leaves_at_most_poses(tree):
    scene = batecho.Scene(tree.leaves)
    poses = batecho.circle(center=tree.base, radius=6.2, altitude=5.0, n_points=8, heading="center")
    echo = batecho.simulate(scene, batecho.Sonar(beamwidth_deg=30.0), poses)
    heard = (echo.n_leaves > 0) & (np.abs(echo.impulse).max(axis=1) > 0)
    assert heard.sum() >= 6


def test_sonar_looking_away_from_the_tree_hears_exactly_nothing(tree):
    scene = batecho.Scene(tree.leaves)
    pose = batecho.Poses(positions=[6.2, 0.0, 5.0], forward=[1.0, 0.0, 0.0])
    echo = batecho.simulate(scene, batecho.Sonar(beamwidth_deg=30.0), pose)
    assert echo.n_leaves[0] == 0
    assert not np.any(echo.impulse)


# ---------------------------------------------------------------------------------------------
# Pictures
# ---------------------------------------------------------------------------------------------


def test_plot_tree_returns_a_figure_and_writes_png(tree, lsys_tree, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    from batecho.treeplots import plot_tree

    for name, t in (("grown", tree), ("lsystem", lsys_tree)):
        fig = plot_tree(t, max_leaves=3000, max_bark_faces=1500)
        assert isinstance(fig, Figure)
        fig.savefig(tmp_path / f"{name}.png", dpi=50)
        plt.close(fig)
        assert (tmp_path / f"{name}.png").stat().st_size > 1000


# ---------------------------------------------------------------------------------------------
# The woody skeleton (Tree.branches)
# ---------------------------------------------------------------------------------------------


def _surface_misfit(t: Tree) -> np.ndarray:
    """Per bark vertex, the least |distance to a skeleton segment's axis - its radius| (m)."""
    from scipy.spatial import cKDTree

    b = t.branches
    s, e, r = b.starts, b.ends, b.radii
    k = 8
    at = (np.arange(k) + 0.5) / k
    pts = (s[:, None, :] + at[None, :, None] * (e - s)[:, None, :]).reshape(-1, 3)
    seg = np.repeat(np.arange(len(s)), k)
    v = t.bark_vertices
    _, near = cKDTree(pts).query(v, k=8)
    best = np.full(len(v), np.inf)
    for j in range(near.shape[1]):
        g = seg[near[:, j]]
        d, m = e[g] - s[g], v - s[g]
        u = np.clip(np.einsum("ij,ij->i", m, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        dist = np.linalg.norm(m - u[:, None] * d, axis=1)
        best = np.minimum(best, np.abs(dist - r[g]))
    return best


def test_lsystem_tree_skeleton_is_its_bark_tubes_axes_with_their_radii(lsys_tree):
    wood = lsys_tree.branches
    assert isinstance(wood, batecho.Branches)
    sides = lsys_tree.params["bark_sides"]
    assert len(wood) == len(lsys_tree.bark_faces) // (2 * sides)
    assert np.median(_surface_misfit(lsys_tree)) < 1e-9
    assert wood.radii.max() == pytest.approx(lsys_tree.params["trunk_radius"])


def test_reference_skeleton_lies_on_the_axis_of_its_bark():
    ref = batecho.trees.load_reference()
    assert ref.has_skeleton
    t = ref.tree()
    miss = _surface_misfit(t)
    # a segment's radius is the mean of its two rings': within the taper, the 0.1 mm rounding
    assert np.quantile(miss, 0.99) < 2e-3 and np.median(miss) < 1e-3
    assert 3000 < len(t.branches) < 5000
    assert t.branches.radii.min() >= 0.0015 and t.branches.radii.max() == pytest.approx(0.2, 0.02)


@pytest.mark.parametrize("kw", [{}, {"bend_sd_deg": 30.0, "length_sd": 0.3, "slide_sd": 0.3}])
def test_grown_tree_skeleton_follows_its_randomised_bark(kw):
    t = grow_tree(np.random.default_rng(5), **kw)
    miss = _surface_misfit(t)
    assert np.quantile(miss, 0.99) < 2e-3 and np.median(miss) < 1e-3


def test_skeleton_moves_and_scales_with_the_tree(tree):
    moved = tree.transformed(90.0, (1.0, 2.0, 0.0), scale=2.0)
    c = tree.branches.starts - tree.base
    want = tree.base + 2.0 * np.column_stack([-c[:, 1], c[:, 0], c[:, 2]]) + [1.0, 2.0, 0.0]
    np.testing.assert_allclose(moved.branches.starts, want, atol=1e-12)
    np.testing.assert_allclose(moved.branches.radii, 2.0 * tree.branches.radii)


def test_with_branches_gives_a_tree_a_skeleton_or_silences_it(tree):
    wood = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 3.0]], [0.1])
    assert tree.with_branches(wood).branches is wood
    assert tree.with_branches(None).branches is None
    with pytest.raises(TypeError, match="branches must be None or batecho.Branches"):
        tree.with_branches("trunk")


def test_a_reference_without_a_skeleton_grows_trees_with_silent_wood(tmp_path, lsys_tree):
    path = lsys_tree.to_obj(tmp_path / "ref.obj")
    with pytest.warns(UserWarning, match="wood is silent"):
        t = grow_tree(np.random.default_rng(0), reference=path)
    assert t.branches is None


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"branching_angle_deg": True}, "branching_angle_deg"),
        ({"divergence_deg": "137.5"}, "divergence_deg"),
        ({"lsystem": {"contraction": "0.85"}}, "contraction"),
        ({"lsystem": {"angle_jitter_deg": False}}, "angle_jitter_deg"),
    ],
)
def test_grow_tree_refuses_a_bool_or_string_for_a_branching_parameter_naming_it(kwargs, name):
    with pytest.raises(TypeError, match=f"{name} must be a real number"):
        grow_tree(0, **kwargs)


def test_grow_tree_refuses_an_lsystem_that_is_not_a_mapping_naming_it():
    with pytest.raises(TypeError, match="lsystem must be a mapping"):
        grow_tree(0, lsystem="buds_per_node=2")


def test_tree_refuses_bark_vertices_beyond_the_largest_coordinate_naming_them(lsys_tree):
    with pytest.raises(ValueError, match="bark_vertices .*beyond 1e\\+15 m"):
        _bare_tree(lsys_tree.leaves, 1e300 * np.eye(3), [[0, 1, 2]])


def test_an_lsystem_tree_with_a_trunk_radius_beyond_the_largest_coordinate_is_refused():
    # (its trunk's branch radius is refused first, as Branches bounds radii)
    with pytest.raises(ValueError, match="at most 1e\\+15 m; branch 0"):
        grow_lsystem_tree(0, n_levels=1, trunk_radius=1e300)
