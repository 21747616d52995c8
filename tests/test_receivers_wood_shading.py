"""Two ears in a wooded, shading forest (docs/model.md §5a, §9, §10): with receivers at their
own places, branches echo and shading dims leaves and branch pieces by tau^(m_out + m_back),
or silences them where a branch blocks the way out or back. The Rust core equals the NumPy
reference's brute force on random receivers, a receiver at the emitter hears the monostatic
shaded wood, a trunk between a leaf and one ear silences the leaf for that ear only, and
dataset specs take two ears with wood and shading."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import rel_err
from hypothesis import given, note, settings
from hypothesis import strategies as st

import batecho
from batecho import Branches, Leaves, Poses, Receiver, Scene, Shading, Sonar, reference

POSE = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
SHADED = Sonar(beamwidth_deg=60.0, shading=Shading(leaf_transmission=0.6))


def grove(rng: np.random.Generator, n_leaves: int = 80) -> Scene:
    """Leaves in a clump 2-6 m ahead, a trunk through it and two slanting branches."""
    c = np.column_stack([rng.uniform(2.0, 6.0, n_leaves), rng.uniform(-1.0, 1.0, (n_leaves, 2))])
    leaves = Leaves(c, rng.normal(size=(n_leaves, 3)), rng.uniform(0.02, 0.05, n_leaves))
    starts = np.array([[4.0, 0.3, -2.0], [3.0, -0.5, 0.2], [4.5, 0.6, -0.4]])
    ends = np.array([[4.0, 0.3, 2.0], [3.6, 0.4, 1.0], [5.2, -0.2, 0.3]])
    return Scene(leaves, branches=Branches(starts, ends, [0.12, 0.04, 0.05]))


@settings(max_examples=15, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.lists(st.tuples(*(st.floats(-0.3, 0.3) for _ in range(3))), min_size=1, max_size=3),
    st.booleans(),
)
def test_receivers_hear_shaded_wood_and_leaves_as_the_reference_does(seed, offsets, block):
    scene = grove(np.random.default_rng(seed), 40)
    sonar = SHADED.replace(
        shading=Shading(leaf_transmission=0.6, branches_block=block),
        receivers=tuple(Receiver(o) for o in offsets),
        too_close="skip",
    )
    want = reference.simulate(scene, sonar, POSE)
    got = batecho.simulate(scene, sonar, POSE, method="exact")
    note(f"n_shaded rust={got.n_shaded.tolist()} ref={want.n_shaded.tolist()}")
    np.testing.assert_array_equal(got.n_leaves, want.n_leaves)
    np.testing.assert_array_equal(got.n_pieces, want.n_pieces)
    np.testing.assert_array_equal(got.n_shaded, want.n_shaded)
    for j in range(len(offsets)):
        # (a segment's pieces cancel at their shared edges: tolerance as tests/test_branches.py)
        assert rel_err(got.spectrum[:, j], want.spectrum[:, j]) <= 1e-9, j
        assert rel_err(got.wood_spectrum[:, j], want.wood_spectrum[:, j]) <= 1e-9, j


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_a_receiver_at_the_emitter_hears_the_monostatic_shaded_wood(method):
    scene = grove(np.random.default_rng(5))
    mono = batecho.simulate(scene, SHADED, POSE, method=method, tol=1e-9)
    heard = batecho.simulate(
        scene, SHADED.replace(receivers=(Receiver(),)), POSE, method=method, tol=1e-9
    )
    assert mono.n_shaded[0] > 5 and mono.n_pieces[0] > 5
    np.testing.assert_array_equal(heard.n_shaded[:, 0], mono.n_shaded)
    assert rel_err(heard.wood_spectrum[:, 0], mono.wood_spectrum) <= 1e-12
    assert rel_err(heard.spectrum[:, 0], mono.spectrum) <= 1e-12 * (1 if method == "exact" else 1e3)


def test_a_trunk_between_a_leaf_and_one_ear_silences_the_leaf_for_that_ear_only():
    # a leaf 3 m ahead; ears 0.6 m to either side; a thin trunk on the line from the leaf to
    # the left ear only
    leaf = Leaves([[3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.03])
    left, right = np.array([0.0, 0.3, 0.0]), np.array([0.0, -0.3, 0.0])
    mid = 0.5 * (left + np.array([3.0, 0.0, 0.0]))
    trunk = Branches([mid - [0.0, 0.0, 1.0]], [mid + [0.0, 0.0, 1.0]], [0.02])
    sonar = Sonar(
        beamwidth_deg=60.0,
        shading=Shading(leaf_transmission=0.6),
        receivers=(Receiver(tuple(left)), Receiver(tuple(right))),
        window="rect",
    )
    blocked = batecho.simulate(Scene(leaf, branches=trunk), sonar, POSE)
    alone = batecho.simulate(Scene(leaf), sonar, POSE)
    assert blocked.n_shaded.tolist() == [[1, 0]]
    leaf_left = blocked.spectrum[0, 0] - blocked.wood_spectrum[0, 0]
    leaf_right = blocked.spectrum[0, 1] - blocked.wood_spectrum[0, 1]
    assert np.abs(leaf_left).max() <= 1e-12 * np.abs(alone.spectrum[0, 0]).max()
    assert rel_err(leaf_right, alone.spectrum[0, 1]) <= 1e-12


def test_a_dataset_spec_takes_two_ears_with_branches_and_shading():
    from batecho.dataset import DatasetSpec

    spec = DatasetSpec.from_dict(
        {
            "n_samples": 2,
            "scene": {"kind": "forest", "forest": {"branches": True}},
            "sonar": {"ear_separation_m": 0.02, "ear_yaw_deg": 20.0, "shading": True},
        }
    )
    assert spec.has_wood and spec.sonar.shading
