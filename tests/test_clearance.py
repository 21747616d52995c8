"""Clearance: the distance from points to the nearest leaf disk (Rust, on the BVH) is the NumPy
reference's brute force to the bit, on the hard cases (points on a disk, on its rim, on its
axis, in its plane beyond the rim, coincident disks); the bark's triangles; `simulate`'s
warning; forests' clear circles."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import batecho
from batecho import ClearanceWarning, reference
from batecho.forest.clearance import BarkGrid, bark_clearance, point_triangle_distances


def unit_rows(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def in_plane(n: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unit vectors perpendicular to the unit rows of ``n``."""
    u = np.cross(n, rng.normal(size=n.shape))
    return unit_rows(u)


@st.composite
def scenes_and_points(draw):
    """A few hundred disks (some coincident, radii 1 mm to 20 cm) and points on them, on
    their rims, on their axes, in their planes beyond the rims, at their centres and
    anywhere."""
    seed = draw(st.integers(0, 2**32 - 1))
    n = draw(st.integers(1, 400))
    scale = draw(st.sampled_from([0.5, 5.0, 50.0]))
    rng = np.random.default_rng(seed)
    c = rng.uniform(-scale, scale, (n, 3))
    nv = rng.normal(size=(n, 3))
    if draw(st.booleans()):
        nv[: n // 2] = [0.0, 0.0, 1.0]  # flat leaves: exact axis-aligned planes
    a = np.exp(rng.uniform(np.log(1e-3), np.log(0.2), n))
    k = draw(st.integers(0, n // 3))
    c[1 : 1 + k] = c[0]  # coincident disks
    nv[1 : 1 + k] = nv[0]
    a[1 : 1 + k] = a[0]
    leaves = batecho.Leaves(c, nv, a)
    c, nv, a = leaves.centers, leaves.normals, leaves.radii
    m = 60
    j = rng.integers(0, n, m)
    u = in_plane(nv[j], rng)
    s = rng.uniform(0.0, 1.0, m)[:, None]
    pts = np.concatenate(
        [
            c[j] + s * a[j, None] * u,  # on the disk
            c[j] + a[j, None] * u,  # on the rim
            c[j] + rng.uniform(-2, 2, m)[:, None] * nv[j],  # on the axis
            c[j] + (1.0 + 3.0 * s) * a[j, None] * u,  # in the plane beyond the rim
            c[j],  # at the centre
            rng.uniform(-2 * scale, 2 * scale, (m, 3)),  # anywhere
        ]
    )
    return leaves, pts


@given(scenes_and_points())
def test_the_bvh_clearance_is_the_reference_brute_force_to_the_bit(case):
    leaves, pts = case
    got, got_i = batecho.Scene(leaves).clearance(pts, return_index=True)
    want, want_i = reference.clearance(leaves, pts)
    assert got.tobytes() == want.tobytes()
    np.testing.assert_array_equal(got_i, want_i)


@given(scenes_and_points())
def test_coincident_disks_name_the_smallest_index(case):
    leaves, pts = case
    _, i = batecho.Scene(leaves).clearance(pts, return_index=True)
    c = leaves.centers
    for k in range(len(pts)):
        twins = np.flatnonzero((c == c[i[k]]).all(axis=1))  # disks equal to the one named
        assert i[k] == twins.min()


def test_a_point_on_a_disk_is_at_distance_zero_to_rounding():
    rng = np.random.default_rng(1)
    n = unit_rows(rng.normal(size=(500, 3)))
    c = rng.uniform(-3, 3, (500, 3))
    a = rng.uniform(0.01, 0.1, 500)
    p = c + rng.uniform(0, 0.99, 500)[:, None] * a[:, None] * in_plane(n, rng)
    d = reference.point_disk_distance(p, c, n, a)
    assert d.max() < 1e-14


def test_a_point_on_the_axis_is_at_its_height():
    c = np.array([[1.0, 2.0, 3.0]])
    n = np.array([[0.0, 0.0, 1.0]])
    p = np.array([[1.0, 2.0, 3.0 + 0.75], [1.0, 2.0, 3.0 - 2.5]])
    np.testing.assert_array_equal(reference.point_disk_distance(p, c, n, 0.1), [0.75, 2.5])


def test_a_point_in_the_plane_beyond_the_rim_is_its_distance_to_the_rim():
    c = np.zeros((1, 3))
    n = np.array([[0.0, 0.0, 1.0]])
    p = np.array([[3.0, 0.0, 0.0], [0.0, -0.5, 0.0]])
    np.testing.assert_array_equal(reference.point_disk_distance(p, c, n, 0.5), [2.5, 0.0])


def test_the_disk_distance_is_the_nearest_of_the_disks_points():
    """The formula against a dense polar sampling of the disk (an independent check)."""
    rng = np.random.default_rng(4)
    n = unit_rows(rng.normal(size=(1, 3)))[0]
    c, a = np.array([0.3, -0.2, 0.1]), 0.05
    u = in_plane(n[None], rng)[0]
    v = np.cross(n, u)
    r, t = np.meshgrid(np.linspace(0, a, 201), np.linspace(0, 2 * np.pi, 721))
    disk = c + (r * np.cos(t))[..., None] * u + (r * np.sin(t))[..., None] * v
    step = a * 2 * np.pi / 720  # the sampling's largest gap
    for p in rng.uniform(-0.2, 0.4, (40, 3)):
        sampled = np.linalg.norm(disk - p, axis=-1).min()
        exact = reference.point_disk_distance(p[None], c[None], n[None], a)[0]
        assert exact <= sampled + 1e-15
        assert sampled - exact <= step


def test_clearance_takes_one_point_and_leaves_the_callers_array_alone():
    scene = batecho.Scene(batecho.Leaves([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [0.1]))
    p = np.array([0.0, 0.0, 2.0])
    before = p.copy()
    np.testing.assert_array_equal(scene.clearance(p), [2.0])
    np.testing.assert_array_equal(p, before)


@pytest.mark.parametrize(
    ("points", "match"),
    [
        ([[0.0, 0.0, np.nan]], "finite"),
        ([[1e300, 0.0, 0.0]], "point 0"),
        ([[0.0, 0.0]], r"shape"),
        ([["a", "b", "c"]], "real numbers"),
    ],
)
def test_bad_points_are_refused_by_name(points, match):
    scene = batecho.Scene(batecho.Leaves([[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], [0.1]))
    with pytest.raises((ValueError, TypeError), match=match):
        scene.clearance(points)


# -- bark ---------------------------------------------------------------------------------


def test_the_triangle_distance_is_the_nearest_of_the_triangles_points():
    rng = np.random.default_rng(8)
    tri = rng.uniform(-1, 1, (30, 3, 3))
    m = 80  # a barycentric grid with m + 1 points along each edge
    i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1))
    keep = i + j <= m
    w = np.column_stack([i[keep], j[keep], m - i[keep] - j[keep]]) / m
    for p in rng.uniform(-2, 2, (20, 3)):
        d = point_triangle_distances(p, tri)
        for k in range(len(tri)):
            edge = np.linalg.norm(tri[k] - np.roll(tri[k], 1, axis=0), axis=1).max()
            sampled = np.linalg.norm(w @ tri[k] - p, axis=1).min()
            assert d[k] <= sampled + 1e-12
            assert sampled - d[k] <= edge / m


def test_a_degenerate_triangle_is_its_edges():
    tri = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]])
    d = point_triangle_distances(np.array([1.5, 3.0, 4.0]), tri)
    np.testing.assert_allclose(d, [5.0], rtol=1e-15)


