"""batecho/EchoFlight-v0 against Gymnasium's contract, beyond tests/test_envs.py and
tests/test_envs_batch.py: what ends an episode on its last step, seeds that give the same
episode whatever came before, observations inside their space under extreme actions, the
documented info keys, Gymnasium's own vector environments against the native batch, and the
render modes the metadata declares."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from _helpers import SMALL_FOREST

from batecho.envs import ENV_ID, EchoFlightEnv
from batecho.envs.baselines import blind

ROOT = Path(__file__).resolve().parents[1]

SMALL = SMALL_FOREST
EMPTY = {**SMALL, "density": 0.0}

#: The 16 corners of the action box.
CORNERS = np.array(list(itertools.product([-1.0, 1.0], repeat=4)), np.float32)


def same(a, b) -> bool:
    """Bit-identical nested dicts, tuples and arrays (their dtypes too)."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def steps_to_end(env: EchoFlightEnv, policy, seed: int) -> tuple[int, dict]:
    """The number of steps an episode of ``policy`` lasts, and its last info."""
    obs, _ = env.reset(seed=seed)
    for k in range(1, 10_000):
        obs, _, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated:
            return k, info
    raise AssertionError("the episode did not end")


# ------------------------------------------------------------------ terminated, truncated


def descend(_obs):
    return np.array([0.0, 0.0, -1.0, 0.0], np.float32)


@pytest.mark.parametrize(
    ("make_policy", "ending"),
    [(lambda env: descend, "collision"), (blind, "is_success")],
    ids=["a collision with the ground", "the goal reached"],
)
def test_an_episode_ending_on_its_last_step_terminates_and_is_not_truncated(make_policy, ending):
    # how many steps the ending takes with time to spare, then a time limit of exactly that
    roomy = EchoFlightEnv(**{**EMPTY, "max_time_s": 60.0})
    k, info = steps_to_end(roomy, make_policy(roomy), seed=2)
    assert info[ending]
    tight = EchoFlightEnv(**{**EMPTY, "max_time_s": k / roomy.pulse_rate_hz})
    assert tight.max_steps == k
    obs, _ = tight.reset(seed=2)
    policy = make_policy(tight)
    for _ in range(k):
        obs, _, terminated, truncated, info = tight.step(policy(obs))
    assert (terminated, truncated, info[ending]) == (True, False, True)


def test_a_drone_wider_than_the_clearance_horizon_does_not_collide_in_open_air():
    # (clearance_m was clipped to 2 m, below a 2.5 m radius: every step was a collision)
    env = EchoFlightEnv(**{**EMPTY, "drone_radius_m": 2.5, "altitude_m": 5.0, "width_m": 20.0})
    env.reset(seed=0)
    _, _, terminated, _, info = env.step(np.zeros(4, np.float32))
    assert not terminated and not info["collision"]
    assert info["clearance_m"] >= env.drone_radius_m


# ---------------------------------------------------------------------------------- seeds


def test_a_seed_gives_the_same_episode_in_a_fresh_environment_and_after_other_episodes():
    actions = np.random.default_rng(4).uniform(-1, 1, (40, 4)).astype(np.float32)
    used = EchoFlightEnv(**SMALL)
    used.reset(seed=3)
    for a in actions[:10]:
        used.step(a)
    used.reset()  # (an unseeded episode in between)
    runs = []
    for env in (EchoFlightEnv(**SMALL), used):
        trace = [env.reset(seed=9)]
        for a in actions:
            trace.append(env.step(a))
            if trace[-1][2] or trace[-1][3]:
                break
        runs.append(trace)
    assert len(runs[0]) == len(runs[1]) > 1
    assert all(same(a, b) for a, b in zip(*runs, strict=True))


# --------------------------------------------------------------------------- observations


def extreme_action(k: int, rng: np.random.Generator) -> np.ndarray:
    """In turn: a corner of the box, values far beyond it (clipped), the largest float32
    values inside it, and zero."""
    kind = k % 4
    if kind == 0:
        return CORNERS[rng.integers(16)]
    if kind == 1:
        return rng.choice([-1e30, 1e30, -1.0, 1.0], 4).astype(np.float32)
    if kind == 2:
        return np.nextafter(rng.choice([-1.0, 1.0], 4).astype(np.float32), np.float32(0.0))
    return np.zeros(4, np.float32)


