"""Objects that hold Rust state pickle (for processes, Dask workers and ``copy.deepcopy``): a
loaded copy gives the original's results bit for bit."""

from __future__ import annotations

import copy
import dataclasses
import multiprocessing
import pickle
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

import batecho
from batecho import trajectories
from batecho.flight.sim import QuadrotorSim


def _roundtrip(obj):
    return pickle.loads(pickle.dumps(obj))


def _wooded_scene() -> batecho.Scene:
    rng = np.random.default_rng(11)
    n = 400
    centers = np.column_stack(
        [rng.uniform(1.5, 6, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-1.5, 1.5, n)]
    )
    leaves = batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.uniform(0.01, 0.03, n))
    trunk = batecho.Branches([[4.0, 0.3, -2.0]], [[4.0, 0.3, 2.0]], [0.12])
    return batecho.Scene(leaves, branches=trunk)


POSES = batecho.Poses([[0.0, 0.0, 0.0], [0.2, 0.1, 0.0]], [[1.0, 0.0, 0.0], [1.0, 0.1, 0.05]])

SONARS = {
    "default": batecho.Sonar(),
    "beamwidth": batecho.Sonar(beamwidth_deg=40.0, too_close="skip"),
    "beam": batecho.Sonar(beam=batecho.Beam(sigma_deg=(12.0, 8.0), rotation_deg=10.0)),
    "ears, shading": batecho.Sonar.binaural(
        0.02, 25.0, shading=batecho.Shading(leaf_transmission=0.5)
    ),
    "auto record": batecho.Sonar(n_samples="auto", absorption=batecho.Atmosphere()),
}


@pytest.mark.parametrize("name", list(SONARS))
def test_a_loaded_sonar_equals_the_original(name):
    sonar = SONARS[name]
    assert _roundtrip(sonar) == sonar
    assert copy.deepcopy(sonar) == sonar


def test_a_loaded_sonar_is_changed_by_replace_as_the_original_is():
    sonar = batecho.Sonar(beamwidth_deg=40.0)
    loaded = _roundtrip(sonar)
    assert loaded.replace(beamwidth_deg=20.0) == sonar.replace(beamwidth_deg=20.0)
    assert loaded.replace(gain=0.3).beam == sonar.beam


@pytest.mark.parametrize("name", list(SONARS))
def test_a_loaded_scene_and_sonar_give_the_originals_echoes_bit_for_bit(name):
    scene, sonar = _wooded_scene(), SONARS[name]
    want = batecho.simulate(scene, sonar, POSES, tol=1e-6, min_clearance_m=0)
    got = batecho.simulate(_roundtrip(scene), _roundtrip(sonar), POSES, tol=1e-6, min_clearance_m=0)
    assert np.array_equal(got.spectrum, want.spectrum)
    assert np.array_equal(got.impulse, want.impulse)
    assert got.wood_spectrum is not None and want.wood_spectrum is not None
    assert np.array_equal(got.wood_spectrum, want.wood_spectrum)
    assert np.array_equal(np.asarray(got.n_shaded), np.asarray(want.n_shaded))


def test_a_loaded_scene_keeps_its_leaves_and_branches():
    scene = _wooded_scene()
    loaded = _roundtrip(scene)
    assert loaded.leaves is not None and scene.leaves is not None
    assert np.array_equal(loaded.leaves.centers, scene.leaves.centers)
    assert loaded.branches is not None and scene.branches is not None
    assert np.array_equal(loaded.branches.radii, scene.branches.radii)
    wood_alone = _roundtrip(batecho.Scene(None, branches=scene.branches))
    assert wood_alone.leaves is None and wood_alone.n_branches == 1


def test_a_loaded_forest_drawn_with_a_uniform_intensity_keeps_its_trees():
    forest = batecho.Forest.from_ipp(
        batecho.UniformIntensity(0.05), (0.0, 20.0, 0.0, 20.0), 3, variants=1
    )
    loaded = _roundtrip(forest)
    assert np.array_equal(loaded.positions, forest.positions)
    assert loaded.n_leaves == forest.n_leaves


def test_loaded_echoes_keep_their_arrays_and_sonar():
    echoes = batecho.simulate(_wooded_scene(), SONARS["ears, shading"], POSES, min_clearance_m=0)
    loaded = _roundtrip(echoes)
    assert np.array_equal(loaded.impulse, echoes.impulse)
    assert loaded.sonar == echoes.sonar


def test_a_loaded_quadrotor_flies_the_originals_flight():
    drone = batecho.Quadrotor.crazyflie()
    path = trajectories.Circle((0.0, 0.0), 2.0, altitude=3.0, speed=2.0)
    want = drone.fly(path, duration=1.0)
    got = _roundtrip(drone).fly(path, duration=1.0)
    assert np.array_equal(got.positions, want.positions)