def test_bark_clearance_with_boxes_first_is_the_brute_force():
    rng = np.random.default_rng(9)
    v = rng.uniform(-3, 3, (300, 3))
    f = rng.integers(0, 300, (200, 3))
    pts = rng.uniform(-4, 4, (50, 3))
    d, i = bark_clearance(v, f, pts)
    brute = np.array([point_triangle_distances(p, v[f]).min() for p in pts])
    np.testing.assert_array_equal(d, brute)
    assert (i >= 0).all()


def test_bark_beyond_the_bound_is_not_searched():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    d, i = bark_clearance(v, [[0, 1, 2]], [[0.0, 0.0, 5.0]], upper=[1.0])
    assert d[0] == np.inf and i[0] == -1


# -- forests ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def forest():
    return batecho.Forest.paper_example(3, variants=2)


def test_a_forests_clearance_is_the_nearer_of_its_leaves_and_its_bark(forest):
    cx, cy = forest.mean_position
    pts = batecho.circle((cx, cy), 6.2, 5.0, n_points=40).positions
    leaf = forest.scene().clearance(pts)
    v, f, _ = forest.bark()
    bark = np.array([point_triangle_distances(p, v[f]).min() for p in pts])
    np.testing.assert_array_equal(forest.clearance(pts), np.minimum(leaf, bark))
    np.testing.assert_array_equal(forest.clearance(pts, bark=False), leaf)