@pytest.mark.parametrize("seed", range(3))
def test_observations_stay_in_their_space_under_extreme_and_boundary_actions(seed):
    env = EchoFlightEnv(**SMALL)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    assert env.observation_space.contains(obs)
    for k in range(env.max_steps):
        obs, reward, terminated, truncated, _ = env.step(extreme_action(k, rng))
        assert env.observation_space.contains(obs), (k, obs)
        assert np.isfinite(reward)
        if terminated or truncated:
            break


# ----------------------------------------------------------------------------------- info


def documented_info_keys() -> set[str]:
    """The keys of the envs guide's `info` table."""
    text = (ROOT / "docs" / "guide" / "envs.md").read_text(encoding="utf-8")
    table = text[text.index("| `info` key |") :].split("\n\n")[0]
    return set(re.findall(r"^\| `(\w+)` \|", table, re.M))


def test_info_holds_exactly_the_keys_the_guide_documents_after_reset_and_step():
    env = EchoFlightEnv(**SMALL)
    _, info = env.reset(seed=0)
    assert set(info) == documented_info_keys()
    assert set(env.step(np.zeros(4, np.float32))[4]) == documented_info_keys()


# ------------------------------------------------------------------------------- vectors


def rollout(envs, actions: np.ndarray, seed: int) -> list:
    """What reset(seed) and each step of ``actions`` return (an async environment's waits
    time out, so that a hung worker fails the test instead of hanging it)."""
    if not isinstance(envs, gym.vector.AsyncVectorEnv):
        return [envs.reset(seed=seed)] + [envs.step(a) for a in actions]
    envs.reset_async(seed=seed)
    trace = [envs.reset_wait(timeout=120)]
    for a in actions:
        envs.step_async(a)
        trace.append(envs.step_wait(timeout=120))
    return trace


def test_sync_and_async_vector_envs_give_the_native_batchs_results_bit_for_bit():
    n, steps = 3, 50
    kw = {**SMALL, "max_time_s": 1.5}  # truncated after 30 steps: autoresets come in
    actions = np.random.default_rng(8).uniform(-1, 1, (steps, n, 4)).astype(np.float32)
    actions[..., 0] = np.abs(actions[..., 0])  # forward, and down: collisions come in too
    actions[..., 2] -= 0.6
    modes = {
        "native": {},
        "sync": {"vectorization_mode": "sync"},
        "async": {"vectorization_mode": "async", "vector_kwargs": {"context": "fork"}},
    }
    traces = {}
    for name, mode in modes.items():
        envs = gym.make_vec(ENV_ID, num_envs=n, **mode, **kw)
        traces[name] = rollout(envs, actions, seed=5)
        envs.close()
    ends = sum(int((t[2] | t[3]).sum()) for t in traces["native"][1:])
    assert ends >= n
    for name in ("sync", "async"):
        for t, (want, got) in enumerate(zip(traces["native"], traces[name], strict=True)):
            assert same(want, got), (name, t)


# -------------------------------------------------------------------------------- render


def test_without_a_render_mode_nothing_is_drawn_and_an_undeclared_mode_is_refused():
    env = gym.make(ENV_ID, **EMPTY)
    env.reset(seed=0)
    assert env.render() is None
    assert "ansi" not in EchoFlightEnv.metadata["render_modes"]
    with pytest.raises(ValueError, match="render_mode"):
        EchoFlightEnv(**EMPTY, render_mode="ansi")


def test_the_native_batch_declares_the_render_frame_rate_as_sync_does():
    # (Gymnasium's vector HumanRendering needs it; its RecordVideo falls back to 30 fps)
    kw = {**EMPTY, "pulse_rate_hz": 10.0, "render_mode": "rgb_array"}
    native = gym.make_vec(ENV_ID, num_envs=2, **kw)
    sync = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", **kw)
    assert native.metadata == sync.metadata
    assert native.metadata["render_fps"] == 10.0
