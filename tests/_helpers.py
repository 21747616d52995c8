"""Helpers for the tests: relative errors, scene builders in a pose's frame, and a small
EchoFlight forest."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np

import batecho


def rel_err(a: np.ndarray, b: np.ndarray) -> float:
    """||a - b||_2 / ||b||_2 (0 when both are exactly zero)."""
    nb = np.linalg.norm(b)
    if nb == 0.0:
        return 0.0 if np.linalg.norm(a) == 0.0 else np.inf
    return float(np.linalg.norm(a - b) / nb)


def frame_points(pose: batecho.Poses, r, az, el) -> np.ndarray:
    """World points at range r, azimuth az, elevation el (radians) in the frame of pose 0."""
    r, az, el = (np.asarray(x, dtype=np.float64) for x in (r, az, el))
    e = (
        (np.cos(el) * np.cos(az))[:, None] * pose.forward[0]
        + (np.cos(el) * np.sin(az))[:, None] * pose.left[0]
        + np.sin(el)[:, None] * pose.up[0]
    )
    return pose.positions[0] + r[:, None] * e


def kinked_leaf_at_the_top(
    sonar: batecho.Sonar, radius: float, live: int, r: float
) -> batecho.Leaves:
    """One paper-model leaf on the x axis at range r whose corner (cos(B(c) beta) turning
    positive) lies at band bin n_bins - live: near grazing incidence, live only in the band's
    top `live` bins, where its values are ~1e-4 of the factor's scale A(c)."""
    c = 2.0 * np.pi * sonar.freqs[sonar.n_bins - live] / sonar.sound_speed * radius
    beta = (np.pi / 2) / (0.3999 * c**-0.9065 + 0.9979) + 1e-12
    return batecho.Leaves([[r, 0.0, 0.0]], [[np.cos(beta), np.sin(beta), 0.0]], [radius])


def run_script_with_threads(script: str, threads: int, path) -> dict:
    """Run ``script`` (which saves an NPZ at ``sys.argv[1]``) in a child process with
    ``RAYON_NUM_THREADS=threads``, and return the saved arrays by name."""
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    subprocess.run([sys.executable, "-c", script, str(path)], env=env, check=True)
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


#: EchoFlightEnv keywords for a small forest that grows in a fraction of a second: one tree
#: variant of three branches.
SMALL_FOREST = {
    "density": 0.06,
    "length_m": 12.0,
    "width_m": 8.0,
    "trees_from_m": 2.5,
    "variants": 1,
    "tree_params": {"n_branches": 3},
    "max_time_s": 15.0,
}
