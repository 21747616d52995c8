"""Receivers at their own places (docs/model.md §5a): the monostatic case is the receiver at
the emitter, two ears mirror each other, delays are bistatic, and the Rust paths agree with the
NumPy reference on hard geometries (a receiver at a leaf's range, a leaf between emitter and
receiver, large bistatic angles), within ``tol`` for the fast method."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from _helpers import frame_points, rel_err
from _strategies import cases, unit
from hypothesis import given, note, settings
from hypothesis import strategies as st

import batecho
from batecho import Beam, Leaves, Poses, Receiver, Sonar, reference

TOL = 1e-10  # against the reference, as tests/test_exact_vs_reference.py


@st.composite
def receivers(draw, n=None):
    n = n or draw(st.integers(1, 3))
    out = []
    for _ in range(n):
        offset = tuple(
            draw(st.floats(-1.0, 1.0)) * draw(st.sampled_from([0.01, 0.3, 3.0])) for _ in range(3)
        )
        beam = None
        if draw(st.booleans()):
            beam = Beam(
                sigma_deg=(draw(st.floats(3.0, 60.0)), draw(st.floats(3.0, 60.0))),
                rotation_deg=draw(st.floats(-90.0, 90.0)),
                center_deg=(draw(st.floats(-180.0, 180.0)), draw(st.floats(-60.0, 60.0))),
                amplitude=draw(st.floats(0.5, 2.0)),
            )
        out.append(Receiver(offset, beam))
    return tuple(out)


@st.composite
def heard_cases(draw):
    """A sonar with receivers, a pose and leaves with the hard bistatic cases mixed in."""
    sonar, pose, leaves = draw(cases())
    rxs = list(draw(receivers()))
    centers = list(leaves.centers)
    normals = list(leaves.normals)
    radii = list(leaves.radii)
    p = pose.positions[0]
    frame = np.array([pose.forward[0], pose.left[0], pose.up[0]])
    for _ in range(draw(st.integers(0, 4))):
        kind = draw(st.sampled_from(["at_range", "between", "wide"]))
        c = centers[draw(st.integers(0, len(centers) - 1))]
        r = float(np.linalg.norm(c - p))
        if kind == "at_range":
            # a receiver as far from the emitter as a leaf
            d = unit(np.array([draw(st.floats(-1, 1)) for _ in range(3)]) + 1e-3)
            rxs.append(Receiver(tuple(r * d), rxs[0].beam))
        elif kind == "between":
            # a leaf on the segment between the emitter and a receiver
            k = draw(st.integers(0, len(rxs) - 1))
            at = p + np.asarray(rxs[k].offset_m) @ frame
            if np.linalg.norm(at - p) > 0.1:
                centers.append(p + draw(st.sampled_from([0.25, 0.5, 0.75])) * (at - p))
                normals.append(unit(np.array([draw(st.floats(-1, 1)) for _ in range(3)]) + 1e-3))
                radii.append(0.02)
        else:
            # a receiver far to the side: bistatic angles up to ~90 degrees and beyond
            side = draw(st.sampled_from([-1.0, 1.0]))
            rxs.append(Receiver((0.0, side * max(r, 0.5), draw(st.floats(-1.0, 1.0)))))
    sonar = sonar.replace(receiver=None, receivers=tuple(rxs[:6]))
    return sonar, pose, Leaves(np.array(centers), np.array(normals), np.array(radii))


def assert_agree(leaves, sonar, pose, method="exact", tol=1e-12):
    try:
        want = reference.simulate(leaves, sonar, pose)
    except ValueError as e:
        # a leaf too close to the emitter or a receiver: refused by both
        assert "closer than min_range_m" in str(e)
        with pytest.raises(ValueError, match="closer than min_range_m"):
            batecho.simulate(leaves, sonar, pose, method=method, tol=tol)
        return None
    got = batecho.simulate(leaves, sonar, pose, method=method, tol=tol)
    note(f"n_leaves rust={got.n_leaves.tolist()} ref={want.n_leaves.tolist()}")
    assert got.spectrum.shape == (len(pose), len(sonar.receivers), sonar_bins(got))
    assert np.array_equal(got.n_leaves, want.n_leaves)
    bound = TOL if method == "exact" else max(tol, TOL)
    for j in range(len(sonar.receivers)):
        assert rel_err(got.spectrum[:, j], want.spectrum[:, j]) <= bound, j
        assert rel_err(got.impulse[:, j], want.impulse[:, j]) <= bound, j
    return got


def sonar_bins(echoes) -> int:
    return len(echoes.freqs)


@given(cases(), st.sampled_from(["exact", "fast"]))
def test_a_receiver_at_the_emitter_with_its_pattern_is_the_monostatic_echo(case, method):
    sonar, pose, leaves = case
    sonar = sonar.replace(receiver=None)
    mono = batecho.simulate(leaves, sonar, pose, method=method)
    heard = batecho.simulate(leaves, sonar.replace(receivers=(Receiver(),)), pose, method=method)
    assert heard.spectrum.shape == (len(pose), 1, mono.spectrum.shape[1])
    assert np.array_equal(heard.n_leaves[:, 0], mono.n_leaves)
    assert rel_err(heard.spectrum[:, 0], mono.spectrum) <= 1e-12
    assert rel_err(heard.impulse[:, 0], mono.impulse) <= 1e-12


@settings(max_examples=60)
@given(heard_cases())
def test_exact_matches_the_reference_for_receivers_at_their_own_places(case):
    sonar, pose, leaves = case
    assert_agree(leaves, sonar, pose)


@settings(max_examples=40)
@given(heard_cases(), st.sampled_from([1e-3, 1e-6, 1e-9, 1e-12]))
def test_fast_is_within_tol_of_exact_for_receivers(case, tol):
    sonar, pose, leaves = case
    sonar = sonar.replace(too_close="skip")
    exact = batecho.simulate(leaves, sonar, pose, method="exact")
    for method in ("fast", "auto"):
        got = batecho.simulate(leaves, sonar, pose, method=method, tol=tol)
        assert np.array_equal(got.n_leaves, exact.n_leaves)
        for j in range(len(sonar.receivers)):
            assert rel_err(got.spectrum[:, j], exact.spectrum[:, j]) <= tol


def test_fast_is_within_tol_for_two_ears_in_a_full_lobe():
    from batecho.echoes.canonical import canonical_leaf_box, canonical_pose

    leaves = canonical_leaf_box(np.random.default_rng(2), density_per_m3=120.0)
    sonar = Sonar.binaural(0.02, 30.0, beamwidth_deg=40.0)
    exact = batecho.simulate(leaves, sonar, canonical_pose(), method="exact")
    assert exact.n_leaves.min() > 5000
    for tol in (1e-3, 1e-6, 1e-9, 1e-12):
        fast = batecho.simulate(leaves, sonar, canonical_pose(), method="fast", tol=tol)
        assert np.array_equal(fast.n_leaves, exact.n_leaves)
        for j in range(2):
            assert rel_err(fast.spectrum[:, j], exact.spectrum[:, j]) <= tol


def mirrored(leaves: Leaves) -> Leaves:
    """The scene mirrored across the plane y = 0 (the vertical plane of a sonar at the origin
    looking along +x)."""
    flip = np.array([1.0, -1.0, 1.0])
    return Leaves(leaves.centers * flip, leaves.normals * flip, leaves.radii)


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_mirroring_the_scene_across_the_vertical_plane_swaps_the_ears(method):
    from batecho.echoes.canonical import canonical_leaf_box

    leaves = canonical_leaf_box(np.random.default_rng(7), density_per_m3=5.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    sonar = Sonar.binaural(0.03, 25.0, 5.0, beamwidth_deg=40.0)
    a = batecho.simulate(leaves, sonar, pose, method=method, tol=1e-9)
    b = batecho.simulate(mirrored(leaves), sonar, pose, method=method, tol=1e-9)
    assert np.array_equal(a.n_leaves[:, ::-1], b.n_leaves)
    assert rel_err(b.spectrum[:, ::-1], a.spectrum) <= 1e-9
    assert rel_err(a.spectrum[:, 0], a.spectrum[:, 1]) > 0.1  # the ears hear differently


def peak_time(echoes, j) -> float:
    env = echoes.envelope()[0, j]
    return float(echoes.times[int(np.argmax(env))])


@pytest.mark.parametrize(("az_deg", "el_deg", "r"), [(20.0, 0.0, 2.0), (-35.0, 10.0, 4.5)])
def test_a_single_leafs_delays_are_bistatic_and_its_interaural_delay_is_the_path_difference(
    az_deg, el_deg, r
):
    pose = Poses([0.5, -1.0, 2.0], [1.0, 0.2, 0.0])
    sonar = Sonar.binaural(
        0.4, 40.0, beamwidth_deg=60.0, window="rect", lobe="cone", cone_half_angle_deg=80.0
    )
    c = frame_points(pose, [r], [math.radians(az_deg)], [math.radians(el_deg)])
    n = unit(pose.positions[0] - c[0])  # facing the emitter
    leaf = Leaves(c, [n], [0.02])
    e = batecho.simulate(leaf, sonar, pose, method="exact")
    assert e.n_leaves.tolist() == [[1, 1]]
    v, dt = sonar.sound_speed, 1.0 / sonar.fs
    r_tx = float(np.linalg.norm(c[0] - pose.positions[0]))
    frame = np.array([pose.forward[0], pose.left[0], pose.up[0]])
    r_rx = [
        float(np.linalg.norm(c[0] - (pose.positions[0] + np.asarray(rx.offset_m) @ frame)))
        for rx in sonar.receivers
    ]
    t_left, t_right = peak_time(e, 0), peak_time(e, 1)
    assert abs(t_left - (r_tx + r_rx[0]) / v) <= dt
    assert abs(t_right - (r_tx + r_rx[1]) / v) <= dt
    assert abs((t_right - t_left) - (r_rx[1] - r_rx[0]) / v) <= dt
    # the leaf on the left is nearer the left ear
    assert (r_rx[1] - r_rx[0]) * az_deg > 0


def test_binaural_puts_the_left_ear_first_turned_outward():
    s = Sonar.binaural(0.02, 30.0, 10.0, beamwidth_deg=50.0)
    left, right = s.receivers
    assert left.offset_m == (0.0, 0.01, 0.0) and right.offset_m == (0.0, -0.01, 0.0)
    assert left.beam.center_deg == (30.0, 10.0) and right.beam.center_deg == (-30.0, 10.0)
    assert left.beam.beamwidth_deg == 50.0
    ear = Beam(sigma_deg=(20.0, 30.0))
    s2 = Sonar.binaural(0.02, 30.0, ear_beam=ear)
    assert s2.receivers[0].beam == dataclasses.replace(ear, center_deg=(30.0, 0.0))


def test_results_without_receivers_have_no_receiver_axis():
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    e = batecho.simulate(leaves, Sonar(), pose)
    assert e.spectrum.ndim == 2 and e.impulse.ndim == 2 and e.n_leaves.shape == (1,)
    assert e.n_receivers == 0


def test_lobe_members_per_receiver_match_the_reference():
    from batecho.echoes.canonical import canonical_leaf_box

    leaves = canonical_leaf_box(np.random.default_rng(3), density_per_m3=5.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    sonar = Sonar.binaural(0.5, 30.0)
    for j in range(2):
        got = batecho.lobe_members(leaves, sonar, pose, receiver=j)
        want = reference.lobe_members(leaves, sonar, pose, receiver=j)
        assert np.array_equal(got, want) and len(got) > 0
    with pytest.raises(ValueError, match="receiver="):
        batecho.lobe_members(leaves, sonar, pose)
    with pytest.raises(ValueError, match="receiver 2 out of range"):
        batecho.lobe_members(leaves, sonar, pose, receiver=2)


def test_n_samples_auto_holds_the_farthest_bistatic_echo():
    leaves = Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    sonar = Sonar(n_samples="auto", receivers=(Receiver((-4.0, 0.0, 0.0)),))
    e = batecho.simulate(leaves, sonar, pose)
    r = (3.0 + 7.0) / 2.0
    assert e.sonar.record_range_m >= r
    want = reference.simulate(leaves, sonar, pose)
    assert e.sonar.n_samples == want.sonar.n_samples
    assert rel_err(e.impulse, want.impulse) <= TOL


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        (dict(receivers=(Receiver(),), receiver=Beam(beamwidth_deg=20)), ValueError, "not both"),
        (dict(receivers=Receiver()), TypeError, "sequence"),
        (dict(receivers=()), ValueError, "1 to 64"),
        (dict(receivers=("ear",)), TypeError, r"receivers\[0\]"),
    ],
)
def test_bad_receivers_are_refused_by_name(kwargs, error, match):
    with pytest.raises(error, match=match):
        Sonar(**kwargs)


@pytest.mark.parametrize(
    ("offset", "error"),
    [((0.0, np.nan, 0.0), ValueError), ((1.0, 2.0), ValueError), ("x", TypeError)],
)
def test_a_receiver_with_a_bad_offset_is_refused(offset, error):
    with pytest.raises(error, match="offset_m"):
        Receiver(offset)


def test_a_leaf_too_close_to_a_receiver_names_the_receiver():
    leaves = Leaves([[0.2, 0.5, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    sonar = Sonar(receivers=(Receiver(), Receiver((0.2, 0.5, 0.005))), beamwidth_deg=120.0)
    with pytest.raises(ValueError, match="receiver 1 of pose 0"):
        batecho.simulate(leaves, sonar, pose)
    skip = batecho.simulate(leaves, sonar.replace(too_close="skip"), pose)
    assert skip.n_leaves[0, 1] == 0


def test_the_memory_guard_counts_every_receivers_records():
    # Poses whose one-ear output fits in the limit with a third to spare: four ears do not.
    leaves = Leaves([[2.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    one = Sonar(receivers=(Receiver(),))
    four = one.replace(receivers=(Receiver(),) * 4)
    e = batecho.simulate(leaves, one, Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
    per_record = 48 * len(e.freqs) + 16 * e.impulse.shape[-1]  # as budget::echoes_bytes
    limit = 2**26
    n_poses = int(limit / per_record / 1.5)
    poses = Poses(np.zeros((n_poses, 3)), [1.0, 0.0, 0.0])
    before = batecho.set_memory_limit(limit)
    try:
        assert batecho.simulate(leaves, one, poses).spectrum.shape[:2] == (n_poses, 1)
        with pytest.raises(MemoryError, match=f"{n_poses} poses for 4 receivers"):
            batecho.simulate(leaves, four, poses)
    finally:
        batecho.set_memory_limit(before)