def test_the_clear_circle_keeps_the_margin_from_leaves_and_bark(forest):
    c = forest.mean_position
    for altitude in (None, 5.0):
        r = forest.clear_circle_radius(c, 6.2, 0.5, altitude=altitude)
        assert r >= 6.2
        pts = batecho.circle(c, r, 5.0, n_points=720).positions
        # 720 points 2 pi r / 720 apart: the circle between them comes at most half that nearer
        assert forest.clearance(pts).min() >= 0.5 + np.pi * r / 720


def test_a_circle_that_already_clears_the_crowns_keeps_its_radius():
    one = batecho.Forest.from_positions([[0.0, 0.0]], rng=1)
    assert one.clear_circle_radius((0.0, 0.0), 6.2, 0.5, altitude=5.0) == 6.2


def test_the_paper_circle_passes_through_its_forests_crowns(forest):
    """Why the experiments widen it: the paper's own geometry."""
    pts = batecho.circle(forest.mean_position, 6.2, 5.0, n_points=360).positions
    assert forest.clearance(pts).min() < 0.5


# -- simulate's warning -------------------------------------------------------------------


def near_leaf_case():
    leaves = batecho.Leaves([[2.0, 0.0, 0.0], [0.3, 0.0, 0.0]], [[1.0, 0.0, 0.0]] * 2, [0.02] * 2)
    poses = batecho.Poses([[0.0, 0.0, 0.0], [0.0, 0.0, 5.0]], [[1.0, 0.0, 0.0]] * 2)
    return leaves, batecho.Sonar(), poses


def test_simulate_warns_of_a_pose_closer_than_the_margin_naming_pose_distance_and_margin():
    leaves, sonar, poses = near_leaf_case()
    with pytest.warns(ClearanceWarning, match=r"pose 0 .* 0\.3 m from leaf 1.*0\.5 m"):
        batecho.simulate(leaves, sonar, poses)


def test_simulate_says_nothing_when_every_pose_keeps_the_margin():
    leaves, sonar, poses = near_leaf_case()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        batecho.simulate(leaves, sonar, poses, min_clearance_m=0.25)
        batecho.simulate(leaves, sonar, poses, min_clearance_m=0)


def test_the_check_does_not_change_a_bit_of_the_echoes():
    leaves, sonar, poses = near_leaf_case()
    with pytest.warns(ClearanceWarning):
        checked = batecho.simulate(leaves, sonar, poses)
    unchecked = batecho.simulate(leaves, sonar, poses, min_clearance_m=0)
    assert checked.spectrum.tobytes() == unchecked.spectrum.tobytes()
    assert checked.impulse.tobytes() == unchecked.impulse.tobytes()


@pytest.mark.parametrize("bad", [-0.1, np.nan, "half"])
def test_a_bad_margin_is_refused(bad):
    leaves, sonar, poses = near_leaf_case()
    with pytest.raises((ValueError, TypeError), match="min_clearance_m"):
        batecho.simulate(leaves, sonar, poses, min_clearance_m=bad)


# ------------------------------------------------------------------------------- branches


