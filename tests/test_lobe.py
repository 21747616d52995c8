"""The BVH lobe query returns exactly the brute-force set of counting leaves.

The BVH only prunes nodes that provably hold no counting leaf; every candidate then goes
through the exact f64 test. So ``search="bvh"`` must equal ``search="brute_force"`` (the same
test on every leaf, in Rust) and the NumPy reference, on random scenes and on leaves placed
exactly on the lobe boundary.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from _helpers import frame_points
from hypothesis import given
from hypothesis import strategies as st

from batecho import Beam, Leaves, Poses, Scene, Sonar, lobe_members, reference


def three_way(scene: Scene, sonar: Sonar, pose: Poses) -> np.ndarray:
    bvh = lobe_members(scene, sonar, pose)
    brute = lobe_members(scene, sonar, pose, search="brute_force")
    ref = reference.lobe_members(scene, sonar, pose)
    np.testing.assert_array_equal(bvh, brute)
    np.testing.assert_array_equal(bvh, ref)
    return bvh


sonar_kwargs = st.one_of(
    st.builds(dict, beamwidth_deg=st.floats(3.0, 150.0), threshold_db=st.floats(-10.0, 40.0)),
    st.builds(dict, lobe=st.just("cone"), cone_half_angle_deg=st.floats(1.0, 120.0)),
    st.builds(
        lambda sx, sy, rot, az0, el0: dict(
            beam=Beam(sigma_deg=(sx, sy), rotation_deg=rot, center_deg=(az0, el0))
        ),
        st.floats(1.0, 30.0),
        st.floats(1.0, 30.0),
        st.floats(-180.0, 180.0),
        st.floats(-170.0, 170.0),
        st.floats(-80.0, 80.0),
    ),
    st.builds(
        lambda bw, rbw, az0: dict(
            beam=Beam(beamwidth_deg=bw, center_deg=(az0, 0.0)), receiver=Beam(beamwidth_deg=rbw)
        ),
        st.floats(5.0, 90.0),
        st.floats(5.0, 90.0),
        st.floats(-60.0, 60.0),
    ),
)


@given(st.integers(0, 2**32 - 1), st.integers(1, 3000), sonar_kwargs)
def test_bvh_members_equal_brute_force_on_random_scenes(seed, n, kw):
    rng = np.random.default_rng(seed)
    scale = rng.choice([0.5, 5.0, 30.0])
    leaves = Leaves(
        rng.normal(scale=scale, size=(n, 3)), rng.normal(size=(n, 3)), rng.uniform(0.005, 0.05, n)
    )
    pose = Poses(rng.normal(scale=scale / 3, size=3), rng.normal(size=3) + [0.0, 0.0, 0.0])
    sonar = Sonar(too_close="skip", **kw)
    three_way(Scene(leaves), sonar, pose)


def boundary_shell(sonar: Sonar, pose: Poses, n: int, seed: int, spread: float) -> Leaves:
    """Leaves at the reference's computed detectable reach, and at 1 ulp-ish either side."""
    rng = np.random.default_rng(seed)
    az = rng.uniform(-spread, spread, n)
    el = rng.uniform(-spread, spread, n)
    ones = frame_points(pose, np.ones(n), az, el)
    lv = Leaves(ones, np.tile([0.0, 0.0, 1.0], (n, 1)), np.full(n, 0.02))
    _, _, _, G = reference._view(lv.centers, sonar, pose, 0)
    K = sonar.r0_m**2 * sonar.p0_pa / (10.0 ** (sonar.threshold_db / 20.0) * sonar.p_ref_pa)
    r = np.sqrt(K * G)
    r = r * rng.choice([1.0, 1.0, 1.0 + 2e-16, 1.0 - 2e-16, 1.0 + 1e-12, 1.0 - 1e-12], n)
    keep = r > 0.02
    return Leaves(
        frame_points(pose, r[keep], az[keep], el[keep]),
        rng.normal(size=(keep.sum(), 3)),
        np.full(keep.sum(), 0.02),
    )


@given(st.integers(0, 2**32 - 1), st.floats(5.0, 120.0), st.floats(-10.0, 30.0))
def test_bvh_members_equal_brute_force_on_the_detectable_boundary(seed, bw, t_db):
    sonar = Sonar(beamwidth_deg=bw, threshold_db=t_db, too_close="skip")
    pose = Poses([3.0, -1.0, 5.0], [1.0, 2.0, -0.3])
    leaves = boundary_shell(sonar, pose, 400, seed, spread=math.radians(bw))
    members = three_way(Scene(leaves), sonar, pose)
    assert 0 < len(members) < len(leaves)


