"""Receivers at their own places hear branches (docs/model.md §9, bistatic physical optics):
a receiver at the emitter with its pattern hears the monostatic branch echo, the Rust core
equals the reference for random receivers with the hard cases (broadside, end-on, a receiver
next to a branch), the fast method stays within tol, one and two threads give the same bits,
mirroring the scene swaps the ears (with shading too: tests/test_receivers_wood_shading.py)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from _helpers import rel_err
from _strategies import sonars
from hypothesis import given, note, settings
from hypothesis import strategies as st

import batecho
from batecho import Beam, Branches, Leaves, Poses, Receiver, Scene, Sonar, reference

LEAVES = Leaves([[3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.03])
TRUNK = Branches([[5.0, 0.0, -2.0]], [[5.0, 0.0, 2.0]], [0.1])
POSE = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def wood_scene(rng: np.random.Generator) -> Scene:
    """A trunk ahead, a slanting branch, a branch nearly end-on, and a few leaves."""
    starts = np.array([[4.0, 0.3, -2.0], [3.0, -0.5, 0.2], [2.5, 0.2, 0.1]])
    ends = np.array([[4.0, 0.3, 2.0], [3.6, 0.4, 1.0], [3.5, 0.28, 0.14]])
    c = np.column_stack([rng.uniform(2.0, 6.0, 30), rng.uniform(-1.5, 1.5, (30, 2))])
    leaves = Leaves(c, rng.normal(size=(30, 3)), rng.uniform(0.015, 0.04, 30))
    return Scene(leaves, branches=Branches(starts, ends, [0.12, 0.04, 0.03]))


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_a_receiver_at_the_emitter_hears_the_monostatic_branch_echo(method):
    scene = wood_scene(np.random.default_rng(3))
    sonar = Sonar(beamwidth_deg=50.0)
    mono = batecho.simulate(scene, sonar, POSE, method=method, tol=1e-9)
    heard = batecho.simulate(
        scene, sonar.replace(receivers=(Receiver(),)), POSE, method=method, tol=1e-9
    )
    assert heard.wood_spectrum.shape == (1, 1, mono.wood_spectrum.shape[1])
    assert np.array_equal(heard.n_pieces[:, 0], mono.n_pieces) and mono.n_pieces[0] > 10
    assert rel_err(heard.wood_spectrum[:, 0], mono.wood_spectrum) <= 1e-12
    assert rel_err(heard.spectrum[:, 0], mono.spectrum) <= 1e-12 * (1 if method == "exact" else 1e3)


@st.composite
def heard_wood_cases(draw):
    """A sonar with one to three receivers and branches with the hard cases mixed in: one at
    broadside, one end-on from the emitter, a receiver next to a branch."""
    sonar = draw(sonars())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    k = draw(st.integers(1, 6))
    reach = min(sonar.record_range_m, 6.0)
    start = np.column_stack(
        [rng.uniform(0.8, reach, k), rng.uniform(-1.5, 1.5, k), rng.uniform(-1.5, 1.5, k)]
    )
    d = rng.normal(size=(k, 3))
    d *= (rng.uniform(0.05, 1.5, k) / np.linalg.norm(d, axis=1))[:, None]
    kind = draw(st.sampled_from(["broadside", "end_on", "near_receiver", "none"]))
    if kind == "broadside":
        # across the line of sight from the emitter, through its middle
        across = np.cross(start[0], [0.0, 0.0, 1.0])
        d[0] = 0.8 * across / np.linalg.norm(across)
        start[0] -= 0.5 * d[0]
    elif kind == "end_on":
        d[0] = start[0] / np.linalg.norm(start[0]) * 0.3
    rxs = []
    for _ in range(draw(st.integers(1, 3))):
        scale = draw(st.sampled_from([0.01, 0.1, 0.5]))
        offset = tuple(draw(st.floats(-1.0, 1.0)) * scale for _ in range(3))
        beam = None
        if draw(st.booleans()):
            beam = Beam(
                sigma_deg=(draw(st.floats(10.0, 60.0)), draw(st.floats(10.0, 60.0))),
                center_deg=(draw(st.floats(-40.0, 40.0)), draw(st.floats(-20.0, 20.0))),
            )
        rxs.append(Receiver(offset, beam))
    if kind == "near_receiver":
        # a receiver 5 to 30 cm from the middle of the first branch's surface
        mid = start[0] + 0.5 * d[0]
        side = np.cross(d[0], [0.0, 0.0, 1.0]) + 1e-3
        side /= np.linalg.norm(side)
        gap = 0.1 + draw(st.floats(0.05, 0.3))
        rxs.append(Receiver(tuple(mid - gap * side * np.sign(side @ mid))))
    radii = rng.uniform(0.02, 0.1, k)
    sonar = sonar.replace(receiver=None, receivers=tuple(rxs), too_close="skip")
    return sonar, Scene(None, branches=Branches(start, start + d, radii))


@settings(max_examples=40, deadline=None)
@given(heard_wood_cases())
def test_receivers_hear_branches_as_the_reference_does(case):
    sonar, scene = case
    want = reference.simulate(scene, sonar, POSE)
    got = batecho.simulate(scene, sonar, POSE, method="exact")
    note(f"n_pieces rust={got.n_pieces.tolist()} ref={want.n_pieces.tolist()}")
    assert np.array_equal(got.n_pieces, want.n_pieces)
    # (a segment's pieces cancel at their shared edges: tolerance as tests/test_branches.py)
    assert rel_err(got.wood_spectrum, want.wood_spectrum) <= 1e-8


@settings(max_examples=25, deadline=None)
@given(heard_wood_cases(), st.sampled_from([1e-3, 1e-6, 1e-9]))
def test_the_fast_method_with_receivers_and_branches_stays_within_tol(case, tol):
    sonar, scene = case
    exact = batecho.simulate(scene, sonar, POSE, method="exact")
    for method in ("fast", "auto"):
        got = batecho.simulate(scene, sonar, POSE, method=method, tol=tol)
        assert np.array_equal(got.n_pieces, exact.n_pieces)
        for j in range(len(sonar.receivers)):
            assert rel_err(got.spectrum[:, j], exact.spectrum[:, j]) <= tol


def mirrored(scene: Scene) -> Scene:
    """The scene mirrored across the plane y = 0."""
    flip = np.array([1.0, -1.0, 1.0])
    lv, br = scene.leaves, scene.branches
    return Scene(
        Leaves(lv.centers * flip, lv.normals * flip, lv.radii),
        branches=Branches(br.starts * flip, br.ends * flip, br.radii),
    )


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_mirroring_a_scene_with_branches_swaps_the_ears(method):
    scene = wood_scene(np.random.default_rng(5))
    sonar = Sonar.binaural(0.2, 25.0, beamwidth_deg=45.0)
    a = batecho.simulate(scene, sonar, POSE, method=method, tol=1e-9)
    b = batecho.simulate(mirrored(scene), sonar, POSE, method=method, tol=1e-9)
    assert np.array_equal(a.n_pieces[:, ::-1], b.n_pieces)
    assert rel_err(b.wood_spectrum[:, ::-1], a.wood_spectrum) <= 1e-9
    assert rel_err(a.wood_spectrum[:, 0], a.wood_spectrum[:, 1]) > 0.1  # the ears differ


SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import batecho
    sys.path.insert(0, sys.argv[2])
    from test_receivers_with_wood import wood_scene, POSE

    scene = wood_scene(np.random.default_rng(11))
    sonar = batecho.Sonar.binaural(0.05, 20.0, beamwidth_deg=45.0)
    out = {}
    for method, tol in (("exact", 1e-12), ("fast", 1e-6)):
        e = batecho.simulate(scene, sonar, POSE, method=method, tol=tol)
        out[method + "-spec"] = e.spectrum
        out[method + "-wood"] = e.wood_spectrum
    np.savez(sys.argv[1], **out)
    """
)


