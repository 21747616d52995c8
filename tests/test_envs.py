"""batecho/EchoFlight-v0 (batecho.envs): the Gymnasium contract, reproducible episodes,
collisions and goals that end them, finite observations, and the baselines."""

from __future__ import annotations

import copy
import math
import pickle

import gymnasium as gym
import numpy as np
import pytest
from _helpers import SMALL_FOREST
from gymnasium.utils.env_checker import check_env

import batecho
from batecho.envs import ENV_ID, EchoFlightEnv
from batecho.envs.baselines import blind, echo_reactive
from batecho.envs.echo_flight import DEFAULT_BRANCHES, DEFAULT_SHADING

SMALL = SMALL_FOREST


def run(env: gym.Env, policy, seed: int, max_steps: int = 10_000):
    """Observations, rewards and the last info of one episode of ``policy``."""
    obs, info = env.reset(seed=seed)
    observations, rewards = [obs], []
    for _ in range(max_steps):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        observations.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            break
    return observations, rewards, info


def test_the_environment_passes_gymnasiums_env_checker():
    env = gym.make(ENV_ID, **SMALL, render_mode="rgb_array")
    check_env(env.unwrapped)


def test_importing_batecho_envs_registers_echoflight():
    assert ENV_ID in gym.registry
    assert isinstance(gym.make(ENV_ID, density=0.0).unwrapped, EchoFlightEnv)


def test_seeded_episodes_are_reproducible_step_by_step():
    env = EchoFlightEnv(**SMALL)
    rng = np.random.default_rng(3)
    actions = rng.uniform(-1, 1, (40, 4)).astype(np.float32)
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=11)
        trace = [obs]
        for a in actions:
            obs, reward, terminated, truncated, info = env.step(a)
            trace.append((obs, reward, terminated, truncated, info["clearance_m"]))
            if terminated or truncated:
                break
        runs.append(trace)
    assert len(runs[0]) == len(runs[1])
    for a, b in zip(runs[0][1:], runs[1][1:], strict=True):
        for key in a[0]:
            assert np.array_equal(a[0][key], b[0][key])
        assert a[1:] == b[1:]


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_a_copied_environment_steps_as_the_original(how):
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=5)
    action = np.array([1.0, 0.2, 0.0, 0.3], np.float32)
    env.step(action)
    twin = pickle.loads(pickle.dumps(env)) if how == "pickle" else copy.deepcopy(env)
    for _ in range(3):
        a, b = env.step(action), twin.step(action)
        for key in a[0]:
            assert np.array_equal(a[0][key], b[0][key])
        assert a[1:4] == b[1:4]


def test_a_numpy_integer_seed_gives_the_episode_of_the_int_it_equals():
    # (Gymnasium refused it: "Seed must be a python integer, actual type: numpy.int64")
    env = EchoFlightEnv(**SMALL)
    first, _ = env.reset(seed=7)
    again, _ = env.reset(seed=np.int64(7))
    for key in first:
        assert np.array_equal(first[key], again[key])


def test_different_seeds_draw_different_forests():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=1)
    first = env.forest.positions.copy()
    env.reset(seed=2)
    assert first.shape != env.forest.positions.shape or not np.array_equal(
        first, env.forest.positions
    )


def test_observations_are_finite_and_in_their_space():
    env = EchoFlightEnv(**SMALL)
    rng = np.random.default_rng(0)
    observations, _, _ = run(env, lambda obs: rng.uniform(-1, 1, 4).astype(np.float32), seed=5)
    for obs in observations:
        assert env.observation_space.contains(obs)
        for value in obs.values():
            assert np.all(np.isfinite(value))


def test_the_observation_has_no_tree_positions():
    env = EchoFlightEnv(**SMALL)
    obs, _ = env.reset(seed=0)
    assert set(obs) == {"echoes", "velocity", "attitude", "goal"}
    assert obs["echoes"].shape == (2, env.n_range_bins)


def toward(env: EchoFlightEnv, target: np.ndarray):
    """A policy flying level straight at ``target`` (world, m), read from the environment."""

    def policy(obs):
        p = env.sim.state.positions[0]
        R = env.sim.state.attitudes[0]
        d = (R.T @ (target - p))[:2]
        d = d / max(np.linalg.norm(d), 1e-9)
        return np.array([d[0], d[1], 0.0, 0.0], np.float32)

    return policy