@st.composite
def wooded_scenes_and_points(draw):
    """Up to 60 branch segments (some joined end to end, radii 5 mm to 30 cm), with or
    without leaves, and points on their sides, on their axes (inside), on their caps, on
    their rims, beyond their ends on the axis line, and anywhere."""
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    k = draw(st.integers(1, 60))
    scale = draw(st.sampled_from([0.5, 5.0, 50.0]))
    s = rng.uniform(-scale, scale, (k, 3))
    e = s + rng.normal(size=(k, 3)) * rng.uniform(0.05, scale, (k, 1))
    s[1::2] = e[:-1:2]  # joined end to end
    if draw(st.booleans()):
        e[: k // 2] = s[: k // 2] + [0.0, 0.0, 2.0]  # upright: exact axis-aligned axes
    r = np.exp(rng.uniform(np.log(5e-3), np.log(0.3), k))
    branches = batecho.Branches(s, e, r)
    leaves = None
    if draw(st.booleans()):
        n = draw(st.integers(1, 200))
        leaves = batecho.Leaves(
            rng.uniform(-scale, scale, (n, 3)), rng.normal(size=(n, 3)), rng.uniform(0.01, 0.1, n)
        )
    st_, en, r = branches.starts, branches.ends, branches.radii
    d = en - st_
    u = unit_rows(d)
    m = 40
    j = rng.integers(0, k, m)
    t = rng.uniform(0.0, 1.0, m)[:, None]
    side = in_plane(u[j], rng)
    axis_pt = st_[j] + t * d[j]
    pts = np.concatenate(
        [
            axis_pt + r[j, None] * side,  # on the side
            axis_pt,  # on the axis, inside
            en[j] + t * r[j, None] * side,  # on the end cap
            en[j] + r[j, None] * side,  # on the rim
            en[j] + (0.1 + t) * d[j],  # beyond the end, on the axis line
            st_[j] - t * d[j] + 2.0 * r[j, None] * side,  # beyond the start, off the axis
            rng.uniform(-2 * scale, 2 * scale, (m, 3)),  # anywhere
        ]
    )
    return batecho.Scene(leaves, branches=branches), pts


@given(wooded_scenes_and_points())
def test_with_branches_the_clearance_is_the_reference_brute_force_to_the_bit(case):
    scene, pts = case
    got, got_i = scene.clearance(pts, return_index=True)
    want, want_i = reference.clearance(scene, pts)
    assert got.tobytes() == want.tobytes()
    np.testing.assert_array_equal(got_i, want_i)


def test_the_distance_to_a_branch_is_to_its_side_its_cap_or_its_rim_and_zero_inside():
    trunk = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 4.0]], [0.25])
    scene = batecho.Scene(None, branches=trunk)
    pts = [[1.0, 0.0, 2.0], [0.1, 0.0, 2.0], [0.0, 0.1, 5.0], [1.25, 0.0, -3.0], [0.0, 0.0, 4.0]]
    d, i = scene.clearance(pts, return_index=True)
    # the side, inside, beyond the cap on the axis, off the rim (3 m down, 1 m out), on the cap
    np.testing.assert_allclose(d, [0.75, 0.0, 1.0, np.sqrt(10.0), 0.0], atol=1e-15)
    assert i.tolist() == [-1] * 5  # branch 0


def test_branches_distance_to_is_the_scenes_clearance_beyond_the_caps_and_the_rims():
    trunk = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 4.0]], [0.25])
    pts = [[1.0, 0.0, 2.0], [0.0, 0.1, 5.0], [1.25, 0.0, -3.0], [0.3, 0.0, 4.2], [0.0, 0.0, -0.5]]
    want = batecho.Scene(None, branches=trunk).clearance(pts)
    got = [trunk.distance_to(p)[0] for p in pts]
    # the side, beyond the cap on the axis, off the rim, just off the rim, below the base cap
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)


def test_branches_distance_to_is_minus_the_depth_to_the_nearest_face_inside():
    trunk = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 4.0]], [0.25])
    pts = [[0.1, 0.0, 2.0], [0.0, 0.0, 0.1], [0.0, 0.2, 3.95]]
    got = [trunk.distance_to(p)[0] for p in pts]
    # the side is nearest, the base cap is, the top cap is (nearer than the side)
    np.testing.assert_allclose(got, [-0.15, -0.1, -0.05], atol=1e-15)


def test_the_nearer_of_a_leaf_and_a_branch_is_named():
    leaves = batecho.Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.05])
    trunk = batecho.Branches(
        [[-1.0, 0.0, -2.0], [0.0, 3.0, -2.0]], [[-1.0, 0.0, 2.0], [0.0, 3.0, 2.0]], [0.2, 0.2]
    )
    scene = batecho.Scene(leaves, branches=trunk)
    d, i = scene.clearance([[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [0.0, 2.5, 0.0]], return_index=True)
    np.testing.assert_allclose(d, [0.8, 0.5, 0.3], atol=1e-12)
    assert i.tolist() == [-1, 0, -2]


def test_simulate_warns_of_a_pose_close_to_a_trunk_naming_the_branch():
    leaves = batecho.Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.03])
    trunk = batecho.Branches([[0.5, -0.5, -2.0]], [[0.5, -0.5, 2.0]], [0.3])
    scene = batecho.Scene(leaves, branches=trunk)
    pose = batecho.Poses([[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]])
    with pytest.warns(ClearanceWarning, match=r"pose 0 .* from branch 0"):
        batecho.simulate(scene, batecho.Sonar(too_close="skip"), pose)


