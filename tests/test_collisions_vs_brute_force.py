"""Clearances and collisions against an independent brute force: the distance to the nearest
point of every leaf disk, branch cylinder and bark triangle, found here by clamping (a disk's
in-plane offset to its radius, a cylinder's axial offset to its length and radial offset to its
radius, a triangle's projection to its edges) rather than by docs/model.md §6's closed forms.

Random scenes with points on the hard places (a rim grazed at a distance, a point a hair off a
leaf's face, the midpoint of two neighbouring leaves, a trunk's surface, an end cap and its
rim) agree to 1e-14 of the coordinates' size (the largest difference seen was 3e-15). Parts with
dyadic coordinates give those places' distances exactly. batecho/EchoFlight-v0's clearance
along every flown step is the brute force's over leaves, branches, bark and the ground (seen:
within 4e-16 m, the same collisions over 1,236 random steps in six forests); a collision is a
clearance below the drone's radius, so a path that only touches it does not collide."""

from __future__ import annotations

import numpy as np
import pytest
from _helpers import SMALL_FOREST

import batecho
from batecho.envs import EchoFlightEnv

SMALL = SMALL_FOREST

#: Distances agree to this, relative to the larger of 1 m and the point's largest coordinate.
REL_TOL = 1e-14

#: How far (m) a hand-made path passes inside or outside the drone's radius.
HAIR = 1e-9


