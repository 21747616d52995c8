"""Results are bit-identical for any number of threads (the reduction order is fixed): echoes
and clearances."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap

import numpy as np

import batecho

SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    import batecho
    from batecho.echoes.canonical import canonical_leaf_box
    leaves = canonical_leaf_box(np.random.default_rng(3))
    extra = batecho.Leaves(leaves.centers * [1.0, 0.5, 0.5], leaves.normals, leaves.radii)
    leaves = batecho.Leaves.concatenate([leaves, extra])
    poses = batecho.Poses([[0, 0, 0], [0, 0.3, 0.1], [0.5, -0.2, 0]],
                          [[1, 0, 0], [1, 0.1, 0], [1, 0, 0.1]])
    out = {}
    for model in ("paper", "physical_optics"):
        for atm in (None, batecho.Atmosphere()):
            e = batecho.simulate(leaves, batecho.Sonar(leaf_model=model, absorption=atm), poses)
            key = f"{model}-{atm is not None}"
            out[key + "-spec"] = e.spectrum
            out[key + "-imp"] = e.impulse
            out[key + "-n"] = e.n_leaves
    # Enough leaves for the fused fast pulse's parallel chunks and its node-count choice.
    rng = np.random.default_rng(5)
    big = batecho.Leaves(np.column_stack([rng.uniform(1, 9, 40000), rng.uniform(-2, 2, 40000),
                                          rng.uniform(-2, 2, 40000)]),
                         rng.normal(size=(40000, 3)), rng.normal(0.02, 0.002, 40000))
    cone = batecho.Sonar(lobe="cone", cone_half_angle_deg=60.0)
    for tol in (1e-6, 1e-12):
        e = batecho.simulate(big, cone, poses, method="fast", tol=tol)
        out[f"fast-{tol}-spec"] = e.spectrum
        out[f"fast-{tol}-n"] = e.n_leaves
    # Two ears: one walk and one pass for both, each ear's spectrum by each method.
    ears = batecho.Sonar.binaural(0.05, 25.0, lobe="cone", cone_half_angle_deg=60.0)
    for method, tol in (("exact", 1e-12), ("fast", 1e-6), ("auto", 1e-9)):
        e = batecho.simulate(big, ears, poses[:2], method=method, tol=tol)
        out[f"ears-{method}-spec"] = e.spectrum
        out[f"ears-{method}-imp"] = e.impulse
        out[f"ears-{method}-n"] = e.n_leaves
    points = np.column_stack([rng.uniform(0, 10, 5000), rng.uniform(-3, 3, 5000),
                              rng.uniform(-3, 3, 5000)])
    out["clearance"], out["clearance-index"] = batecho.Scene(big).clearance(
        points, return_index=True)
    np.savez(sys.argv[1], **out)
    """
)


def run(threads: int, path) -> dict:
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    subprocess.run([sys.executable, "-c", SCRIPT, str(path)], env=env, check=True)
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


def test_results_are_bit_identical_with_one_and_two_threads(tmp_path):
    one = run(1, tmp_path / "one.npz")
    two = run(2, tmp_path / "two.npz")
    assert one.keys() == two.keys()
    for k in one:
        assert one[k].tobytes() == two[k].tobytes(), k
    assert one["paper-False-n"].min() > 256  # several leaf chunks per pose
    assert one["fast-1e-06-n"].min() > 20000  # several fused chunks per pose
    assert one["ears-fast-n"].shape == (2, 2) and one["ears-fast-n"].min() > 20000


def test_repeated_calls_are_bit_identical():
    import batecho
    from batecho.echoes.canonical import canonical_leaf_box

    leaves = canonical_leaf_box(np.random.default_rng(4))
    scene = batecho.Scene(leaves)
    pose = batecho.Poses([0, 0, 0], [1, 0, 0])
    a = batecho.simulate(scene, batecho.Sonar(), pose)
    b = batecho.simulate(scene, batecho.Sonar(), pose)
    assert a.spectrum.tobytes() == b.spectrum.tobytes()
    assert a.impulse.tobytes() == b.impulse.tobytes()


def _simulate_in_child(queue):
    from batecho.echoes.canonical import canonical_leaf_box

    leaves = canonical_leaf_box(np.random.default_rng(3))
    poses = batecho.Poses([[0, 0, 0], [0, 0.3, 0.1]], [[1, 0, 0], [1, 0.1, 0]])
    fast = batecho.simulate(leaves, batecho.Sonar(), poses, method="fast", tol=1e-6)
    queue.put(fast.spectrum.tobytes())


def test_a_forked_child_simulates_what_its_parent_does():
    # The parent's worker threads are not copied into a forked child; the child must make its
    # own rather than wait for them forever.
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    _simulate_in_child(queue)  # the parent's pool is running before the fork
    parent = queue.get(timeout=60)
    child = ctx.Process(target=_simulate_in_child, args=(queue,))
    child.start()
    child.join(timeout=120)
    if child.is_alive():
        child.kill()
        raise AssertionError("the forked child hung")
    assert child.exitcode == 0
    assert queue.get(timeout=10) == parent