def test_a_loaded_step_by_step_flight_goes_on_where_the_original_stopped():
    drone = batecho.Quadrotor.crazyflie()
    sim = QuadrotorSim(drone, drone.initial_state(trajectories.Hover([0, 0, 1.0])), n_drones=3)
    sim.step([1.0, 0.0, 0.2], 0.3, n_steps=40)
    loaded = _roundtrip(sim)
    assert loaded.time == sim.time
    assert np.array_equal(loaded.path, sim.path)
    a = sim.step([0.5, 0.5, 0.0], -0.2, n_steps=40)
    b = loaded.step([0.5, 0.5, 0.0], -0.2, n_steps=40)
    assert np.array_equal(a.vectors, b.vectors)


def _read_only_arrays(obj) -> list[str]:
    """The names of ``obj``'s attributes that are read-only arrays, or tuples holding one."""
    state = obj.__getstate__()
    names = []
    for part in state if isinstance(state, tuple) else (state,):
        for name, value in (part or {}).items():
            arrays = value if isinstance(value, tuple) else (value,)
            if any(isinstance(a, np.ndarray) and not a.flags.writeable for a in arrays):
                names.append(name)
    return sorted(names)


def _read_only_objects() -> dict[str, object]:
    forest = batecho.Forest.from_ipp(
        batecho.UniformIntensity(0.05), (0.0, 20.0, 0.0, 20.0), 3, variants=1
    )
    forest.bark()
    tree = forest.variants[0]
    drone = batecho.Quadrotor.crazyflie()
    path = trajectories.Circle((0.0, 0.0), 2.0, altitude=3.0, speed=2.0)
    reference = batecho.load_reference()
    return {
        "Leaves": _wooded_scene().leaves,
        "Branches": _wooded_scene().branches,
        "Poses": POSES,
        "Call": batecho.Call.linear_fm(80e3, 60e3, duration_s=1e-3),
        "Forest": forest,
        "Tree": tree,
        "BranchLayout": tree.layout,
        "SonarMount": batecho.SonarMount(pitch_deg=-5.0),
        "Flight": drone.fly(path, duration=0.1),
        "QuadState": drone.initial_state(trajectories.Hover([0.0, 0.0, 1.0])),
        "SwarmState": QuadrotorSim(
            drone, drone.initial_state(trajectories.Hover([0, 0, 1.0]))
        ).step([0.0, 0.0, 0.0], 0.0, n_steps=1),
        "ReferenceTree": reference,
        "BranchTemplate": reference.branches[0],
        "Mesh": batecho.load_obj(batecho.REFERENCE_TREE),
        "SquaredExponentialMixture": batecho.paper_intensity(),
        "RasterIntensity": batecho.RasterIntensity(np.ones((3, 3)), (0.0, 1.0, 0.0, 1.0)),
    }


READ_ONLY_OBJECTS = _read_only_objects()


@pytest.mark.parametrize("copier", [_roundtrip, copy.deepcopy], ids=["pickle", "deepcopy"])
@pytest.mark.parametrize("name", list(READ_ONLY_OBJECTS))
def test_a_loaded_copy_keeps_the_originals_read_only_arrays_read_only(name, copier):
    obj = READ_ONLY_OBJECTS[name]
    assert _read_only_arrays(obj)
    assert set(_read_only_arrays(obj)) <= set(_read_only_arrays(copier(obj)))


def test_the_leaves_of_a_loaded_scene_cannot_be_changed_behind_its_bvh():
    loaded = _roundtrip(_wooded_scene())
    assert loaded.leaves is not None
    with pytest.raises(ValueError, match="read-only"):
        loaded.leaves.centers[0] = 0.0


def _echo_in_worker(args):
    scene, sonar, poses = args
    return batecho.simulate(scene, sonar, poses, tol=1e-6, min_clearance_m=0).impulse


def test_a_spawned_process_pool_simulates_what_this_process_does():
    scene, sonar = _wooded_scene(), SONARS["ears, shading"]
    want = batecho.simulate(scene, sonar, POSES, tol=1e-6, min_clearance_m=0).impulse
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        got = pool.submit(_echo_in_worker, (scene, sonar, POSES)).result(timeout=300)
    assert np.array_equal(got, want)