# -------------------------------------------------------------------------- brute force


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def disk_distances(p: np.ndarray, c: np.ndarray, n: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(m, k): from each point to the nearest point of each disk, its in-plane offset clamped
    to the radius."""
    d = p[:, None, :] - c[None]
    q = d - np.einsum("mkj,kj->mk", d, n)[..., None] * n[None]
    rho = np.linalg.norm(q, axis=-1)
    shrink = np.minimum(1.0, a[None] / np.where(rho > 0.0, rho, 1.0))
    return np.linalg.norm(d - q * shrink[..., None], axis=-1)


def cylinder_distances(p: np.ndarray, s: np.ndarray, e: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(m, k): from each point to the nearest point of each solid capped cylinder (0 inside)."""
    length = np.linalg.norm(e - s, axis=1)
    u = (e - s) / length[:, None]
    d = p[:, None, :] - s[None]
    sigma = np.einsum("mkj,kj->mk", d, u)
    q = d - sigma[..., None] * u[None]
    rho = np.linalg.norm(q, axis=-1)
    shrink = np.minimum(1.0, r[None] / np.where(rho > 0.0, rho, 1.0))
    nearest = np.clip(sigma, 0.0, length[None])[..., None] * u[None] + q * shrink[..., None]
    return np.linalg.norm(d - nearest, axis=-1)


def segment_distances(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.einsum("mkj,kj->mk", p[:, None, :] - a[None], ab) / np.einsum("kj,kj->k", ab, ab)
    foot = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - foot, axis=-1)


def triangle_distances(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(m, k): the distance to the plane where the foot falls inside, else to the nearest edge
    (triangles of nonzero area)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    n = unit(np.cross(b - a, c - a))
    h = np.einsum("mkj,kj->mk", p[:, None, :] - a[None], n)
    foot = p[:, None, :] - h[..., None] * n[None]

    def left_of(x, y):
        return np.einsum("mkj,kj->mk", np.cross(y - x, foot - x[None]), n) >= 0.0

    inside = left_of(a, b) & left_of(b, c) & left_of(c, a)
    edges = np.minimum(segment_distances(p, a, b), segment_distances(p, b, c))
    return np.where(inside, np.abs(h), np.minimum(edges, segment_distances(p, c, a)))


def forest_distance(env: EchoFlightEnv, path: np.ndarray) -> float:
    """The least distance from ``path`` to the ground and the forest's leaves, branches and
    bark (the triangles within 2.5 m of the path's box)."""
    forest = env.forest
    leaves, wood = forest.leaves, forest.branches
    v, f, _ = forest.bark()
    tri = v[f]
    lo, hi = path.min(axis=0) - 2.5, path.max(axis=0) + 2.5
    near = np.all((tri.max(axis=1) >= lo) & (tri.min(axis=1) <= hi), axis=1)
    parts = [
        path[:, 2].min(),
        disk_distances(path, leaves.centers, leaves.normals, leaves.radii).min(),
        cylinder_distances(path, wood.starts, wood.ends, wood.radii).min(),
    ]
    if near.any():
        parts.append(triangle_distances(path, tri[near]).min())
    return float(min(parts))


# ---------------------------------------------------------------------------- scenes


def random_scene(seed: int):
    """A scene of leaves and branches at one of three scales, and points on its hard places."""
    rng = np.random.default_rng(seed)
    scale = [0.5, 5.0, 30.0][seed % 3]
    n, k, m = 150, 20, 20
    leaves = batecho.Leaves(
        rng.uniform(-scale, scale, (n, 3)), rng.normal(size=(n, 3)), rng.uniform(0.005, 0.1, n)
    )
    start = rng.uniform(-scale, scale, (k, 3))
    wood = batecho.Branches(
        start, start + rng.normal(size=(k, 3)) * scale / 3, rng.uniform(0.01, 0.4, k)
    )
    c, nv, a = leaves.centers, leaves.normals, leaves.radii
    s, e, r = wood.starts, wood.ends, wood.radii
    i, b = rng.integers(0, n, m), rng.integers(0, k, m)
    apart = np.linalg.norm(c[i][:, None, :] - c[None], axis=-1)
    apart[np.arange(m), i] = np.inf
    j = np.argmin(apart, axis=1)  # leaf i's nearest neighbour
    along = unit(np.cross(nv[i], rng.normal(size=(m, 3))))  # in leaf i's plane
    axis = unit(e[b] - s[b])
    out = unit(np.cross(axis, rng.normal(size=(m, 3))))  # perpendicular to branch b
    gap = rng.uniform(0.05, 0.3, (m, 1))
    inner = rng.uniform(0.0, 0.99, (m, 1))
    points = np.concatenate(
        [
            c[i] + (a[i, None] + gap) * along,  # grazing the rim at gap
            c[i] + a[i, None] * along,  # on the rim
            c[i] + inner * a[i, None] * along + 1e-12 * nv[i],  # a hair off the face
            c[i] + inner * a[i, None] * along - 1e-15 * nv[i],
            0.5 * (c[i] + c[j]),  # midway between two neighbouring leaves
            s[b] + inner * (e[b] - s[b]) + r[b, None] * out,  # on the bark's surface
            s[b] + inner * (e[b] - s[b]) + (r[b, None] + gap) * out,  # gap off it
            e[b] + inner * r[b, None] * out,  # on the end cap
            e[b] + r[b, None] * out,  # on the cap's rim
            e[b] + gap * axis + inner * r[b, None] * out,  # gap above the cap
            rng.uniform(-1.2 * scale, 1.2 * scale, (100, 3)),  # anywhere
        ]
    )
    return batecho.Scene(leaves, branches=wood), leaves, wood, points


@pytest.mark.parametrize("seed", range(6))
def test_a_scenes_clearance_is_the_distance_to_the_nearest_point_of_any_leaf_or_branch(seed):
    scene, leaves, wood, points = random_scene(seed)
    brute = np.minimum(
        disk_distances(points, leaves.centers, leaves.normals, leaves.radii).min(axis=1),
        cylinder_distances(points, wood.starts, wood.ends, wood.radii).min(axis=1),
    )
    size = np.maximum(1.0, np.abs(points).max(axis=1))
    np.testing.assert_array_less(np.abs(scene.clearance(points) - brute) / size, REL_TOL)


@pytest.mark.parametrize("seed", range(6))
def test_a_paths_smallest_clearance_below_a_bound_is_the_brute_force_least(seed):
    scene, leaves, wood, points = random_scene(seed)
    brute = min(
        disk_distances(points, leaves.centers, leaves.normals, leaves.radii).min(),
        cylinder_distances(points, wood.starts, wood.ends, wood.radii).min(),
    )
    size = max(1.0, float(np.abs(points).max()))
    assert abs(scene.min_clearance(points) - brute) <= REL_TOL * size
    assert scene.min_clearance(points, brute / 2) == brute / 2  # (nothing nearer than it)


# ------------------------------------------------------------- exact distances


#: Parts with dyadic coordinates, a point at an exact distance from one, and the direction
#: from the point toward it.
LEAF = batecho.Leaves([[1.0, 2.0, 3.0]], [[0.0, 0.0, 1.0]], [0.25])
TWO_LEAVES = batecho.Leaves([[0.0, 0.5, 0.0], [0.0, -0.5, 0.0]], [[0.0, 0.0, 1.0]] * 2, [0.25] * 2)
TRUNK = batecho.Branches([[0.0, 0.0, 0.0]], [[0.0, 0.0, 4.0]], [0.25])
X, Y, Z = np.eye(3)
EXACT = {
    "grazing a leaf's rim in its plane": (LEAF, None, [1.375, 2.0, 3.0], 0.125, -X),
    "above a leaf's face": (LEAF, None, [1.125, 2.0, 3.125], 0.125, -Z),
    "inside a leaf's thickness": (LEAF, None, [1.125, 2.0, 3.0 + 2.0**-40], 2.0**-40, -Z),
    "on a leaf's face": (LEAF, None, [1.125, 2.0, 3.0], 0.0, -Z),
    "exactly between two leaves": (TWO_LEAVES, None, [0.0, 0.0, 0.0], 0.25, Y),
    "off a trunk's side": (None, TRUNK, [0.375, 0.0, 2.0], 0.125, -X),
    "on a trunk's surface": (None, TRUNK, [0.0, -0.25, 2.0], 0.0, Y),
    "above an end cap": (None, TRUNK, [0.125, 0.0, 4.125], 0.125, -Z),
    "on an end cap": (None, TRUNK, [0.125, 0.0, 4.0], 0.0, -Z),
    "beyond a cap's rim": (None, TRUNK, [0.625, 0.0, 4.5], 0.625, -0.6 * X - 0.8 * Z),
}


@pytest.mark.parametrize("place", sorted(EXACT))
def test_a_path_through_a_point_at_an_exact_distance_from_a_part_has_that_clearance(place):
    leaves, wood, point, gap, _ = EXACT[place]
    scene = batecho.Scene(leaves, branches=wood)
    assert scene.clearance(point)[0] == gap
    assert scene.min_clearance([[10.0, 10.0, 10.0], point]) == gap  # (the path's other end far)


@pytest.mark.parametrize("place", sorted(k for k in EXACT if EXACT[k][3] > 0))
def test_a_path_a_hair_nearer_than_an_exact_distance_has_less_clearance(place):
    leaves, wood, point, gap, toward = EXACT[place]
    scene = batecho.Scene(leaves, branches=wood)
    assert scene.min_clearance(np.asarray(point) + 2.0**-40 * toward) < gap


# ----------------------------------------------------------------- the environment's forest


def test_every_steps_clearance_and_collision_are_the_brute_force_ones_until_a_trunk_is_hit():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=0)
    trunk = env.forest.trunk_bases[0] + (0.0, 0.0, env.altitude_m)
    for _ in range(200):
        p, R = env.sim.state.positions[0], env.sim.state.attitudes[0]
        d = (R.T @ (trunk - p))[:2]
        d /= np.linalg.norm(d)
        _, _, terminated, truncated, info = env.step(np.array([d[0], d[1], 0.0, 0.0], np.float32))
        want = min(forest_distance(env, env.sim.path[0]), 2.0)
        assert abs(info["clearance_m"] - want) <= REL_TOL * 20.0
        assert info["collision"] == (want < env.drone_radius_m)
        if terminated or truncated:
            break
    assert info["collision"]  # (the trunk was reached)


def test_a_path_exactly_the_drones_radius_above_the_ground_touches_it_without_colliding():
    env = EchoFlightEnv(**SMALL)
    env.reset(seed=0)
    radius = env.drone_radius_m
    p = env.start.copy()  # (the forest keeps clear of it)
    p[2] = radius
    info = env.after_flight(np.zeros(4), 0.0, p[None, :])[3]
    assert info["clearance_m"] == radius and not info["collision"]
    p[2] = np.nextafter(radius, 0.0)
    assert env.after_flight(np.zeros(4), 0.0, p[None, :])[3]["collision"]