# -- the bark grid --------------------------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([0.05, 0.3, 1.0, 5.0]))
def test_the_bark_grid_finds_the_brute_force_nearest_triangle(seed, cell_m):
    rng = np.random.default_rng(seed)
    corners = rng.uniform(-3, 3, (80, 1, 3))
    tri = corners + rng.normal(0.0, rng.choice([0.02, 0.3, 2.0]), (80, 3, 3))
    v, f = tri.reshape(-1, 3), np.arange(240).reshape(80, 3)
    pts = rng.uniform(-5, 5, (30, 3))
    grid = BarkGrid(v, f, cell_m=cell_m)
    d, i = bark_clearance(None, None, pts, grid=grid)
    brute = np.array([point_triangle_distances(p, tri) for p in pts])
    np.testing.assert_array_equal(d, brute.min(axis=1))
    np.testing.assert_array_equal(i, brute.argmin(axis=1))
    upper = float(np.median(brute.min(axis=1)))
    near = brute.min() if brute.min() <= upper else np.inf
    assert grid.set_clearance(pts, upper) == near


def test_the_bark_grid_leaves_triangles_beyond_the_bound_unsearched():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    grid = BarkGrid(v, [[0, 1, 2]])
    assert grid.nearest(np.array([0.0, 0.0, 5.0]), 1.0) == (np.inf, -1)
    assert grid.set_clearance(np.array([[0.0, 0.0, 5.0]]), 1.0) == np.inf
    assert grid.nearest(np.array([0.2, 0.2, 5.0]), 6.0) == (5.0, 0)


# -- flights ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def pass_by(forest):
    """A flight that passes a tree's trunk 0.6 m from its axis, at 2 m, sampled every 10 ms."""
    from batecho.flight import Line

    base = forest.trunk_bases[0]
    a, b = base + (-2.0, 0.6, 2.0), base + (2.0, 0.6, 2.0)
    path = Line(a, b, speed=2.0)
    return batecho.Quadrotor.crazyflie().fly(path, duration=path.duration, dt=1e-2)


def test_a_flights_clearance_is_the_forests_at_its_positions(forest, pass_by):
    np.testing.assert_array_equal(pass_by.clearance(forest), forest.clearance(pass_by.positions))
    np.testing.assert_array_equal(
        pass_by.clearance(forest.scene()), forest.scene().clearance(pass_by.positions)
    )


def test_a_flights_smallest_clearance_names_its_time(forest, pass_by):
    d = pass_by.clearance(forest)
    smallest, t = pass_by.min_clearance(forest)
    assert smallest == d.min() and t == pass_by.times[np.argmin(d)]


def test_a_collision_is_the_first_time_the_clearance_falls_below_the_radius(forest, pass_by):
    d = pass_by.clearance(forest)
    radius = float(np.quantile(d, 0.2))
    first = np.flatnonzero(d < radius)[0]
    assert pass_by.collision(forest, radius) == pass_by.times[first]
    assert pass_by.collision(forest, 0.0) is None
    assert pass_by.collision(forest, float(d.min())) is None


@pytest.mark.parametrize("bad", [-0.1, np.nan])
def test_a_bad_drone_radius_is_refused_by_name(forest, pass_by, bad):
    with pytest.raises(ValueError, match="radius_m"):
        pass_by.collision(forest, bad)


def test_a_bark_grid_too_large_for_memory_is_refused_before_it_is_filed():
    # one 100 km triangle covers 4e10 cells of 0.5 m (NumPy was asked for 298 GiB)
    big = np.array([[0.0, 0.0, 0.0], [1e5, 0.0, 0.0], [0.0, 1e5, 0.0]])
    with pytest.raises(MemoryError, match="bark grid .* memory limit"):
        BarkGrid(big, [[0, 1, 2]])