class _Edited:
    """Pickles as ``obj`` with the entries ``edits`` of its state replaced: an edited pickle."""

    def __init__(self, obj, **edits):
        self.obj, self.edits = obj, edits

    def __reduce__(self):
        state = self.obj.__reduce_ex__(2)[2]
        if isinstance(state, tuple):  # (dict or None, slots)
            state = (state[0], {**state[1], **self.edits})
        else:
            state = {**state, **self.edits}
        return (_new, (type(self.obj),), state)


def _new(cls):
    return cls.__new__(cls)


def _load_edited(obj, **edits):
    return pickle.loads(pickle.dumps(_Edited(obj, **edits)))


def test_a_pickled_leaves_edited_to_nan_centres_is_refused_on_loading():
    leaves = _wooded_scene().leaves
    centers = np.array(leaves.centers)
    centers[3] = np.nan
    with pytest.raises(ValueError, match="pickled Leaves: centers must be finite"):
        _load_edited(leaves, _centers=centers)


def test_a_pickled_leaves_edited_to_radii_of_another_length_is_refused_on_loading():
    leaves = _wooded_scene().leaves
    with pytest.raises(ValueError, match="pickled Leaves: radii must have shape"):
        _load_edited(leaves, _radii=np.full(3, 0.02))


def test_a_pickled_leaves_edited_to_normals_of_another_length_than_one_is_refused_on_loading():
    leaves = _wooded_scene().leaves
    with pytest.raises(ValueError, match="pickled Leaves: leaf 0's normal .* not a unit vector"):
        _load_edited(leaves, _normals=leaves.normals * 2.0)


def test_a_pickled_branches_edited_to_a_zero_length_segment_is_refused_on_loading():
    branches = _wooded_scene().branches
    with pytest.raises(ValueError, match="pickled Branches: branch 0 has zero length"):
        _load_edited(branches, _ends=np.array(branches.starts))


def test_a_pickled_poses_edited_to_float32_positions_is_refused_on_loading():
    with pytest.raises(ValueError, match="pickled Poses: its positions is float32"):
        _load_edited(POSES, _positions=POSES.positions.astype(np.float32))


def test_a_pickled_poses_edited_to_a_frame_that_is_not_orthonormal_is_refused_on_loading():
    with pytest.raises(ValueError, match="pickled Poses: its left vectors are not up x forward"):
        _load_edited(POSES, _left=-POSES.left)


def test_a_pickled_call_edited_to_silent_samples_is_refused_on_loading():
    # (its matched filter divided by the zero energy: compressed echoes were all NaN)
    call = batecho.Call.linear_fm(80e3, 60e3, duration_s=1e-3)
    with pytest.raises(ValueError, match="pickled Call: the samples' energy"):
        _load_edited(call, samples=np.zeros(len(call)))


def test_a_pickled_call_edited_to_a_rate_that_is_not_a_number_is_refused_on_loading():
    call = batecho.Call.linear_fm(80e3, 60e3, duration_s=1e-3)
    with pytest.raises(ValueError, match="pickled Call: fs must be"):
        _load_edited(call, fs=float("nan"))


def _array_results() -> dict[str, object]:
    scene, sonar = _wooded_scene(), SONARS["ears, shading"]
    return {
        "Echoes": batecho.simulate(scene, sonar, POSES, min_clearance_m=0),
        "LeafSights": batecho.leaf_sights(scene, SONARS["default"], POSES[0]),
        "Branching": batecho.trunk_branching(5),
        "Segments": batecho.turtle("F[+F]F[-F]F", marks="F"),
    }


ARRAY_RESULTS = _array_results()


@pytest.mark.parametrize("protocol", [2, 3, 4, 5])
@pytest.mark.parametrize("name", list(ARRAY_RESULTS))
def test_a_loaded_result_holding_arrays_equals_the_original(name, protocol):
    # (the generated == compared the arrays element by element and raised ValueError)
    obj = ARRAY_RESULTS[name]
    assert pickle.loads(pickle.dumps(obj, protocol=protocol)) == obj


@pytest.mark.parametrize("name", list(ARRAY_RESULTS))
def test_a_deep_copy_of_a_result_holding_arrays_equals_the_original(name):
    obj = ARRAY_RESULTS[name]
    assert copy.deepcopy(obj) == obj


def test_echoes_that_differ_in_one_sample_are_not_equal():
    echoes = ARRAY_RESULTS["Echoes"]
    impulse = np.array(echoes.impulse)
    impulse[0, 0, 5] += 1.0
    assert dataclasses.replace(echoes, impulse=impulse) != echoes


def test_echoes_of_other_poses_are_not_equal():
    echoes = ARRAY_RESULTS["Echoes"]
    moved = POSES.transformed(translation=(0.0, 0.0, 1e-3))
    assert dataclasses.replace(echoes, poses=moved) != echoes
