"""Shading (docs/model.md §10): the Rust core's crossings and blocks equal the NumPy reference's
brute force on random scenes and on the hard cases (rays grazing a rim, a leaf exactly behind
another, coincident leaves, a disk lying along the ray, thousands of leaves in a row); the
shaded echo is the sum over m of tau^(2m) times the unshaded echo of the leaves crossed m
times; a trunk in the way silences a leaf; tau = 1 is the unshaded echo bit for bit; the fast
method stays within tol; results do not depend on the number of threads."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from _helpers import frame_points, rel_err, run_script_with_threads
from _strategies import cases
from hypothesis import given
from hypothesis import strategies as st

import batecho
from batecho import Branches, Leaves, Poses, Scene, Shading, Sonar, leaf_sights, reference

ORIGIN = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
WIDE = Sonar(beamwidth_deg=60.0)


def assert_sights_equal_reference(scene, sonar, pose, branches_block=True):
    got = leaf_sights(scene, sonar, pose, branches_block=branches_block)
    want = reference.leaf_sights(scene, sonar, pose, branches_block=branches_block)
    np.testing.assert_array_equal(got.index, want.index)
    np.testing.assert_array_equal(got.crossings, want.crossings)
    np.testing.assert_array_equal(got.blocked, want.blocked)
    return got


def clumps(rng, n, n_clumps=6, spread=0.5):
    """``n`` leaves in clumps 1.5-8 m in front of the origin: leaves shade each other."""
    centres = np.column_stack(
        [
            rng.uniform(1.5, 8.0, n_clumps),
            rng.uniform(-1.5, 1.5, n_clumps),
            rng.uniform(-1, 1, n_clumps),
        ]
    )
    c = centres[rng.integers(0, n_clumps, n)] + rng.uniform(-spread, spread, (n, 3))
    return Leaves(c, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.05, n))


# ---------------------------------------------------------------- against the reference


@given(st.integers(0, 2**32 - 1), st.integers(2, 800))
def test_crossings_equal_the_brute_force_reference_in_clumped_scenes(seed, n):
    rng = np.random.default_rng(seed)
    sights = assert_sights_equal_reference(clumps(rng, n), WIDE, ORIGIN)
    assert sights.index.size > 0


@given(cases())
def test_crossings_equal_the_reference_on_the_lobe_tests_hard_cases(case):
    sonar, poses, leaves = case
    for i in range(len(poses)):
        assert_sights_equal_reference(leaves, sonar, poses[i])


@given(st.integers(0, 2**32 - 1), st.integers(0, 40))
def test_rays_grazing_a_rim_are_decided_as_the_reference_decides_them(seed, ulps):
    # An occluder across the x axis; targets whose rays pass its rim exactly (in real numbers)
    # and a few ulps either side.
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.01, 0.05)
    x0 = rng.uniform(1.0, 4.0)
    phi = rng.uniform(0.0, 2 * np.pi, 64)
    scale = rng.uniform(1.2, 2.5)
    rim = np.column_stack([np.full(64, x0), a * np.cos(phi), a * np.sin(phi)])
    targets = rim * scale
    if ulps % 2:  # one ulp outwards
        targets[:, 1:] = np.nextafter(targets[:, 1:], np.where(targets[:, 1:] < 0, -np.inf, np.inf))
    for _ in range(ulps // 2):
        targets[:, 1:] = np.nextafter(targets[:, 1:], 0.0)
    n = np.tile([1.0, 0.0, 0.0], (65, 1))
    n[1:] = rng.normal(size=(64, 3))  # the targets' own normals are free
    leaves = Leaves(np.vstack([[x0, 0.0, 0.0], targets]), n, np.r_[a, np.full(64, 0.01)])
    assert_sights_equal_reference(leaves, WIDE, ORIGIN)


def test_a_ray_through_the_rim_exactly_counts_as_a_crossing():
    # the hit point (2, 0.25, 0) lies at exactly the radius 0.25 from the occluder's centre
    leaves = Leaves([[2.0, 0.0, 0.0], [4.0, 0.5, 0.0]], [[1, 0, 0], [1, 0, 0]], [0.25, 0.02])
    sights = assert_sights_equal_reference(leaves, WIDE, ORIGIN)
    assert sights.crossings.tolist() == [0, 1]


def test_a_leaf_exactly_behind_another_is_crossed_once_and_the_front_one_not_at_all():
    leaves = Leaves([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]], [[1, 0, 0], [0.6, 0.8, 0]], [0.02, 0.02])
    sights = assert_sights_equal_reference(leaves, WIDE, ORIGIN)
    assert sights.crossings.tolist() == [0, 1]


def test_coincident_leaves_do_not_shade_each_other():
    # two disks with one centre (the rays end at the centre: t = 1 is not in the open segment)
    c = [[2.0, 0.1, 0.0], [2.0, 0.1, 0.0], [2.0, 0.1, 0.0]]
    n = [[1, 0, 0], [1, 0, 0], [0, 1, 0]]
    sights = assert_sights_equal_reference(Leaves(c, n, [0.03, 0.03, 0.05]), WIDE, ORIGIN)
    assert sights.crossings.tolist() == [0, 0, 0]


def test_a_disk_lying_along_the_ray_is_not_crossed():
    # the front disk's plane holds the ray (n . w = 0): parallel rays do not cross
    leaves = Leaves([[2.0, 0.0, 0.0], [3.0, 0.0, 0.0]], [[0, 0, 1], [0, 1, 0]], [0.05, 0.02])
    sights = assert_sights_equal_reference(leaves, WIDE, ORIGIN)
    assert sights.crossings.tolist() == [0, 0]


def test_thousands_of_leaves_in_a_row_are_each_crossed_by_every_one_in_front():
    n = 3000
    x = 0.5 + 0.003 * np.arange(n)
    rng = np.random.default_rng(2)
    tilt = np.column_stack([np.ones(n), rng.uniform(-0.5, 0.5, (n, 2))])
    leaves = Leaves(np.column_stack([x, np.zeros(n), np.zeros(n)]), tilt, np.full(n, 0.01))
    sonar = Sonar(beamwidth_deg=60.0, shading=Shading())
    sights = assert_sights_equal_reference(leaves, sonar, ORIGIN)
    np.testing.assert_array_equal(sights.index, np.arange(n))
    np.testing.assert_array_equal(sights.crossings, np.arange(n))


# ------------------------------------------------------------- the echo it gives


@given(st.integers(0, 2**32 - 1), st.floats(0.0, 1.0), st.booleans())
def test_shaded_echoes_equal_the_reference(seed, tau, with_wood):
    rng = np.random.default_rng(seed)
    leaves = clumps(rng, 300)
    branches = None
    if with_wood:
        s = np.column_stack([rng.uniform(2, 7, 4), rng.uniform(-1, 1, 4), np.full(4, -2.0)])
        branches = Branches(s, s + [0.0, 0.0, 4.0], rng.uniform(0.03, 0.15, 4))
    scene = Scene(leaves, branches=branches)
    sonar = Sonar(beamwidth_deg=50.0, shading=Shading(tau, branches_block=with_wood))
    poses = Poses([[0, 0, 0], [0.3, -0.2, 0.1]], [[1, 0, 0], [1, 0.1, -0.05]])
    got = batecho.simulate(scene, sonar, poses, method="exact")
    want = reference.simulate(scene, sonar, poses)
    np.testing.assert_array_equal(got.n_shaded, want.n_shaded)
    np.testing.assert_array_equal(got.n_leaves, want.n_leaves)
    assert rel_err(got.spectrum, want.spectrum) <= 1e-11


@given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.3, 0.6, 0.95]))
def test_the_shaded_echo_is_the_sum_over_m_of_tau_2m_times_the_echo_of_leaves_crossed_m_times(
    seed, tau
):
    rng = np.random.default_rng(seed)
    leaves = clumps(rng, 400, n_clumps=3)
    plain = Sonar(beamwidth_deg=50.0)
    sights = leaf_sights(leaves, plain, ORIGIN)
    shaded = batecho.simulate(
        leaves, plain.replace(shading=Shading(tau)), ORIGIN, method="exact"
    ).spectrum
    total = np.zeros_like(shaded)
    for m in np.unique(sights.crossings):
        group = leaves[sights.index[sights.crossings == m]]
        total += tau ** (2 * m) * batecho.simulate(group, plain, ORIGIN, method="exact").spectrum
    assert rel_err(shaded, total) <= 1e-12
    assert (sights.crossings > 0).any()


def test_a_trunk_between_the_sonar_and_a_leaf_silences_the_leaf():
    leaf = Leaves([[4.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.03])
    trunk = Branches([[2.0, 0.0, -3.0]], [[2.0, 0.0, 3.0]], [0.15])
    scene = Scene(leaf, branches=trunk)
    sonar = Sonar(beamwidth_deg=30.0, shading=Shading(branches_block=True))
    e = batecho.simulate(scene, sonar, ORIGIN, method="exact")
    assert e.n_shaded.tolist() == [1]
    assert e.wood_spectrum is not None
    assert np.array_equal(e.spectrum, e.wood_spectrum)  # the leaf adds nothing
    open_ = batecho.simulate(scene, sonar.replace(shading=Shading(branches_block=False)), ORIGIN)
    leaf_alone = batecho.simulate(leaf, Sonar(beamwidth_deg=30.0), ORIGIN, method="exact")
    assert rel_err(open_.spectrum - open_.wood_spectrum, leaf_alone.spectrum) <= 1e-12


def test_a_trunk_beside_the_ray_does_not_silence_the_leaf():
    leaf = Leaves([[4.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.03])
    trunk = Branches([[2.0, 0.5, -3.0]], [[2.0, 0.5, 3.0]], [0.15])
    e = batecho.simulate(
        Scene(leaf, branches=trunk), Sonar(shading=Shading()), ORIGIN, method="exact"
    )
    assert e.n_shaded.tolist() == [0]
    assert np.abs(e.spectrum - e.wood_spectrum).max() > 0


@pytest.mark.parametrize("method", ["exact", "fast", "auto"])
def test_a_transmission_of_one_gives_the_unshaded_echo_bit_for_bit(method):
    rng = np.random.default_rng(8)
    leaves = clumps(rng, 6000)
    poses = Poses([[0, 0, 0], [0.5, 0.2, 0]], [[1, 0, 0], [1, 0.2, 0]])
    plain = Sonar(beamwidth_deg=50.0)
    a = batecho.simulate(leaves, plain, poses, method=method, tol=1e-6)
    b = batecho.simulate(
        leaves, plain.replace(shading=Shading(1.0, False)), poses, method=method, tol=1e-6
    )
    assert a.spectrum.tobytes() == b.spectrum.tobytes()
    assert a.impulse.tobytes() == b.impulse.tobytes()
    assert b.n_shaded.tolist() == [0, 0]


@given(st.integers(0, 2**32 - 1), st.sampled_from([1e-3, 1e-6, 1e-9, 1e-12]), st.booleans())
def test_the_fast_method_stays_within_tol_with_shading(seed, tol, with_wood):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(100, 6000))
    leaves = clumps(rng, n, spread=rng.uniform(0.2, 1.0))
    branches = None
    if with_wood:
        s = np.column_stack([rng.uniform(2, 7, 3), rng.uniform(-1, 1, 3), np.full(3, -2.0)])
        branches = Branches(s, s + rng.uniform(-0.5, 0.5, (3, 3)) + [0, 0, 4], [0.1, 0.05, 0.2])
    scene = Scene(leaves, branches=branches)
    sonar = Sonar(beamwidth_deg=50.0, shading=Shading(rng.uniform(0.0, 1.0)))
    exact = batecho.simulate(scene, sonar, ORIGIN, method="exact")
    for method in ("fast", "auto"):
        fast = batecho.simulate(scene, sonar, ORIGIN, method=method, tol=tol)
        assert np.array_equal(fast.n_shaded, exact.n_shaded)
        assert rel_err(fast.spectrum, exact.spectrum) <= tol


def test_leaves_outside_the_lobe_shade_those_inside():
    # the occluder's centre lies outside the 10 degree cone, its disk across a member's ray
    target = frame_points(ORIGIN, [5.0], [np.radians(9.0)], [0.0])
    occluder = frame_points(ORIGIN, [1.0], [np.radians(11.5)], [0.0])
    leaves = Leaves(np.vstack([target, occluder]), np.vstack([target, occluder]), [0.02, 0.06])
    sonar = Sonar(lobe="cone", cone_half_angle_deg=10.0, beamwidth_deg=20.0)
    sights = assert_sights_equal_reference(leaves, sonar, ORIGIN)
    assert sights.index.tolist() == [0]
    assert sights.crossings.tolist() == [1]


# ------------------------------------------------------------------------ parameters


def test_a_transmission_outside_zero_one_is_refused_by_name():
    with pytest.raises(ValueError, match="leaf_transmission must be in"):
        Shading(1.2)
    with pytest.raises(TypeError, match="leaf_transmission"):
        Shading("0.5")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="shading must be None or a batecho.Shading"):
        Sonar(shading=0.6)  # type: ignore[arg-type]


def test_the_default_sonar_does_not_shade_and_the_default_shading_is_documented():
    assert Sonar().shading is None
    assert Shading().leaf_transmission == batecho.sonar.DEFAULT_LEAF_TRANSMISSION == 0.6
    assert Shading().branches_block is True


# ------------------------------------------------------------------------- threads

SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import batecho
    rng = np.random.default_rng(5)
    n = 40000
    leaves = batecho.Leaves(np.column_stack([rng.uniform(1, 9, n), rng.uniform(-2, 2, n),
                                             rng.uniform(-2, 2, n)]),
                            rng.normal(size=(n, 3)), rng.normal(0.02, 0.002, n))
    s = np.column_stack([rng.uniform(2, 8, 30), rng.uniform(-2, 2, 30), np.full(30, -3.0)])
    wood = batecho.Branches(s, s + [0.0, 0.0, 6.0], rng.uniform(0.05, 0.2, 30))
    scene = batecho.Scene(leaves, branches=wood)
    poses = batecho.Poses([[0, 0, 0], [0, 0.3, 0.1]], [[1, 0, 0], [1, 0.1, 0]])
    out = {}
    for shading in (None, batecho.Shading()):
        sonar = batecho.Sonar(lobe="cone", cone_half_angle_deg=40.0, shading=shading)
        for method, tol in (("exact", 1e-12), ("fast", 1e-6)):
            e = batecho.simulate(scene, sonar, poses, method=method, tol=tol)
            key = f"{shading is not None}-{method}"
            out[key + "-spec"] = e.spectrum
            out[key + "-wood"] = e.wood_spectrum
            out[key + "-shaded"] = e.n_shaded
    np.savez(sys.argv[1], **out)
    """
)