def test_flying_into_a_tree_terminates_with_a_collision():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=4)
    assert env.forest.n_trees >= 1
    trunk = env.forest.trunk_bases[0] + (0.0, 0.0, env.altitude_m)
    policy = toward(env, trunk)
    obs, info = env.start, None
    for _ in range(2000):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
        if terminated or truncated:
            break
    assert terminated and info["collision"] and not info["is_success"]
    assert info["clearance_m"] < env.drone_radius_m
    assert reward < -env.collision_penalty / 2


def test_a_step_ending_inside_a_branch_terminates_with_a_collision():
    # (a long, fast step takes the drone from clear of the trunk to inside it, where its pulse
    # is sent from)
    env = EchoFlightEnv(**SMALL, pulse_rate_hz=5.0, max_speed_mps=3.0)
    env.reset(seed=0)
    assert env.forest.n_trees >= 1
    policy = toward(env, env.forest.trunk_bases[0] + (0.0, 0.0, env.altitude_m))
    for _ in range(2000):
        obs, _, terminated, truncated, info = env.step(policy(None))
        if terminated or truncated:
            break
    assert terminated and info["collision"]
    assert env.observation_space.contains(obs)


def test_diving_below_the_ground_in_a_forest_terminates_with_a_collision():
    # (a fast climb rate takes the drone from above drone_radius_m to below the ground in one
    # step)
    env = EchoFlightEnv(**SMALL, max_climb_mps=5.0)
    env.reset(seed=0)
    assert env.forest.n_trees >= 1
    for _ in range(100):
        _, _, terminated, truncated, info = env.step(np.array([0.0, 0.0, -1.0, 0.0]))
        if terminated or truncated:
            break
    assert terminated and info["collision"] and info["position"][2] < 0.0


def test_reaching_the_goal_ends_the_episode_with_success():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    _, rewards, info = run(env, blind(env), seed=2)
    assert info["is_success"] and not info["collision"]
    assert math.hypot(*(info["position"][:2] - env.goal[:2])) <= env.goal_radius_m
    assert sum(rewards) > env.success_reward


def test_an_episode_is_truncated_at_the_time_limit():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0, "max_time_s": 0.5})
    env.reset(seed=0)
    hover = np.zeros(4, np.float32)
    ends = [env.step(hover)[2:4] for _ in range(env.max_steps)]
    assert ends[-1] == (False, True) and all(e == (False, False) for e in ends[:-1])


def test_a_step_after_the_goal_is_reached_is_refused_until_reset():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    observations, _, info = run(env, blind(env), seed=2)
    assert info["is_success"]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(blind(env)(observations[-1]))


def test_a_step_after_the_time_limit_is_refused_until_reset():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0, "max_time_s": 0.1})
    env.reset(seed=0)
    hover = np.zeros(4, np.float32)
    assert [env.step(hover)[3] for _ in range(env.max_steps)][-1]
    with pytest.raises(RuntimeError, match="reset"):
        env.step(hover)
    env.reset(seed=0)
    assert env.step(hover)[2:4] == (False, False)


def test_the_echoes_grow_louder_as_a_tree_comes_near():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=4)
    trunk = env.forest.trunk_bases[0] + (0.0, 0.0, env.altitude_m)
    policy = toward(env, trunk)
    obs, loudest = None, []
    for _ in range(2000):
        obs, _, terminated, truncated, _info = env.step(policy(obs))
        loudest.append(float(obs["echoes"].max()))
        if terminated or truncated:
            break
    assert loudest[-1] > loudest[0] + 20.0


@pytest.mark.parametrize("make_policy", [blind, echo_reactive])
def test_each_baseline_flies_a_full_episode(make_policy):
    env = EchoFlightEnv(**SMALL)
    policy = make_policy(env)
    _, rewards, info = run(env, policy, seed=7)
    assert rewards and (
        info["is_success"] or info["collision"] or info["out_of_bounds"] or info["time_s"] > 0
    )
    assert env.action_space.contains(policy(env.reset(seed=7)[0]))


@pytest.mark.parametrize("make_policy", [blind, echo_reactive])
def test_a_baseline_for_a_vector_environment_is_refused_by_name(make_policy):
    envs = gym.make_vec(ENV_ID, num_envs=2, **{**SMALL, "density": 0.0})
    with pytest.raises(TypeError, match="one environment"):
        make_policy(envs)