@given(st.integers(0, 2**32 - 1), st.floats(1.0, 100.0))
def test_bvh_members_equal_brute_force_on_the_cone_boundary(seed, half_deg):
    rng = np.random.default_rng(seed)
    sonar = Sonar(lobe="cone", cone_half_angle_deg=half_deg)
    pose = Poses([0.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    h = math.radians(half_deg)
    n = 300
    phi = rng.uniform(0, 2 * np.pi, n)
    h_i = h * rng.choice([1.0, 1.0 + 1e-15, 1.0 - 1e-15, 1.0 + 1e-9, 1.0 - 1e-9], n)
    e = (
        np.cos(h_i)[:, None] * pose.forward[0]
        + (np.sin(h_i) * np.cos(phi))[:, None] * pose.left[0]
        + (np.sin(h_i) * np.sin(phi))[:, None] * pose.up[0]
    )
    r = rng.uniform(0.5, 9.0, n)
    leaves = Leaves(e * r[:, None], rng.normal(size=(n, 3)), np.full(n, 0.02))
    members = three_way(Scene(leaves), sonar, pose)
    assert 0 < len(members) < n


def test_bvh_members_equal_brute_force_in_a_dense_forest():
    rng = np.random.default_rng(11)
    n = 200_000
    centers = np.column_stack(
        [rng.uniform(-30, 30, n), rng.uniform(-30, 30, n), rng.uniform(1, 12, n)]
    )
    scene = Scene(Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.04, n)))
    for bw in (10.0, 50.0):
        sonar = Sonar(beamwidth_deg=bw)
        for _ in range(3):
            pose = Poses([*rng.uniform(-10, 10, 2), 5.0], [*rng.normal(size=2), 0.2])
            members = three_way(scene, sonar, pose)
            assert len(members) > 0


def test_lobe_members_with_a_leaf_behind_the_sonar_excludes_it():
    sonar = Sonar(beamwidth_deg=30.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    leaves = Leaves([[2.0, 0.0, 0.0], [-2.0, 0.0, 0.0]], [[1.0, 0, 0], [1.0, 0, 0]], [0.02, 0.02])
    np.testing.assert_array_equal(lobe_members(leaves, sonar, pose), [0])


def test_detectable_reach_on_the_axis_is_ten_metres():
    sonar = Sonar(beamwidth_deg=30.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    x = np.array([9.999, 10.0, 10.001])
    leaves = Leaves(
        np.column_stack([x, np.zeros(3), np.zeros(3)]),
        np.tile([1.0, 0, 0], (3, 1)),
        np.full(3, 0.02),
    )
    np.testing.assert_array_equal(lobe_members(leaves, sonar, pose), [0, 1])
    assert sonar.max_reach_m == 10.0


def test_lobe_members_refuses_more_than_one_pose():
    sonar = Sonar()
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0, 0]], [0.02])
    poses = Poses([[0.0, 0, 0], [0.0, 1, 0]], [1.0, 0, 0])
    try:
        lobe_members(leaves, sonar, poses)
    except ValueError as e:
        assert "one pose" in str(e)
    else:
        raise AssertionError("expected ValueError")


def test_a_receiver_index_too_large_for_an_int_is_refused_as_out_of_range():
    # (the core's argument conversion raised "OverflowError: int too big to convert")
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0, 0]], [0.02])
    pose = Poses([0.0, 0, 0], [1.0, 0, 0])
    with pytest.raises(ValueError, match="receiver 1180591620717411303424 out of range"):
        lobe_members(leaves, Sonar.binaural(0.02, 30.0), pose, receiver=2**70)


@pytest.mark.parametrize("search", [None, 3, "BVH"])
def test_a_search_that_is_not_one_of_the_two_is_refused_naming_it(search):
    # (None and 3 raised the core's "'None' is not an instance of 'str'")
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0, 0]], [0.02])
    pose = Poses([0.0, 0, 0], [1.0, 0, 0])
    with pytest.raises(ValueError, match="search must be 'bvh' or 'brute_force'"):
        lobe_members(leaves, Sonar(), pose, search=search)
