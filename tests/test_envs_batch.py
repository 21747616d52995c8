"""The native batch of EchoFlight and the pieces it stands on: a path's smallest clearance
(Scene.min_clearance) is the least of its points' clearances; the envelope from the band
spectrum is the Hilbert envelope at its samples; the range bins are the peak of each bin;
many scenes' pulses in one call are each scene's own; and the batched environments give
each single environment's results step by step."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_clearance import scenes_and_points
from test_envs import SMALL

import batecho
from batecho import _core
from batecho.echoes.envelope import band_envelope, envelope_stride
from batecho.envs import ENV_ID, EchoFlightEnv, EchoFlightVectorEnv
from batecho.envs.pulses import EchoBins


@given(scenes_and_points(), st.sampled_from([0.0, 0.01, 0.3, 5.0, np.inf]))
def test_a_sets_smallest_clearance_is_the_least_of_its_points_or_the_bound(case, upper):
    leaves, pts = case
    scene = batecho.Scene(leaves)
    want = min(upper, float(scene.clearance(pts).min()))
    assert scene.min_clearance(pts, upper) == want


def test_a_sets_smallest_clearance_counts_branches():
    wood = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 2.0]], [0.1])
    leaves = batecho.Leaves([[5.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]], [0.05])
    scene = batecho.Scene(leaves, branches=wood)
    pts = np.array([[1.0, 0.0, 1.0], [0.5, 0.0, 1.0]])
    assert scene.min_clearance(pts) == pytest.approx(0.4, abs=1e-12)
    assert scene.min_clearance(pts, 0.2) == 0.2
    assert scene.min_clearance(np.zeros((0, 3)), 0.7) == 0.7


@pytest.mark.parametrize(("upper", "word"), [(-1.0, "upper_m"), (np.nan, "upper_m")])
def test_a_bad_bound_on_the_smallest_clearance_is_refused_by_name(upper, word):
    scene = batecho.Scene(batecho.Leaves([[1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.05]))
    with pytest.raises(ValueError, match=word):
        scene.min_clearance([[0.0, 0.0, 0.0]], upper)


@pytest.mark.parametrize("upper", [None, "far", [1.0, 2.0]])
def test_a_bound_on_the_smallest_clearance_that_is_not_a_number_is_refused_by_name(upper):
    scene = batecho.Scene(batecho.Leaves([[1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.05]))
    with pytest.raises(TypeError, match="upper_m"):
        scene.min_clearance([[0.0, 0.0, 0.0]], upper)


def echoes_of(seed: int, n_samples: int, ears: bool) -> batecho.Echoes:
    rng = np.random.default_rng(seed)
    n = 300
    c = rng.uniform([1.0, -1.0, -1.0], [4.0, 1.0, 1.0], (n, 3))
    nv = rng.normal(size=(n, 3))
    leaves = batecho.Leaves(c, nv, rng.uniform(0.005, 0.05, n))
    kw = {"fs": 200e3, "n_samples": n_samples}
    sonar = batecho.Sonar.binaural(0.05, 25.0, **kw) if ears else batecho.Sonar(**kw)
    poses = batecho.Poses(np.zeros((2, 3)), [[1.0, 0.0, 0.0], [1.0, 0.2, 0.1]])
    return batecho.simulate(batecho.Scene(leaves), sonar, poses)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.sampled_from([1, 2, 3, 4, 5, 8]), st.booleans())
def test_the_band_envelope_is_the_hilbert_envelope_at_its_samples(seed, stride, ears):
    e = echoes_of(seed, 6000, ears)
    k0 = round(float(e.freqs[0]) * 6000 / e.sonar.fs)
    got = band_envelope(e.spectrum, k0, 6000, stride)
    want = e.envelope()[..., ::stride]
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * want.max())


def test_a_band_envelope_with_more_bins_than_samples_folds_them():
    e = echoes_of(1, 6000, False)
    k0 = round(float(e.freqs[0]) * 6000 / e.sonar.fs)
    got = band_envelope(e.spectrum, k0, 6000, 20)  # 300 samples, 600 band bins
    want = e.envelope()[..., ::20]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * want.max())


def test_the_envelope_stride_divides_the_record_and_oversamples():
    assert envelope_stride(6000, 200e3, (60e3, 80e3), 4.0) == 2
    assert envelope_stride(7, 200e3, (60e3, 80e3), 1.0) == 7
    assert envelope_stride(6000, 200e3, (60e3, 80e3), 100.0) == 1


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 40), st.floats(0.5, 12.0))
def test_each_range_bin_holds_the_peak_of_its_samples_in_db(seed, n_bins, reach):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    ranges = np.sort(rng.uniform(0.0, 10.0, n))
    envelope = rng.exponential(1e-3, (2, n)) * (rng.uniform(size=(2, n)) < 0.7)
    got = EchoBins(ranges, reach, n_bins, -100.0, 20.0).levels(envelope)
    edges = np.searchsorted(ranges, np.linspace(0.0, reach, n_bins + 1))
    want = np.full((2, n_bins), -100.0)
    for b in range(n_bins):
        if edges[b + 1] > edges[b]:
            peak = envelope[:, edges[b] : edges[b + 1]].max(axis=1)
            want[:, b] = 20.0 * np.log10(np.maximum(peak, 1e-5))
    np.testing.assert_array_equal(got, np.clip(want, -100.0, 20.0))


def test_many_scenes_pulses_in_one_call_are_each_scenes_own():
    rng = np.random.default_rng(4)
    sonar = batecho.Sonar.binaural(0.05, 25.0, fs=200e3, n_samples=6000)
    scenes, poses = [], []
    for k in range(3):
        c = rng.uniform([1.0, -1.0, -1.0], [4.0, 1.0, 1.0], (200 + 50 * k, 3))
        leaves = batecho.Leaves(c, rng.normal(size=c.shape), np.full(len(c), 0.02))
        scenes.append(batecho.Scene(leaves))
        poses.append(batecho.Poses(rng.normal(0, 0.1, (k + 1, 3)), [1.0, 0.1 * k, 0.0]))
    out = _core.simulate_many(
        [s._core for s in scenes],
        sonar._core,
        [p.positions for p in poses],
        [p.forward for p in poses],
        [p.up for p in poses],
        [p.left for p in poses],
        "bvh",
        "auto",
        1e-6,
    )
    for scene, pose, (spectrum, counts) in zip(scenes, poses, out, strict=True):
        alone = batecho.simulate(scene, sonar, pose, tol=1e-6, min_clearance_m=0)
        assert spectrum.tobytes() == alone.spectrum.tobytes()
        np.testing.assert_array_equal(counts, alone.n_leaves)


def test_a_failing_scene_of_many_is_named():
    sonar = batecho.Sonar(fs=200e3, n_samples=6000)
    far = batecho.Scene(batecho.Leaves([[3.0, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.02]))
    near = batecho.Scene(batecho.Leaves([[1e-3, 0.0, 0.0]], [[-1.0, 0.0, 0.0]], [0.02]))
    pose = batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    arrays = [pose.positions, pose.forward, pose.up, pose.left]
    with pytest.raises(ValueError, match="scene 1"):
        _core.simulate_many(
            [far._core, near._core], sonar._core, *[[a, a] for a in arrays], "bvh", "exact", 1e-6
        )


def test_make_vec_gives_the_native_batch():
    envs = gym.make_vec(ENV_ID, num_envs=2, **SMALL)
    assert isinstance(envs, EchoFlightVectorEnv)
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **SMALL)
    assert isinstance(envs, EchoFlightVectorEnv)
    obs, _ = envs.reset(seed=0)
    assert envs.observation_space.contains(obs)


def test_the_batch_gives_each_single_environments_results_step_by_step():
    n, steps = 3, 60
    kw = {**SMALL, "max_time_s": 1.2}  # truncated after 24 steps: autoresets come in
    batch = EchoFlightVectorEnv(n, **kw)
    singles = [EchoFlightEnv(**kw) for _ in range(n)]
    rng = np.random.default_rng(8)
    actions = rng.uniform(-1.0, 1.0, (steps, n, 4)).astype(np.float32)
    actions[:, :, 0] = np.abs(actions[:, :, 0])  # mostly forward: into the trees
    obs, _ = batch.reset(seed=[5, 6, 7])
    alone = [env.reset(seed=5 + i)[0] for i, env in enumerate(singles)]
    ended = np.zeros(n, dtype=bool)
    ends, loudest = 0, -np.inf
    for t in range(steps):
        loudest = max(loudest, float(obs["echoes"].max()))
        for key in obs:
            assert obs[key].tobytes() == np.stack([o[key] for o in alone]).tobytes()
        obs, rewards, terminated, truncated, info = batch.step(actions[t])
        for i, env in enumerate(singles):
            if ended[i]:
                alone[i], _ = env.reset()
                assert rewards[i] == 0.0 and not (terminated[i] or truncated[i])
                continue
            alone[i], r, te, tr, inf = env.step(actions[t, i])
            assert (rewards[i], terminated[i], truncated[i]) == (r, te, tr)
            assert info["clearance_m"][i] == inf["clearance_m"]
        ended = terminated | truncated
        ends += int(ended.sum())
    assert ends >= n  # autoresets were among the steps compared
    assert loudest > batch.envs[0].floor_db + 40.0  # and echoes were heard


def test_async_environments_hear_what_sync_environments_hear():
    # Forked workers make their own pulse thread and worker threads: the parent's, running
    # since the step below, are not copied into them.
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=0)
    env.step(np.zeros(4, np.float32))
    kw = {**SMALL, "max_time_s": 0.5}
    actions = np.tile(np.array([[1.0, 0.2, 0.0, 0.1]], np.float32), (2, 1))
    sync = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", **kw)
    want, _ = sync.reset(seed=3)
    forked = gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="async", vector_kwargs={"context": "fork"}, **kw
    )
    # (waits that time out, so that a hung worker fails the test instead of hanging it)
    forked.reset_async(seed=3)
    got, _ = forked.reset_wait(timeout=120)
    for _ in range(3):
        assert got["echoes"].tobytes() == want["echoes"].tobytes()
        want = sync.step(actions)[0]
        forked.step_async(actions)
        got = forked.step_wait(timeout=120)[0]
    assert got["echoes"].tobytes() == want["echoes"].tobytes()
    sync.close()
    forked.close()


def test_the_batch_refuses_actions_of_the_wrong_shape():
    batch = EchoFlightVectorEnv(2, **{**SMALL, "density": 0.0})
    batch.reset(seed=0)
    with pytest.raises(ValueError, match="actions"):
        batch.step(np.zeros((3, 4)))


def test_a_copied_native_batch_steps_as_the_original():
    envs = EchoFlightVectorEnv(2, **SMALL)
    envs.reset(seed=[3, 4])
    actions = np.array([[1.0, 0.1, 0.0, 0.2], [0.8, -0.3, 0.1, 0.0]], np.float32)
    envs.step(actions)
    twin = copy.deepcopy(envs)
    for _ in range(3):
        a, b = envs.step(actions), twin.step(actions)
        for key in a[0]:
            assert np.array_equal(a[0][key], b[0][key])
        for x, y in zip(a[1:4], b[1:4], strict=True):
            assert np.array_equal(x, y)


def test_make_vec_with_max_episode_steps_truncates_the_native_batch_as_sync_does():
    kw = {**SMALL, "density": 0.0}
    native = gym.make_vec(ENV_ID, num_envs=2, max_episode_steps=3, **kw)
    sync = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", max_episode_steps=3, **kw)
    native.reset(seed=0)
    sync.reset(seed=0)
    hover = np.zeros((2, 4), np.float32)
    for _ in range(5):
        got, want = native.step(hover), sync.step(hover)
        assert np.array_equal(got[2], want[2]) and np.array_equal(got[3], want[3])
        assert np.array_equal(got[1], want[1])


def test_the_batch_refuses_a_max_episode_steps_below_one_by_name():
    with pytest.raises(ValueError, match="max_episode_steps"):
        EchoFlightVectorEnv(2, max_episode_steps=0, **{**SMALL, "density": 0.0})


def test_a_batchs_observations_are_not_overwritten_by_its_next_step():
    batch = EchoFlightVectorEnv(2, **{**SMALL, "density": 0.0})
    first, _ = batch.reset(seed=0)
    kept = {key: value.copy() for key, value in first.items()}
    batch.step(np.tile(np.array([[1.0, 0.0, 0.0, 0.5]], np.float32), (2, 1)))
    for key in kept:
        assert np.array_equal(first[key], kept[key])


def test_a_refused_batch_step_leaves_an_ended_environment_to_be_reset_once():
    kw = {**SMALL, "density": 0.0}
    hover = np.zeros((2, 4), np.float32)
    runs = []
    for refuse in (False, True):
        batch = EchoFlightVectorEnv(2, **kw)
        batch.reset(seed=0)
        batch.envs[0].max_steps = 1  # environment 0 ends on the first step, 1 flies on
        batch.step(hover)
        if refuse:
            with pytest.raises(ValueError, match="action"):
                batch.step(np.array([[0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 0.0]]))
        runs.append(batch.step(hover)[0])
    for key in runs[0]:
        assert np.array_equal(runs[0][key], runs[1][key])


@pytest.mark.parametrize("actions", ["up", [[0, 0, 0, "x"]] * 2, {"forward": 1.0}])
def test_the_batch_refuses_actions_that_are_not_numbers_by_name(actions):
    batch = EchoFlightVectorEnv(2, **{**SMALL, "density": 0.0})
    batch.reset(seed=0)
    with pytest.raises(ValueError, match="actions must be"):
        batch.step(actions)


@pytest.mark.parametrize("num_envs", [float("nan"), float("inf"), "x", None])
def test_a_batch_size_that_is_not_a_finite_number_is_refused_by_name(num_envs):
    # (it raised int()'s "cannot convert float NaN to integer", "invalid literal" and the like)
    with pytest.raises(ValueError, match="num_envs"):
        EchoFlightVectorEnv(num_envs=num_envs, **SMALL)