@pytest.mark.parametrize("make_policy", [blind, echo_reactive])
def test_a_baseline_refuses_a_batch_of_observations_by_name(make_policy):
    envs = gym.make_vec(ENV_ID, num_envs=2, **{**SMALL, "density": 0.0})
    obs, _ = envs.reset(seed=0)
    policy = make_policy(EchoFlightEnv(**{**SMALL, "density": 0.0}))
    with pytest.raises(ValueError, match="one environment's observation"):
        policy(obs)


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"near_m": 1.0, "stop_m": 1.0}, "stop_m"),
        ({"near_m": 1.0, "stop_m": 2.0}, "stop_m"),
        ({"stop_m": -0.1}, "stop_m"),
        ({"near_m": float("nan")}, "near_m"),
        ({"near_m": 0.0, "stop_m": 0.0}, "near_m"),
        ({"threshold_db": float("inf")}, "threshold_db"),
        ({"turn_gain": float("nan")}, "turn_gain"),
        ({"min_speed": 1.5}, "min_speed"),
    ],
)
def test_echo_reactive_refuses_impossible_parameters_by_name(kwargs, name):
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    with pytest.raises(ValueError, match=name):
        echo_reactive(env, **kwargs)


def test_echo_reactive_refuses_a_threshold_whose_amplitudes_overflow_by_name():
    # (it was taken, and the policy returned NaN yaw rate and sidestep)
    with pytest.raises(ValueError, match="threshold_db"):
        echo_reactive(EchoFlightEnv(**SMALL), threshold_db=-1e300)


def test_render_gives_an_rgb_array():
    env = EchoFlightEnv(**SMALL, render_mode="rgb_array")
    env.reset(seed=0)
    env.step(np.array([1, 0, 0, 0], np.float32))
    img = env.render()
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert img.std() > 0


def test_the_render_frame_rate_is_the_pulse_rate():
    env = gym.make(ENV_ID, **{**SMALL, "pulse_rate_hz": 10.0}, render_mode="rgb_array")
    assert env.metadata["render_fps"] == 10.0
    assert EchoFlightEnv.metadata["render_fps"] == 20


def test_sync_vector_envs_step_together():
    envs = gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", **SMALL)
    obs, _ = envs.reset(seed=0)
    assert obs["echoes"].shape == (2, 2, 32)
    obs, reward, _terminated, _truncated, _info = envs.step(np.zeros((2, 4), np.float32))
    assert reward.shape == (2,)
    envs.close()


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"density": -1.0}, "density"),
        ({"length_m": float("nan")}, "length_m"),
        ({"n_range_bins": 0}, "n_range_bins"),
        ({"n_range_bins": 10**12}, "n_range_bins must be at most"),
        ({"pulse_rate_hz": 30.0}, "pulse interval"),
        ({"ceiling_m": 1.0}, "ceiling_m"),
        ({"render_mode": "human"}, "render_mode"),
        ({"ceiling_m": float("nan")}, "ceiling_m"),
        ({"ceiling_m": float("inf")}, "ceiling_m"),
        ({"floor_db": float("-inf")}, "floor_db"),
        ({"floor_db": -1e300}, "floor_db"),
        ({"effort_weight": float("nan")}, "effort_weight"),
        ({"collision_penalty": float("inf")}, "collision_penalty"),
        ({"success_reward": -1.0}, "success_reward"),
        ({"altitude_m": 0.1, "drone_radius_m": 0.15}, "altitude_m"),
        ({"width_m": 0.2, "drone_radius_m": 0.15}, "width_m"),
        ({"goal_radius_m": 30.0}, "goal_radius_m"),
        ({"variants": 2.5}, "variants"),
        ({"method": "bogus"}, "method"),
        ({"tol": -1.0}, "tol"),
    ],
)
def test_impossible_parameters_are_refused_by_name(kwargs, word):
    with pytest.raises(ValueError, match=word):
        EchoFlightEnv(**kwargs)


def test_a_time_step_longer_than_the_motor_time_constant_is_refused_before_any_step():
    # (QuadrotorSim refuses it; the environment took it and failed at the first step)
    with pytest.raises(ValueError, match="dt.*motor time constant"):
        EchoFlightEnv(**SMALL, dt=0.05)


@pytest.mark.parametrize("rate", [1e-300, 1e-310])
def test_a_pulse_interval_of_too_many_rk4_steps_is_refused_by_name_when_made(rate):
    # (it was taken, and its first step asked for ~1e303 RK4 steps or raised OverflowError)
    with pytest.raises(MemoryError, match="pulse_rate_hz"):
        EchoFlightEnv(**SMALL, pulse_rate_hz=rate)