def run(threads: int, path) -> dict:
    return run_script_with_threads(SCRIPT, threads, path)


def test_branches_and_shading_are_bit_identical_with_one_and_two_threads(tmp_path):
    one = run(1, tmp_path / "one.npz")
    two = run(2, tmp_path / "two.npz")
    assert one.keys() == two.keys()
    for k in one:
        assert one[k].tobytes() == two[k].tobytes(), k
    assert one["True-fast-shaded"].min() > 1000


def test_a_numpy_bool_branches_block_is_kept_as_the_python_bool():
    shading = Shading(branches_block=np.False_)
    assert shading == Shading(branches_block=False)
    assert shading.branches_block is False


def test_leaf_sights_takes_a_numpy_bool_branches_block_as_the_python_bool():
    scene = Scene(
        Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02]),
        branches=Branches([[2.0, -1.0, 0.0]], [[2.0, 1.0, 0.0]], [0.05]),
    )
    got = leaf_sights(scene, WIDE, ORIGIN, branches_block=np.False_)
    assert not got.blocked.any()


def test_tiny_leaves_in_a_plane_through_the_sonar_are_shaded_without_a_huge_light_buffer():
    # their directions have a box of no area: the buffer's cells were sized by their tiny
    # angular radius alone (about 1e12 cells, and the process aborted)
    n = 300
    rng = np.random.default_rng(0)
    centers = np.column_stack([np.full(n, 3.0), np.linspace(-1.0, 1.0, n), np.zeros(n)])
    leaves = Leaves(centers, rng.normal(size=(n, 3)), np.full(n, 1e-12))
    sonar = Sonar(min_ka=0.0, shading=Shading())
    echoes = batecho.simulate(Scene(leaves), sonar, batecho.look_at([0, 0, 0], [1, 0, 0]))
    assert echoes.n_leaves[0] == n


def test_a_thin_branch_in_a_plane_through_the_sonar_is_shaded_without_a_huge_light_buffer():
    branch = Branches([[2.0, -1.0, 0.0]], [[2.0, 1.0, 0.0]], [1e-12])
    sonar = Sonar(min_ka=0.0, shading=Shading())
    echoes = batecho.simulate(
        Scene(None, branches=branch), sonar, batecho.look_at([0, 0, 0], [1, 0, 0])
    )
    assert echoes.n_pieces[0] > 0