def run(threads: int, path) -> dict:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    here = os.path.dirname(__file__)
    subprocess.run([sys.executable, "-c", SCRIPT, str(path), here], env=env, check=True)
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def test_receivers_with_branches_are_bit_identical_with_one_and_two_threads(tmp_path):
    one = run(1, tmp_path / "one.npz")
    two = run(2, tmp_path / "two.npz")
    assert one.keys() == two.keys()
    for k in one:
        assert one[k].tobytes() == two[k].tobytes(), k


def test_a_branch_between_emitter_and_receiver_is_silent_and_one_beside_them_is_heard():
    # a receiver 4 m ahead facing back at the emitter; a vertical trunk halfway between them
    # scatters forward, which physical optics of the lit side does not describe: silent
    back = Beam(beamwidth_deg=60.0, center_deg=(180.0, 0.0))
    sonar = Sonar(beamwidth_deg=60.0, receivers=(Receiver((4.0, 0.0, 0.0), back),))
    sonar = sonar.replace(too_close="skip")

    def trunk(y: float) -> Scene:
        return Scene(None, branches=Branches([[2.0, y, -0.5]], [[2.0, y, 0.5]], [0.05]))

    between = batecho.simulate(trunk(0.0), sonar, POSE)
    beside = batecho.simulate(trunk(0.6), sonar, POSE)
    assert between.n_pieces.tolist() == [[0]] and beside.n_pieces[0, 0] > 0


def test_a_receiver_inside_a_branch_is_refused_naming_the_receiver():
    sonar = Sonar(receivers=(Receiver(), Receiver((0.0, 0.5, 0.0))))
    trunk = Branches([[0.0, 0.5, -1.0]], [[0.0, 0.5, 1.0]], [0.1])
    with pytest.raises(ValueError, match="branch 0 is .* from receiver 1 of pose 0"):
        batecho.simulate(Scene(None, branches=trunk), sonar, POSE, min_clearance_m=0.0)


def test_two_ears_hear_a_trunk_at_the_delay_of_their_paths():
    ears = Sonar.binaural(0.3, ear_yaw_deg=20, beamwidth_deg=40, window="rect")
    echo = batecho.simulate(Scene(LEAVES, branches=TRUNK), ears, POSE)
    assert echo.n_pieces.shape == (1, 2) and echo.n_pieces.min() > 0
    env = np.abs(echo.wood_impulse()[0])
    for j, rx in enumerate(ears.receivers):
        # the near surface 4.9 m ahead; the ear 0.15 m to the side
        r_rx = math.hypot(4.9, rx.offset_m[1])
        want = (4.9 + r_rx) / ears.sound_speed
        assert abs(echo.times[int(np.argmax(env[j]))] - want) <= 2.0 / ears.fs


def test_echoes_built_without_n_pieces_have_a_receiver_axis_on_it():
    leaves = Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    echoes = batecho.simulate(
        leaves, Sonar.binaural(0.02, 10.0), batecho.look_at([0, 0, 0], [1, 0, 0])
    )
    built = batecho.Echoes(
        spectrum=echoes.spectrum,
        freqs=echoes.freqs,
        impulse=echoes.impulse,
        times=echoes.times,
        n_leaves=echoes.n_leaves,
        sonar=echoes.sonar,
        poses=echoes.poses,
    )
    assert built.n_pieces.shape == echoes.n_leaves.shape
