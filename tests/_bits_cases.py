"""The scenes, sonars and methods whose `simulate` results are pinned by checksum in
`test_bits.py`: the benchmark box scene, a forest of the paper flown around, both leaf models,
absorption, exact and fast at three tolerances."""

from __future__ import annotations

import hashlib

import numpy as np

import batecho


def box_scene(n: int, seed: int = 7) -> batecho.Scene:
    """The benchmarks' scene: n leaves in x in [1, 9.5] m, y, z in [-2, 2] m."""
    rng = np.random.default_rng(seed)
    centers = np.column_stack(
        [rng.uniform(1.0, 9.5, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)]
    )
    return batecho.Scene(
        batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.normal(0.02, 0.002, n))
    )


def forest_case() -> tuple[batecho.Scene, batecho.Poses]:
    """A paper forest (two tree variants) and 6 pulses on the paper's circle."""
    forest = batecho.Forest.paper_example(3, variants=2)
    cx, cy = forest.mean_position
    poses = batecho.circle((cx, cy), radius=6.2, altitude=5.0, n_points=6, heading="center")
    return forest.scene(), poses


SONARS = {
    "cone-paper": dict(lobe="cone", cone_half_angle_deg=75.0, beamwidth_deg=30.0),
    "cone-po": dict(
        lobe="cone", cone_half_angle_deg=75.0, beamwidth_deg=30.0, leaf_model="physical_optics"
    ),
    "cone-absorb": dict(
        lobe="cone", cone_half_angle_deg=75.0, beamwidth_deg=30.0, absorption=batecho.Atmosphere()
    ),
    "detectable": dict(beamwidth_deg=30.0, too_close="skip"),
    "detectable-po-absorb": dict(
        beamwidth_deg=40.0,
        leaf_model="physical_optics",
        absorption=batecho.Atmosphere(),
        too_close="skip",
    ),
}

METHODS = (("exact", None), ("fast", 1e-3), ("fast", 1e-6), ("fast", 1e-12))


def cases():
    """(name, scene factory, sonar kwargs, method, tol) for every pinned case."""
    out = []
    for n in (1_000, 20_000):
        for s in ("cone-paper", "cone-po", "cone-absorb"):
            for m, tol in METHODS:
                out.append((f"box{n}-{s}-{m}-{tol}", ("box", n), s, m, tol))
    for s in ("detectable", "detectable-po-absorb"):
        for m, tol in METHODS:
            out.append((f"forest-{s}-{m}-{tol}", ("forest", 0), s, m, tol))
    return out


_SCENES: dict = {}


def scene_and_poses(key):
    if key not in _SCENES:
        kind, n = key
        if kind == "box":
            _SCENES[key] = (box_scene(n), batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))
        else:
            _SCENES[key] = forest_case()
    return _SCENES[key]


def digest(key, sonar_name: str, method: str, tol) -> str:
    scene, poses = scene_and_poses(key)
    sonar = batecho.Sonar(**SONARS[sonar_name])
    kw = {} if tol is None else {"tol": tol}
    echo = batecho.simulate(scene, sonar, poses, method=method, **kw)
    h = hashlib.sha256()
    for a in (echo.spectrum, echo.impulse, echo.n_leaves):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:24]
