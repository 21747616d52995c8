"""Tests for batecho.forest.Forest and batecho.treeplots' forest pictures."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import batecho
from batecho.forest import Forest
from batecho.forest.ipp import PAPER_WINDOW, paper_intensity
from batecho.trees import Tree, grow_lsystem_tree, grow_tree

SMALL = {"n_levels": 2}  # a quick L-system tree (4 + 16 branches, 320 leaves)


@pytest.fixture(scope="module")
def small_tree() -> Tree:
    return grow_lsystem_tree(np.random.default_rng(0), **SMALL)


@pytest.fixture(scope="module")
def paper_forest() -> Forest:
    return Forest.paper_example(np.random.default_rng(2020))


def _same(a: Forest, b: Forest) -> bool:
    return (
        np.array_equal(a.positions, b.positions)
        and np.array_equal(a.rotations_deg, b.rotations_deg)
        and np.array_equal(a.scales, b.scales)
        and np.array_equal(a.variant_index, b.variant_index)
        and np.array_equal(a.leaves.centers, b.leaves.centers)
    )


def test_same_seed_gives_the_same_forest(paper_forest):
    assert _same(Forest.paper_example(np.random.default_rng(2020)), paper_forest)


def test_different_seeds_give_different_forests(paper_forest):
    other = Forest.paper_example(np.random.default_rng(2021))
    assert other.n_trees != paper_forest.n_trees or not np.allclose(
        other.positions, paper_forest.positions
    )


def test_paper_forest_positions_lie_in_the_window(paper_forest):
    xmin, xmax, ymin, ymax = PAPER_WINDOW
    p = paper_forest.positions
    assert paper_forest.n_trees >= 1
    assert ((p[:, 0] >= xmin) & (p[:, 0] <= xmax) & (p[:, 1] >= ymin) & (p[:, 1] <= ymax)).all()


def test_paper_forest_trees_stand_at_their_positions(paper_forest):
    for i in range(paper_forest.n_trees):
        t = paper_forest.placed(i)
        assert np.allclose(t.base[:2], paper_forest.positions[i])
        assert t.n_leaves == paper_forest.trees[i].n_leaves


def test_forest_leaves_are_the_placed_trees_leaves_in_order(paper_forest):
    parts = [paper_forest.placed(i).leaves for i in range(paper_forest.n_trees)]
    allv = batecho.Leaves.concatenate(parts)
    assert np.allclose(paper_forest.leaves.centers, allv.centers, atol=1e-12)
    assert np.allclose(paper_forest.leaves.normals, allv.normals, atol=1e-12)
    assert np.array_equal(paper_forest.leaves.radii, allv.radii)
    assert paper_forest.n_leaves == len(allv)


def test_number_of_trees_is_poisson_with_the_intensity_integral(small_tree):
    lam = paper_intensity()
    expected = lam.integral(PAPER_WINDOW)
    counts = np.array(
        [Forest.from_ipp(lam, PAPER_WINDOW, seed, tree=small_tree).n_trees for seed in range(400)]
    )
    se = np.sqrt(expected / len(counts))
    assert abs(counts.mean() - expected) < 4.0 * se
    assert 0.75 < counts.var() / counts.mean() < 1.3


def test_rotations_are_uniform_and_scales_default_to_one(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.5, (0.0, 20.0, 0.0, 20.0), 1, tree=small_tree)
    assert f.n_trees > 100
    r = f.rotations_deg
    assert (r >= 0).all() and (r < 360).all()
    assert np.histogram(r, bins=4, range=(0, 360))[0].min() > 0.15 * f.n_trees
    assert np.array_equal(f.scales, np.ones(f.n_trees))


def test_scale_sd_gives_lognormal_scales(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.5, (0.0, 20.0, 0.0, 20.0), 1, tree=small_tree, scale_sd=0.2)
    logs = np.log(f.scales)
    assert abs(logs.mean()) < 0.05
    assert logs.std() == pytest.approx(0.2, rel=0.2)
    i = int(np.argmax(f.scales))
    assert f.placed(i).height == pytest.approx(
        f.scales[i] * (small_tree.bark_vertices[:, 2].max() - small_tree.base[2]), rel=0.05
    )


def test_instanced_forest_uses_exactly_k_distinct_trees():
    f = Forest.from_ipp(
        lambda x, y: 0.1,
        (0.0, 30.0, 0.0, 30.0),
        4,
        tree=grow_lsystem_tree,
        tree_params=SMALL,
        variants=3,
    )
    assert f.n_trees >= 3
    assert len(f.variants) == 3
    assert {id(t) for t in f.trees} == {id(v) for v in f.variants}
    assert set(np.unique(f.variant_index)) == {0, 1, 2}


def test_unique_forest_grows_one_tree_per_position():
    f = Forest.from_ipp(
        lambda x, y: 0.02, (0.0, 30.0, 0.0, 30.0), 4, tree=grow_lsystem_tree, tree_params=SMALL
    )
    assert len(f.variants) == f.n_trees
    assert len({id(t) for t in f.trees}) == f.n_trees
    c = [t.leaves.centers for t in f.trees]
    assert not np.allclose(c[0], c[1])


def test_variant_j_does_not_depend_on_how_many_variants_are_grown():
    kw = {"tree": grow_lsystem_tree, "tree_params": SMALL}
    a = Forest.from_positions(np.zeros((5, 2)), 9, variants=2, **kw)
    b = Forest.from_positions(np.zeros((5, 2)), 9, variants=3, **kw)
    for j in range(2):
        assert np.array_equal(a.variants[j].leaves.centers, b.variants[j].leaves.centers)


def test_more_variants_than_memory_holds_are_refused_before_growing_them():
    # two trees placed, ten million grown: refused at once, naming the variants
    kw = {"tree": grow_lsystem_tree, "tree_params": SMALL}
    with pytest.raises(MemoryError, match="10000000 grown"):
        Forest.from_positions(np.zeros((2, 2)), 9, variants=10_000_000, **kw)


def test_from_ipp_positions_match_sample_ipp_with_the_first_child_generator(paper_forest):
    gen = np.random.default_rng(2020)
    pos_gen = gen.spawn(3)[0] if hasattr(gen, "spawn") else None
    if pos_gen is None:
        pytest.skip("NumPy without Generator.spawn")
    pts = batecho.sample_ipp(paper_intensity(), PAPER_WINDOW, pos_gen)
    assert np.array_equal(pts, paper_forest.positions)


def test_million_leaf_instanced_forest_builds_with_its_scene():
    f = Forest.from_ipp(
        lambda x, y: 0.06, (0.0, 40.0, 0.0, 40.0), np.random.default_rng(3), variants=3
    )
    scene = f.scene()
    assert f.n_leaves >= 1_000_000
    assert scene.n_leaves == f.n_leaves
    assert f.scene() is scene
    assert len(f.variants) == 3


def test_bark_is_built_lazily_and_holds_every_trees_bark(small_tree):
    f = Forest.from_positions([[0.0, 0.0], [5.0, 1.0]], 0, tree=small_tree)
    assert f._bark is None
    v, faces, owner = f.bark()
    assert len(faces) == 2 * len(small_tree.bark_faces)
    assert np.array_equal(np.bincount(owner), [len(small_tree.bark_faces)] * 2)
    assert faces.max() < len(v)


def test_bounds_contain_every_leaf_and_bark_vertex(small_tree):
    f = Forest.from_positions(
        [[0.0, 0.0], [5.0, 1.0], [2.0, 7.0]], 0, tree=small_tree, scale_sd=0.3
    )
    lo, hi = f.bounds()
    v, _, _ = f.bark()
    pts = np.concatenate([v, f.leaves.centers])
    assert (pts >= lo - 1e-9).all() and (pts <= hi + 1e-9).all()


def test_forest_obj_round_trip_keeps_every_leaf(small_tree, tmp_path):
    f = Forest.from_positions([[0.0, 0.0], [5.0, 1.0]], 0, tree=small_tree)
    back = batecho.load_obj(f.to_obj(tmp_path / "forest.obj"))
    assert back.n_leaves == f.n_leaves
    assert np.allclose(back.leaves.centers, f.leaves.centers, atol=1e-9)
    assert len(back.bark_faces) == len(f.bark()[1])


def test_mean_position_is_the_mean_of_the_tree_positions(paper_forest):
    assert np.allclose(paper_forest.mean_position, paper_forest.positions.mean(axis=0))


def test_empty_forest_has_no_scene(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.0, (0.0, 10.0, 0.0, 10.0), 0, tree=small_tree)
    assert f.n_trees == 0 and f.n_leaves == 0
    with pytest.raises(ValueError):
        f.scene()


def test_an_empty_forest_is_infinitely_far_from_every_point(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.0, (0.0, 10.0, 0.0, 10.0), 0, tree=small_tree)
    assert np.array_equal(f.clearance([[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]), [np.inf, np.inf])


def test_an_empty_forest_still_refuses_bad_points(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.0, (0.0, 10.0, 0.0, 10.0), 0, tree=small_tree)
    with pytest.raises(ValueError, match="points"):
        f.clearance([[np.nan, 0.0, 0.0]])


@pytest.mark.parametrize("altitude", [float("nan"), float("inf")])
def test_a_clear_circle_at_a_non_finite_altitude_is_refused(paper_forest, altitude):
    with pytest.raises(ValueError, match="altitude"):
        paper_forest.clear_circle_radius(paper_forest.mean_position, 6.2, altitude=altitude)


@pytest.mark.parametrize(
    "kwargs",
    [{"variants": 0}, {"variants": 2.5}, {"scale_sd": -1.0}, {"scale_sd": float("nan")}],
)
def test_bad_forest_arguments_raise(small_tree, kwargs):
    with pytest.raises(ValueError):
        Forest.from_positions([[0.0, 0.0]], 0, tree=grow_lsystem_tree, tree_params=SMALL, **kwargs)


@pytest.mark.parametrize("positions", [[[0.0, 0.0, 0.0], [5.0, 5.0, 0.0]], [0.0, 0.0, 5.0, 5.0]])
def test_from_positions_refuses_positions_not_shaped_t_by_2(small_tree, positions):
    with pytest.raises(ValueError, match=r"positions must have shape \(t, 2\)"):
        Forest.from_positions(positions, 0, tree=small_tree)


def test_make_forest_refuses_positions_with_a_third_column():
    from batecho.forest.models import make_forest

    with pytest.raises(ValueError, match=r"positions must have shape \(t, 2\)"):
        make_forest([[0.0, 0.0, 0.0], [5.0, 5.0, 0.0]], np.random.default_rng(0), "lsystem", SMALL)


def test_forest_constructor_validates_its_arrays(small_tree):
    with pytest.raises(ValueError):
        Forest([small_tree], [[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ValueError):
        Forest([small_tree], [[0.0, np.nan]])
    with pytest.raises(ValueError):
        Forest([small_tree], [[0.0, 0.0]], scales=[0.0])


def test_sonar_circling_the_paper_forest_hears_leaves(paper_forest):
    poses = batecho.circle(
        center=paper_forest.mean_position, radius=6.2, altitude=5.0, n_points=8, heading="center"
    )
    sonar = batecho.Sonar(beamwidth_deg=30.0, too_close="skip")
    echo = batecho.simulate(paper_forest.scene(), sonar, poses)
    assert (echo.n_leaves > 0).sum() >= 6
    assert np.abs(echo.impulse).max() > 0


def test_grown_forest_default_tree_is_grow_tree(paper_forest):
    assert paper_forest.params["tree"] == grow_tree.__name__
    assert all(8_000 <= t.n_leaves <= 40_000 for t in paper_forest.variants)


# ---------------------------------------------------------------------------------------------
# Pictures
# ---------------------------------------------------------------------------------------------


def test_plot_forest_map_returns_a_figure(paper_forest, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    from batecho.treeplots import plot_forest_map

    fig = plot_forest_map(paper_forest)
    assert isinstance(fig, Figure)
    fig.savefig(tmp_path / "map.png", dpi=50)
    plt.close(fig)
    assert (tmp_path / "map.png").stat().st_size > 1000


def test_plot_forest_map_without_intensity_or_window(small_tree, tmp_path):
    import matplotlib.pyplot as plt

    from batecho.treeplots import plot_forest_map

    f = Forest.from_positions([[0.0, 0.0], [5.0, 1.0]], 0, tree=small_tree)
    fig = plot_forest_map(f)
    fig.savefig(tmp_path / "map2.png", dpi=50)
    plt.close(fig)


def test_plot_forest_3d_returns_a_figure(paper_forest, tmp_path):
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    from batecho.treeplots import plot_forest_3d

    fig = plot_forest_3d(paper_forest, max_leaves=5000)
    assert isinstance(fig, Figure)
    fig.savefig(tmp_path / "forest3d.png", dpi=50)
    plt.close(fig)
    assert (tmp_path / "forest3d.png").stat().st_size > 1000


def test_scene_with_branches_places_every_trees_skeleton_with_its_tree():
    forest = batecho.Forest.paper_example(np.random.default_rng(4), variants=2)
    wood = forest.branches
    assert isinstance(wood, batecho.Branches)
    assert len(wood) == sum(len(forest.placed(i).branches) for i in range(forest.n_trees))
    first = forest.placed(0).branches
    np.testing.assert_allclose(wood.starts[: len(first)], first.starts, atol=1e-12)
    np.testing.assert_allclose(wood.radii[: len(first)], first.radii)
    scene = forest.scene(branches=True)
    assert scene.branches is wood and scene.n_leaves == forest.n_leaves
    assert forest.scene().branches is None  # the paper's model: leaves alone
    assert forest.scene(branches=True) is scene


def test_scene_with_branches_refuses_a_forest_without_skeletons():
    tree = batecho.grow_lsystem_tree(0).with_branches(None)
    forest = batecho.Forest.from_positions([[0.0, 0.0]], 0, tree=tree)
    assert forest.branches is None
    with pytest.raises(ValueError, match="no tree of this forest has a woody skeleton"):
        forest.scene(branches=True)
    with pytest.raises(TypeError, match="branches must be True or False"):
        forest.scene(branches="yes")


@pytest.mark.parametrize("extra", [{"tree_params": {"n_levels": 3}}, {"variants": 2}])
def test_one_tree_for_every_position_refuses_tree_params_and_variants_naming_them(
    small_tree, extra
):
    (name,) = extra
    with pytest.raises(ValueError, match=name):
        Forest.from_positions([[0.0, 0.0], [5.0, 5.0]], 0, tree=small_tree, **extra)


def test_a_tree_function_that_returns_no_tree_is_refused_after_its_first_call():
    calls = []

    def no_tree(rng, **kwargs):
        calls.append(rng)
        return None

    with pytest.raises(TypeError, match="must return a Tree"):
        Forest.from_positions(np.zeros((20, 2)), 0, tree=no_tree)
    assert len(calls) == 1


@pytest.mark.parametrize("scale_sd", [1000.0, 1e300])
def test_a_scale_sd_whose_sizes_leave_float64_is_refused_naming_it_before_growing(scale_sd):
    def no_growing(rng, **kwargs):
        raise AssertionError("grew a tree")

    with pytest.raises(ValueError, match="scale_sd"):
        Forest.from_positions(np.zeros((20, 2)), 0, tree=no_growing, scale_sd=scale_sd)


def test_an_empty_forest_scene_with_branches_says_it_has_no_trees(small_tree):
    f = Forest.from_ipp(lambda x, y: 0.0, (0.0, 10.0, 0.0, 10.0), 0, tree=small_tree)
    with pytest.raises(ValueError, match="the forest has no trees"):
        f.scene(branches=True)


@pytest.mark.parametrize("positions", [[[0.0, 0.0], [1.0]], [["a", "b"]], [[1.0 + 1.0j, 0.0]]])
def test_positions_that_are_not_real_numbers_are_refused_naming_positions(small_tree, positions):
    with pytest.raises(TypeError, match="positions"):
        Forest.from_positions(positions, 0, tree=small_tree)


@pytest.mark.parametrize("center", [(0.0, 0.0, 0.0), "ab", (0.0, float("nan"))])
def test_a_clear_circle_about_a_center_that_is_not_a_finite_x_y_is_refused_naming_it(
    paper_forest, center
):
    with pytest.raises((TypeError, ValueError), match="center"):
        paper_forest.clear_circle_radius(center, 6.2)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"min_radius": "6"}, "min_radius"),
        ({"min_radius": True}, "min_radius"),
        ({"min_radius": 6.0, "margin": "1"}, "margin"),
    ],
)
def test_a_clear_circle_refuses_a_radius_or_margin_that_is_not_a_number_naming_it(
    paper_forest, kwargs, name
):
    with pytest.raises(TypeError, match=name):
        paper_forest.clear_circle_radius((10.0, 10.0), **kwargs)


def test_forest_params_keep_a_numpy_variants_count_as_a_python_int_for_json():
    import json

    f = Forest.from_positions(
        [[0.0, 0.0]], 0, tree=grow_lsystem_tree, tree_params=SMALL, variants=np.int64(1)
    )
    assert json.loads(json.dumps(f.params))["variants"] == 1


@pytest.mark.parametrize("name", ["rotations_deg", "scales"])
@pytest.mark.parametrize("value", [["a"], [1j], [True]])
def test_forest_refuses_rotations_or_scales_that_are_not_real_numbers_naming_them(
    small_tree, name, value
):
    with pytest.raises(TypeError, match=f"{name} must"):
        Forest([small_tree], [[0.0, 0.0]], variant_index=[0], **{name: value})


@pytest.mark.parametrize("index", [1.5, "0", True, None])
def test_placed_refuses_a_tree_index_that_is_not_an_integer_naming_it(small_tree, index):
    forest = Forest([small_tree], [[0.0, 0.0], [3.0, 3.0]], variant_index=[0, 0])
    with pytest.raises(TypeError, match="tree index must be an integer"):
        forest.placed(index)