def test_numpy_numbers_are_taken_as_the_python_numbers_they_equal():
    # (np.float32(1.5) was refused as "max_speed_mps must be a finite number > 0")
    env = EchoFlightEnv(**SMALL, max_speed_mps=np.float32(1.5), effort_weight=np.int64(0))
    assert env.scales[0] == 1.5 and env.effort_weight == 0.0


def test_a_time_limit_whose_step_count_overflows_float64_is_refused_by_name():
    # (it raised OverflowError "cannot convert float infinity to integer")
    with pytest.raises(ValueError, match="max_time_s"):
        EchoFlightEnv(**{**SMALL, "max_time_s": 1e308})


def test_a_ceiling_db_beyond_float32_is_refused_by_name():
    # (gymnasium's Box refused it as "Box high is out of bounds of the dtype range")
    with pytest.raises(ValueError, match="ceiling_db"):
        EchoFlightEnv(**{**SMALL, "ceiling_db": 1e300})


@pytest.mark.parametrize("name", ["ceiling_m", "floor_db", "ceiling_db"])
def test_a_level_or_ceiling_that_is_not_a_number_is_refused_by_name(name):
    # ("8" for ceiling_m was refused as "ceiling_m (8) must be above altitude_m (2.5)"; the
    # dB levels raised "'<' not supported" or "bad operand type for abs()")
    with pytest.raises(TypeError, match=f"{name} must be a real number"):
        EchoFlightEnv(**{**SMALL, name: "8"})


def test_a_quadrotor_that_is_not_one_is_refused_by_name():
    with pytest.raises(TypeError, match="quadrotor"):
        EchoFlightEnv(quadrotor="crazyflie")


def test_the_drone_hears_with_two_ears_and_the_trees_echo_with_their_wood_by_default():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=4)
    assert env.sonar.n_receivers == 2 and env.branches == DEFAULT_BRANCHES
    assert env.sonar.shading == DEFAULT_SHADING == env.shading
    left, right = env.sonar.receivers
    assert left.offset_m[1] > 0 > right.offset_m[1]  # the left ear first
    if DEFAULT_BRANCHES:
        assert env.echo_scene().n_branches > 0


def test_the_ears_hear_a_tree_on_the_left_louder_in_the_left_ear():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    env.reset(seed=0)
    p = env.drone_state()[0:3]
    leaves = batecho.Leaves(
        p + np.array([[2.0, 0.8 + 0.05 * k, 0.02 * k] for k in range(20)]),
        np.tile([-1.0, -0.4, 0.0], (20, 1)),
        np.full(20, 0.03),
    )
    echoes = batecho.simulate(leaves, env.sonar, batecho.Poses(p, [1.0, 0.0, 0.0]))
    left, right = np.abs(echoes.impulse[0]).max(axis=-1)
    assert left > 2.0 * right


@pytest.mark.parametrize(
    ("sonar", "word"),
    [
        (batecho.Sonar(fs=200e3, n_samples=6000), "two receivers"),
        (batecho.Sonar.binaural(0.05, 25.0, n_samples="auto", max_range_m=5.0), "fixed record"),
    ],
)
def test_a_sonar_without_two_ears_or_a_fixed_record_is_refused(sonar, word):
    with pytest.raises(ValueError, match=word):
        EchoFlightEnv(sonar=sonar)


def test_shading_must_be_a_shading():
    with pytest.raises(TypeError, match="shading"):
        EchoFlightEnv(shading=0.5)


def test_a_nan_action_is_refused():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.array([np.nan, 0, 0, 0]))


def test_an_action_outside_its_bounds_steps_as_the_action_clipped_to_them():
    kw = {**SMALL, "density": 0.0}
    outside, clipped = EchoFlightEnv(**kw), EchoFlightEnv(**kw)
    outside.reset(seed=0)
    clipped.reset(seed=0)
    a = outside.step(np.array([5.0, -3.0, 2.0, -1.5]))
    b = clipped.step(np.array([1.0, -1.0, 1.0, -1.0]))
    for key in a[0]:
        assert np.array_equal(a[0][key], b[0][key])
    assert a[1:4] == b[1:4]


def test_an_action_of_the_wrong_shape_is_refused_by_name():
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.zeros((1, 4)))


@pytest.mark.parametrize("action", ["up", [0, 0, 0, "x"], {"forward": 1.0}, [1j, 0, 0, 0]])
def test_an_action_that_is_not_numbers_is_refused_by_name_as_a_value_error(action):
    env = EchoFlightEnv(**{**SMALL, "density": 0.0})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be 4 finite numbers"):
        env.step(action)
