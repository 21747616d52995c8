"""The Rust exact path agrees with the NumPy reference (docs/model.md) on generated scenes.

Tolerance: relative L2 error of the spectrum and of the impulse at most 1e-10, and the same
number of counting leaves per pose. Generated scenes mix the hard cases: normal and grazing
incidence, leaves exactly on and next to the lobe boundary, radii from 1 mm to 20 cm, ranges
from 5 cm to the edge of the record, many leaves at one range.
"""

from __future__ import annotations

import numpy as np
from _helpers import frame_points, rel_err
from _strategies import boundary_range, cases
from hypothesis import given, note
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context

import batecho
from batecho import Leaves, Poses, Sonar, reference

TOL = 1e-10


def assert_agree(leaves, sonar, pose):
    got = batecho.simulate(leaves, sonar, pose, method="exact")
    want = reference.simulate(leaves, sonar, pose)
    if currently_in_test_context():
        note(f"n_leaves rust={got.n_leaves} ref={want.n_leaves}")
    assert np.array_equal(got.n_leaves, want.n_leaves)
    assert rel_err(got.spectrum, want.spectrum) <= TOL
    assert rel_err(got.impulse, want.impulse) <= TOL
    return got, want


@given(cases())
def test_exact_matches_reference_on_generated_scenes(case):
    sonar, pose, leaves = case
    assert_agree(leaves, sonar, pose)


@given(st.integers(0, 2**32 - 1), st.integers(50, 1500), st.floats(0.3, 9.5))
def test_exact_matches_reference_with_many_leaves_at_one_range(seed, n, r):
    """Every leaf at the same range: equal delays, phases that differ only through the leaf
    model, so the sum cancels in part."""
    rng = np.random.default_rng(seed)
    sonar = Sonar(beamwidth_deg=40.0, spreading=bool(seed % 2))
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    az = rng.uniform(-0.2, 0.2, n)
    el = rng.uniform(-0.2, 0.2, n)
    centers = frame_points(pose, np.full(n, r), az, el)
    leaves = Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.005, 0.05, n))
    got, _want = assert_agree(leaves, sonar, pose)
    assert got.n_leaves[0] > 0


@given(st.integers(0, 2**32 - 1))
def test_exact_matches_reference_on_the_canonical_box(seed):
    from batecho.echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar

    leaves = canonical_leaf_box(np.random.default_rng(seed), density_per_m3=5.0)
    assert_agree(leaves, canonical_sonar(), canonical_pose())


def test_exact_matches_reference_for_leaves_exactly_on_the_detectable_boundary():
    """A shell of leaves placed at the reference's computed reach: each falls in or out by its
    last bit, and both implementations must decide every one the same way."""
    sonar = Sonar(beamwidth_deg=25.0)
    pose = Poses([1.0, 2.0, 3.0], [0.3, 1.0, 0.1])
    rng = np.random.default_rng(5)
    az = rng.uniform(-0.5, 0.5, 300)
    el = rng.uniform(-0.5, 0.5, 300)
    r = np.array([boundary_range(sonar, pose, a, e) for a, e in zip(az, el, strict=False)])
    keep = r > 0.05
    leaves = Leaves(
        frame_points(pose, r[keep], az[keep], el[keep]),
        rng.normal(size=(keep.sum(), 3)),
        np.full(keep.sum(), 0.02),
    )
    got, _want = assert_agree(leaves, sonar, pose)
    assert 0 < got.n_leaves[0] < keep.sum()  # the shell really straddles the boundary
