"""Hypothesis strategies for sonars, poses and leaf scenes with the hard cases mixed in:
normal and grazing incidence, leaves exactly on and next to the lobe boundary, radii from 1 mm
to 20 cm, ranges from 5 cm to the edge of the record."""

from __future__ import annotations

import math

import numpy as np
from _helpers import frame_points
from hypothesis import strategies as st

from batecho import Atmosphere, Beam, Leaves, Poses, Sonar, reference


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


@st.composite
def sonars(draw) -> Sonar:
    lobe = draw(st.sampled_from(["detectable", "cone"]))
    kw: dict = dict(
        leaf_model=draw(st.sampled_from(["paper", "physical_optics"])),
        spreading=draw(st.booleans()),
        window=draw(st.sampled_from(["hann", "rect"])),
        gain=draw(st.floats(0.01, 5.0)),
        sound_speed=draw(st.floats(330.0, 350.0)),
        lobe=lobe,
    )
    if draw(st.booleans()):
        kw["absorption"] = Atmosphere(
            temperature_c=draw(st.floats(-10.0, 40.0)),
            relative_humidity=draw(st.floats(0.0, 100.0)),
        )
    if draw(st.integers(0, 3)) == 0:
        kw["beam"] = Beam(
            sigma_deg=(draw(st.floats(2.0, 40.0)), draw(st.floats(2.0, 40.0))),
            rotation_deg=draw(st.floats(-90.0, 90.0)),
            center_deg=(draw(st.floats(-20.0, 20.0)), draw(st.floats(-20.0, 20.0))),
            amplitude=draw(st.floats(0.5, 2.0)),
        )
        if draw(st.booleans()):
            kw["receiver"] = Beam(beamwidth_deg=draw(st.floats(5.0, 120.0)))
    else:
        kw["beamwidth_deg"] = draw(st.floats(5.0, 120.0))
    if lobe == "cone":
        kw["cone_half_angle_deg"] = draw(st.floats(2.0, 80.0))
    else:
        kw["threshold_db"] = draw(st.floats(0.0, 40.0))
    fs = draw(st.sampled_from([250e3, 400e3, 500e3]))
    kw["fs"] = fs
    kw["n_samples"] = draw(st.integers(4000, 30000))
    return Sonar(**kw)


@st.composite
def poses(draw, n=None) -> Poses:
    n = n or draw(st.integers(1, 3))
    pos = [[draw(st.floats(-20.0, 20.0)) for _ in range(3)] for _ in range(n)]
    fwd = []
    for _ in range(n):
        f = [draw(st.floats(-1.0, 1.0)) for _ in range(3)]
        if np.linalg.norm(f) < 0.1 or abs(unit(f)[2]) > 0.99:
            f = [1.0, 0.0, 0.0]
        fwd.append(f)
    return Poses(pos, fwd)


def boundary_range(sonar: Sonar, pose: Poses, az: float, el: float) -> float:
    """The reference's detectable reach in the direction (az, el) of pose 0."""
    p = frame_points(pose, [1.0], [az], [el])
    lv = Leaves(p, [[0.0, 0.0, 1.0]], [0.02])
    _r, _, _, G = reference._view(lv.centers, sonar, pose, 0)
    K = (
        sonar.r0_m
        * sonar.r0_m
        * sonar.p0_pa
        / (10.0 ** (sonar.threshold_db / 20.0) * sonar.p_ref_pa)
    )
    return math.sqrt(K * G[0])


@st.composite
def scenes(draw, sonar: Sonar, pose: Poses) -> Leaves:
    """Leaves around pose 0's beam, with the hard cases mixed in."""
    n = draw(st.integers(1, 40))
    bw = math.radians(min(120.0, 2.5 * max(sonar.beam.sigmas_rad) * 180 / math.pi * 2.4))
    rec = sonar.record_range_m
    centers, normals, radii = [], [], []
    for _ in range(n):
        kind = draw(
            st.sampled_from(
                ["random", "normal", "grazing", "boundary", "near_boundary", "cone_edge"]
            )
        )
        az = draw(st.floats(-bw, bw))
        el = draw(st.floats(-min(bw, 1.4), min(bw, 1.4)))
        r = math.exp(draw(st.floats(math.log(0.05), math.log(rec * 1.02))))
        if kind in ("boundary", "near_boundary") and sonar.lobe == "detectable":
            r = boundary_range(sonar, pose, az, el)
            if kind == "near_boundary":
                r *= 1.0 + draw(st.sampled_from([-1, 1])) * 10.0 ** -draw(st.integers(6, 15))
            r = min(max(r, 0.05), rec * 1.02)
        if kind == "cone_edge" and sonar.lobe == "cone":
            h = math.radians(sonar.cone_half_angle_deg)
            phi = draw(st.floats(0.0, 2 * math.pi))
            e = math.cos(h) * pose.forward[0] + math.sin(h) * (
                math.cos(phi) * pose.left[0] + math.sin(phi) * pose.up[0]
            )
            c = pose.positions[0] + r * e
        else:
            c = frame_points(pose, [r], [az], [el])[0]
        e_dir = unit(c - pose.positions[0])
        if kind == "normal":
            nv = e_dir * draw(st.sampled_from([-1.0, 1.0]))
        elif kind == "grazing":
            nv = np.cross(
                e_dir, unit([draw(st.floats(-1, 1)) for _ in range(3)] + np.array([0.3, 0.2, 0.1]))
            )
            if np.linalg.norm(nv) < 1e-6:
                nv = np.cross(e_dir, [0.0, 0.0, 1.0])
        else:
            nv = [draw(st.floats(-1.0, 1.0)) for _ in range(3)]
            if np.linalg.norm(nv) < 1e-3:
                nv = [0.0, 0.0, 1.0]
        centers.append(c)
        normals.append(nv)
        radii.append(math.exp(draw(st.floats(math.log(1e-3), math.log(0.2)))))
    return Leaves(np.array(centers), np.array(normals), np.array(radii))


@st.composite
def cases(draw):
    sonar = draw(sonars())
    pose = draw(poses())
    leaves = draw(scenes(sonar, pose))
    return sonar, pose, leaves
