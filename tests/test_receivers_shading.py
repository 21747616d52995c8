"""Shading heard by receivers at their own places (docs/model.md §10): a leaf's echo at a
receiver is dimmed by tau^(m_out + m_back), the leaves crossed from the emitter and back to that
receiver. A receiver at the emitter gives the monostatic shaded echo; the Rust paths equal the
NumPy reference's brute force on random receiver offsets and on the hard cases (a leaf on the
line from a leaf to one receiver only, a receiver behind a leaf); the fast method stays within
tol; results do not depend on the number of threads."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
from _helpers import rel_err, run_script_with_threads
from hypothesis import given, settings
from hypothesis import strategies as st

import batecho
from batecho import Leaves, Poses, Receiver, Shading, Sonar, reference

ORIGIN = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
TAU = 0.6
SHADED = Sonar(beamwidth_deg=60.0, shading=Shading(leaf_transmission=TAU))
TOL = 1e-10  # against the reference, as tests/test_receivers.py


def clumps(rng, n, n_clumps=5, spread=0.4):
    """``n`` leaves in clumps 1.5-7 m in front of the origin: leaves shade each other."""
    centres = np.column_stack(
        [
            rng.uniform(1.5, 7.0, n_clumps),
            rng.uniform(-1, 1, n_clumps),
            rng.uniform(-1, 1, n_clumps),
        ]
    )
    c = centres[rng.integers(0, n_clumps, n)] + rng.uniform(-spread, spread, (n, 3))
    return Leaves(c, rng.normal(size=(n, 3)), rng.uniform(0.02, 0.05, n))


def assert_agrees_with_reference(leaves, sonar, pose, method="exact", tol=1e-12):
    want = reference.simulate(leaves, sonar, pose)
    got = batecho.simulate(leaves, sonar, pose, method=method, tol=tol)
    np.testing.assert_array_equal(got.n_leaves, want.n_leaves)
    np.testing.assert_array_equal(got.n_shaded, want.n_shaded)
    bound = TOL if method == "exact" else max(tol, TOL)
    for j in range(len(sonar.receivers)):
        assert rel_err(got.spectrum[:, j], want.spectrum[:, j]) <= bound, j
    return got


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_a_receiver_at_the_emitter_hears_the_monostatic_shaded_echo(method):
    leaves = clumps(np.random.default_rng(3), 600)
    mono = batecho.simulate(leaves, SHADED, ORIGIN, method=method)
    heard = batecho.simulate(leaves, SHADED.replace(receivers=(Receiver(),)), ORIGIN, method=method)
    assert mono.n_shaded[0] > 50
    np.testing.assert_array_equal(heard.n_shaded[:, 0], mono.n_shaded)
    np.testing.assert_array_equal(heard.n_leaves[:, 0], mono.n_leaves)
    assert rel_err(heard.spectrum[:, 0], mono.spectrum) <= 1e-12
    assert rel_err(heard.impulse[:, 0], mono.impulse) <= 1e-12


@settings(max_examples=25, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(2, 300),
    st.lists(
        st.tuples(*[st.floats(-1.0, 1.0)] * 3).map(lambda o: tuple(0.5 * x for x in o)),
        min_size=1,
        max_size=3,
    ),
)
def test_shading_with_receivers_equals_the_brute_force_reference(seed, n, offsets):
    leaves = clumps(np.random.default_rng(seed), n)
    sonar = SHADED.replace(receivers=tuple(Receiver(o) for o in offsets), too_close="skip")
    assert_agrees_with_reference(leaves, sonar, ORIGIN)


# Receiver 1 at (0, 0.5, 0): a target leaf at (3, 0, 0) and a leaf halfway from it to that
# receiver, across that segment only (the emitter's ray to the target passes 0.25 m away).
TARGET = np.array([3.0, 0.0, 0.0])
EAR = np.array([0.0, 0.5, 0.0])
MID = (TARGET + EAR) / 2.0
BACK = (EAR - TARGET) / np.linalg.norm(EAR - TARGET)
TWO = SHADED.replace(receivers=(Receiver(), Receiver((0.0, 0.5, 0.0))))


def test_a_leaf_on_the_way_back_to_one_receiver_dims_the_echo_there_by_tau_once():
    target = Leaves([TARGET], [[-1.0, 0.0, 0.0]], [0.04])
    blocker = Leaves([MID], [BACK], [0.04])
    both = Leaves(np.vstack([TARGET, MID]), np.vstack([[-1.0, 0.0, 0.0], BACK]), [0.04, 0.04])
    got = assert_agrees_with_reference(both, TWO, ORIGIN)
    np.testing.assert_array_equal(got.n_leaves, [[2, 2]])
    np.testing.assert_array_equal(got.n_shaded, [[0, 1]])
    plain = TWO.replace(shading=None)
    alone = batecho.simulate(target, plain, ORIGIN).spectrum[0]
    other = batecho.simulate(blocker, plain, ORIGIN).spectrum[0]
    # superposition: the emitter's ear hears both whole, receiver 1 the target dimmed by tau
    assert rel_err(got.spectrum[0, 0], alone[0] + other[0]) <= 1e-12
    assert rel_err(got.spectrum[0, 1], TAU * alone[1] + other[1]) <= 1e-12


def test_a_receiver_behind_a_leaf_hears_every_other_leaf_dimmed():
    rng = np.random.default_rng(11)
    n = 120
    c = np.column_stack(
        [rng.uniform(2, 6, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n)]
    )
    normals = np.tile([1.0, 0.0, 0.0], (n, 1))
    # a 15 cm leaf 0.4 m in front of receiver 1, facing it: every ray back to it crosses
    # the leaf; the emitter's rays pass at least 0.2 m from it
    cover = np.array([[0.4, 0.3, 0.0]])
    leaves = Leaves(np.vstack([c, cover]), np.vstack([normals, [[1.0, 0, 0]]]), [0.03] * n + [0.15])
    sonar = SHADED.replace(
        receivers=(Receiver(), Receiver((0.0, 0.3, 0.0))), lobe="cone", cone_half_angle_deg=60.0
    )
    got = assert_agrees_with_reference(leaves, sonar, ORIGIN)
    assert got.n_shaded[0, 1] >= got.n_leaves[0, 1] - 1 > 100
    assert got.n_shaded[0, 1] > got.n_shaded[0, 0]


@pytest.mark.parametrize("tol", [1e-3, 1e-6, 1e-9])
def test_the_fast_method_with_shading_and_two_ears_stays_within_tol(tol):
    leaves = clumps(np.random.default_rng(7), 3000)
    ears = Sonar.binaural(0.3, ear_yaw_deg=20, beamwidth_deg=60, shading=Shading())
    exact = batecho.simulate(leaves, ears, ORIGIN, method="exact")
    fast = batecho.simulate(leaves, ears, ORIGIN, method="fast", tol=tol)
    assert exact.n_shaded.min() > 500
    np.testing.assert_array_equal(fast.n_shaded, exact.n_shaded)
    for j in range(2):
        assert rel_err(fast.spectrum[:, j], exact.spectrum[:, j]) <= tol


def test_transmission_one_with_receivers_is_the_unshaded_echo_bit_for_bit():
    leaves = clumps(np.random.default_rng(2), 800)
    ears = Sonar.binaural(0.2, ear_yaw_deg=20, beamwidth_deg=60)
    plain = batecho.simulate(leaves, ears, ORIGIN)
    clear = batecho.simulate(leaves, ears.replace(shading=Shading(leaf_transmission=1.0)), ORIGIN)
    assert plain.spectrum.tobytes() == clear.spectrum.tobytes()
    assert clear.n_shaded.shape == (1, 2) and clear.n_shaded.sum() == 0


def test_one_receivers_echoes_keep_their_shaded_counts():
    leaves = clumps(np.random.default_rng(4), 400)
    ears = Sonar.binaural(0.3, ear_yaw_deg=20, beamwidth_deg=60, shading=Shading())
    echo = batecho.simulate(leaves, ears, Poses([[0, 0, 0], [0.2, 0, 0]], [[1, 0, 0]] * 2))
    assert echo.n_shaded.shape == (2, 2)
    np.testing.assert_array_equal(echo.for_receiver(1).n_shaded, echo.n_shaded[:, 1])


@pytest.mark.parametrize("sights", [batecho.leaf_sights, reference.leaf_sights])
def test_leaf_sights_refuses_a_sonar_with_receivers_of_its_own(sights):
    # its rays run from the emitter only, and which leaves count depends on the receiver: two
    # ears facing away from the axis each hear a leaf that no emitter-only lobe holds
    leaves = Leaves([[3.0, 2.0, 0.0], [3.0, -2.0, 0.0]], [[1, 0, 0]] * 2, [0.05] * 2)
    ears = Sonar.binaural(0.02, ear_yaw_deg=40, beamwidth_deg=30, shading=Shading())
    assert batecho.simulate(leaves, ears, ORIGIN).n_leaves.tolist() == [[1, 1]]
    with pytest.raises(ValueError, match="receivers"):
        sights(leaves, ears, ORIGIN)


def test_a_dataset_spec_with_two_ears_and_shading_labels_each_ear():
    from batecho.dataset import DatasetSpec
    from batecho.dataset.store import schema

    spec = DatasetSpec.from_dict(
        {"n_samples": 2, "sonar": {"ear_separation_m": 0.02, "ear_yaw_deg": 20.0, "shading": True}}
    )
    dims = {v.name: v.dims for v in schema(spec)}
    assert dims["n_shaded"] == ("sample", "pulse", "receiver")


SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import batecho
    rng = np.random.default_rng(5)
    n = 20000
    leaves = batecho.Leaves(np.column_stack([rng.uniform(1, 9, n), rng.uniform(-2, 2, n),
                                             rng.uniform(-2, 2, n)]),
                            rng.normal(size=(n, 3)), rng.normal(0.02, 0.002, n))
    poses = batecho.Poses([[0, 0, 0], [0, 0.3, 0.1]], [[1, 0, 0], [1, 0.1, 0]])
    ears = batecho.Sonar.binaural(0.3, ear_yaw_deg=20, lobe="cone", cone_half_angle_deg=40.0,
                                  shading=batecho.Shading())
    out = {}
    for method, tol in (("exact", 1e-12), ("fast", 1e-6)):
        e = batecho.simulate(leaves, ears, poses, method=method, tol=tol)
        out[method + "-spec"] = e.spectrum
        out[method + "-shaded"] = e.n_shaded
    np.savez(sys.argv[1], **out)
    """
)


def run(threads: int, path) -> dict:
    return run_script_with_threads(SCRIPT, threads, path)


def test_shading_with_two_ears_is_bit_identical_with_one_and_two_threads(tmp_path):
    one = run(1, tmp_path / "one.npz")
    two = run(2, tmp_path / "two.npz")
    assert one.keys() == two.keys()
    for k in one:
        assert one[k].tobytes() == two[k].tobytes(), k
    assert one["fast-shaded"].min() > 1000
