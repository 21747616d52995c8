"""Generate batecho's shipped reference tree: ``python/batecho/data/reference_tree.{obj,mtl,json}``.

A plausible deciduous tree, about 8 m tall, grown procedurally from a fixed seed with plain
NumPy (it does not import batecho, so later changes to the library cannot change the data):

* ``trunk``: a straight, vertical, tapered 6-sided tube from (0, 0, 0) to (0, 0, 7.0) m;
* 9 first-level branches (``branch_00`` ... ``branch_08``, bottom to top, a 137.5 degree
  spiral): each a curved *axis* polyline starting on the trunk axis, bark as a tapered 6-sided
  tube, carrying *sub-branches* (5-sided tubes) at arc-length positions along the axis; each
  sub-branch carries twigs (4-sided tubes) and the twigs carry the leaves. A branch's bark
  group holds the bark of its axis, sub-branches and twigs;
* leaves as rhombic quad cards (area ``pi r^2``, ``r ~ Normal(2.5 cm, 0.5 cm)`` truncated to
  [0.5, 4.5] cm), mostly facing up, in one group per branch (``leaves_branch_00`` ...), so
  leaves can follow their branch.

The structure that :func:`batecho.trees.grow_tree` randomises is written to the JSON sidecar
``reference_tree.json``: for each branch, its axis polyline (m, z up), the number of bark
triangles of the axis tube (the first triangles of the branch's bark group, in file order),
and for each sub-branch ("unit": the sub-branch with its twigs and leaves, in file order) its
anchor (arc length along the axis, m), its number of bark triangles (each quad is two) and
its number of leaves. The woody skeleton is there too: every bark tube's axis points with the
bark's radius at each (the trunk's, each branch axis's, each unit's sub-branch and twigs).

Determinism: one ``numpy.random.Generator(PCG64(SEED))`` used only through ``random()``
(normals by Box-Muller), coordinates rounded to 4 decimals (0.1 mm) before they are written,
and fixed formatting. Running the script twice gives byte-identical files; it prints their
SHA-256. ``tests/test_trees.py`` regenerates the files and compares them with the shipped ones,
so the data are never edited by hand.

Usage::

    python tools/make_reference_tree.py            # (re)write python/batecho/data/
    python tools/make_reference_tree.py --check    # exit 1 if the shipped files differ
    python tools/make_reference_tree.py --out DIR  # write elsewhere
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SEED = 20_170_817
NAME = "reference_tree"
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "python" / "batecho" / "data"
DECIMALS = 4

TRUNK_HEIGHT = 7.0  # m
N_BRANCHES = 9
FIRST_BRANCH_HEIGHT = 2.0  # m
LAST_BRANCH_HEIGHT = 6.4  # m
DIVERGENCE_DEG = 137.5
LEAF_RADIUS_MEAN = 0.025  # m
LEAF_RADIUS_SD = 0.005  # m
LEAF_RADIUS_RANGE = (0.005, 0.045)  # m, truncation
LEAF_ASPECT = 1.6  # rhombus length / width

_BARK_RGB = (0.45, 0.32, 0.22)
_LEAF_RGB = (0.25, 0.55, 0.2)


# ------------------------------------------------------------------------------ randomness


class Rand:
    """Uniform and normal variates from ``Generator.random()`` only (a stable stream)."""

    def __init__(self, seed: int):
        self._g = np.random.Generator(np.random.PCG64(seed))

    def uniform(self, lo: float = 0.0, hi: float = 1.0) -> float:
        return lo + (hi - lo) * float(self._g.random())

    def normal(self, mean: float = 0.0, sd: float = 1.0) -> float:
        u1 = 1.0 - float(self._g.random())  # (0, 1]
        u2 = float(self._g.random())
        return mean + sd * math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)

    def truncated_normal(self, mean: float, sd: float, lo: float, hi: float) -> float:
        while True:
            x = self.normal(mean, sd)
            if lo <= x <= hi:
                return x


# ------------------------------------------------------------------------------ geometry


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for 3-vectors (much faster than ``np.cross`` on single vectors)."""
    a0, a1, a2 = a.tolist()
    b0, b1, b2 = b.tolist()
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def norm(v: np.ndarray) -> float:
    return math.sqrt(float(v @ v))


def unit(v: np.ndarray) -> np.ndarray:
    return v / norm(v)


def rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotate ``v`` about the unit ``axis`` by ``angle`` radians (Rodrigues)."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + cross(axis, v) * s + axis * (axis @ v) * (1.0 - c)


def side_frame(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors perpendicular to ``t``: ``s`` horizontal, ``u`` as up as possible."""
    s = cross(t, np.array([0.0, 0.0, 1.0]))
    if norm(s) < 1e-9:
        s = cross(t, np.array([1.0, 0.0, 0.0]))
    s = unit(s)
    return s, cross(s, t)


def bend_towards(t: np.ndarray, target: np.ndarray, angle: float) -> np.ndarray:
    """``t`` turned by ``angle`` radians towards ``target`` (no turn if they are parallel)."""
    axis = cross(t, target)
    n = norm(axis)
    if n < 1e-12:
        return t
    return unit(rotate(t, axis / n, angle))


def arc_lengths(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def point_at(points: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and unit tangent of a polyline at arc length ``s``."""
    arc = arc_lengths(points)
    j = int(np.clip(np.searchsorted(arc, s, side="right") - 1, 0, len(points) - 2))
    d = points[j + 1] - points[j]
    seg = float(np.linalg.norm(d))
    f = (s - arc[j]) / seg
    return points[j] + f * d, d / seg


def tube(points: np.ndarray, radii: np.ndarray, sides: int) -> tuple[np.ndarray, np.ndarray]:
    """A tapered open tube around a polyline: ``sides`` vertices per point, rings in planes
    bisecting the neighbouring segments, frames parallel-transported (no twist). Returns
    vertices ``(m * sides, 3)`` and quads ``(sides * (m - 1), 4)`` (0-based, outward)."""
    m = len(points)
    seg = np.diff(points, axis=0)
    seg = seg / np.linalg.norm(seg, axis=1)[:, None]
    tang = np.empty_like(points)
    tang[0], tang[-1] = seg[0], seg[-1]
    if m > 2:
        tang[1:-1] = seg[:-1] + seg[1:]
        tang[1:-1] /= np.linalg.norm(tang[1:-1], axis=1)[:, None]
    e1, _ = side_frame(tang[0])
    verts = np.empty((m, sides, 3))
    theta = 2.0 * np.pi * np.arange(sides) / sides
    for i in range(m):
        if i > 0:  # parallel transport of e1 from the previous tangent to this one
            e1 = e1 - (e1 @ tang[i]) * tang[i]
            e1 = unit(e1)
        e2 = cross(tang[i], e1)
        ring = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
        verts[i] = points[i] + radii[i] * ring
    k = np.arange(sides)
    quads = []
    for i in range(m - 1):
        a, b = i * sides + k, i * sides + (k + 1) % sides
        quads.append(np.stack([a, b, b + sides, a + sides], axis=1))
    return verts.reshape(-1, 3), np.concatenate(quads)


def leaf_card(center: np.ndarray, along: np.ndarray, normal: np.ndarray, r: float) -> np.ndarray:
    """A rhombus of area ``pi r^2`` (length/width ``LEAF_ASPECT``) centred at ``center``."""
    across = unit(cross(normal, along))
    half_w = r * math.sqrt(math.pi / (2.0 * LEAF_ASPECT))
    half_l = LEAF_ASPECT * half_w
    return np.array(
        [
            center - half_l * along,
            center - half_w * across,
            center + half_l * along,
            center + half_w * across,
        ]
    )


# ------------------------------------------------------------------------------ the tree


@dataclass
class Part:
    """Bark (vertices, quads), leaf cards and the tubes' axes (the woody skeleton) of one piece
    of a branch."""

    verts: list[np.ndarray] = field(default_factory=list)
    quads: list[np.ndarray] = field(default_factory=list)
    cards: list[np.ndarray] = field(default_factory=list)
    tubes: list[np.ndarray] = field(default_factory=list)

    def add_tube(self, points: np.ndarray, radii: np.ndarray, sides: int) -> None:
        v, q = tube(points, radii, sides)
        base = sum(len(x) for x in self.verts)
        self.verts.append(v)
        self.quads.append(q + base)
        self.tubes.append(np.column_stack([points, radii]))

    def skeleton(self) -> list[list[list[float]]]:
        """Each tube's axis points and radii as rows ``[x, y, z, r]`` (m), rounded."""
        return [_round(t).tolist() for t in self.tubes]

    @property
    def n_quads(self) -> int:
        return sum(len(q) for q in self.quads)


def trunk_radius(z: float) -> float:
    t = z / TRUNK_HEIGHT
    return 0.03 + 0.13 * (1.0 - t) ** 1.3 + 0.05 * math.exp(-z / 0.25)


def polyline(
    rnd: Rand,
    start: np.ndarray,
    direction: np.ndarray,
    length: float,
    n_seg: int,
    upturn: float,
    wander: float,
) -> np.ndarray:
    """A gently curving polyline: each step turns the heading by ``upturn / n_seg`` radians
    towards +z plus a random turn of sd ``wander`` radians."""
    pts = [start]
    d = unit(direction)
    step = length / n_seg
    z = np.array([0.0, 0.0, 1.0])
    for _ in range(n_seg):
        pts.append(pts[-1] + step * d)
        d = bend_towards(d, z, upturn / n_seg)
        s, u = side_frame(d)
        d = unit(d + rnd.normal(0.0, wander) * s + rnd.normal(0.0, wander) * u)
    return np.array(pts)


def add_leaves(rnd: Rand, part: Part, twig: np.ndarray, side0: int) -> None:
    """Alternate leaves along a twig (every 2.5 cm from 15% of its length) plus two at the tip."""
    arc = arc_lengths(twig)
    length = arc[-1]
    z = np.array([0.0, 0.0, 1.0])
    positions = list(np.arange(0.12 * length, length, 0.025)) + [length, length]
    for j, s in enumerate(positions):
        p, t = point_at(twig, min(s, length))
        sv, uv = side_frame(t)
        side = 1.0 if (j + side0) % 2 == 0 else -1.0
        out = unit(side * sv + 0.45 * uv + rnd.normal(0.0, 0.25) * uv)
        gamma = math.radians(rnd.uniform(40.0, 70.0)) if j < len(positions) - 2 else 0.35
        along = unit(math.cos(gamma) * t + math.sin(gamma) * out)
        r = rnd.truncated_normal(LEAF_RADIUS_MEAN, LEAF_RADIUS_SD, *LEAF_RADIUS_RANGE)
        half_l = LEAF_ASPECT * r * math.sqrt(math.pi / (2.0 * LEAF_ASPECT))
        center = p + (0.015 + half_l) * along
        n0 = z - (z @ along) * along  # as up as possible, perpendicular to the blade axis
        n0 = unit(n0) if norm(n0) > 1e-6 else side_frame(along)[1]
        normal = rotate(n0, along, math.radians(rnd.normal(0.0, 30.0)))
        normal = bend_towards(normal, along, math.radians(rnd.normal(0.0, 12.0)))
        normal = unit(normal - (normal @ along) * along)
        part.cards.append(leaf_card(center, along, normal, r))


def add_subbranch(
    rnd: Rand, part: Part, anchor: np.ndarray, direction: np.ndarray, length: float, side0: int
) -> None:
    """A sub-branch with alternate twigs (every ~6.5 cm from 12% of its length, plus one at the
    tip), each twig with its leaves."""
    pts = polyline(rnd, anchor, direction, length, 4, math.radians(12.0), math.radians(4.0))
    part.add_tube(pts, np.linspace(0.014, 0.005, len(pts)), 5)
    arc = arc_lengths(pts)
    positions = list(np.arange(0.12 * arc[-1], arc[-1] - 0.03, 0.065)) + [arc[-1]]
    for j, s in enumerate(positions):
        p, t = point_at(pts, s)
        sv, uv = side_frame(t)
        side = 1.0 if (j + side0) % 2 == 0 else -1.0
        tip = j == len(positions) - 1
        beta = 0.0 if tip else math.radians(rnd.uniform(40.0, 60.0))
        psi = math.radians(25.0 + rnd.normal(0.0, 40.0))
        out = side * math.cos(psi) * sv + math.sin(psi) * uv
        d = unit(math.cos(beta) * t + math.sin(beta) * out)
        twig_len = rnd.uniform(0.14, 0.26)
        twig = polyline(rnd, p, d, twig_len, 2, math.radians(10.0), math.radians(5.0))
        part.add_tube(twig, np.array([0.004, 0.003, 0.0018]), 4)
        add_leaves(rnd, part, twig, j + side0)


@dataclass
class Branch:
    name: str
    height: float
    axis: np.ndarray
    axis_part: Part
    units: list[Part]
    anchors: list[float]


def make_branch(rnd: Rand, i: int, height: float, azimuth: float) -> Branch:
    t = (height - FIRST_BRANCH_HEIGHT) / (LAST_BRANCH_HEIGHT - FIRST_BRANCH_HEIGHT)
    polar = math.radians(76.0 - 30.0 * t + rnd.uniform(-4.0, 4.0))
    length = 3.5 * (0.5 + 0.5 * math.sin(math.pi * (0.25 + 0.75 * t))) * rnd.uniform(0.92, 1.08)
    d0 = np.array(
        [math.sin(polar) * math.cos(azimuth), math.sin(polar) * math.sin(azimuth), math.cos(polar)]
    )
    n_seg = 16
    axis = polyline(
        rnd,
        np.array([0.0, 0.0, height]),
        d0,
        length,
        n_seg,
        math.radians(18.0),
        math.radians(3.0),
    )
    r0 = 0.55 * trunk_radius(height)
    axis_part = Part()
    axis_part.add_tube(axis, np.linspace(r0, 0.012, len(axis)), 6)
    arc = arc_lengths(axis)
    total = float(arc[-1])
    anchors: list[float] = []
    s = 0.30 * total
    while s < 0.95 * total:
        anchors.append(s)
        s += 0.13 * rnd.uniform(0.75, 1.25)
    anchors.append(total)  # the terminal unit continues the axis
    units = []
    for j, s in enumerate(anchors):
        p, tan = point_at(axis, s)
        sv, uv = side_frame(tan)
        part = Part()
        if j == len(anchors) - 1:
            d, sub_len = tan, 0.5
        else:
            side = 1.0 if j % 2 == 0 else -1.0
            psi = math.radians(20.0 + rnd.normal(0.0, 35.0))
            out = unit(side * math.cos(psi) * sv + math.sin(psi) * uv)
            beta = math.radians(rnd.uniform(40.0, 60.0))
            d = unit(math.cos(beta) * tan + math.sin(beta) * out)
            sub_len = (0.6 + 0.6 * (1.0 - s / total)) * rnd.uniform(0.85, 1.15)
        add_subbranch(rnd, part, p, d, sub_len, j)
        units.append(part)
    return Branch(f"branch_{i:02d}", height, axis, axis_part, units, anchors)


def make_tree(seed: int = SEED) -> tuple[Part, list[Branch]]:
    rnd = Rand(seed)
    zs = np.concatenate([[0.0, 0.1, 0.25], np.linspace(0.5, TRUNK_HEIGHT, 17)])
    trunk_pts = np.column_stack([np.zeros_like(zs), np.zeros_like(zs), zs])
    trunk = Part()
    trunk.add_tube(trunk_pts, np.array([trunk_radius(z) for z in zs]), 6)
    ratio = 0.88
    gaps = ratio ** np.arange(N_BRANCHES - 1)
    heights = FIRST_BRANCH_HEIGHT + (LAST_BRANCH_HEIGHT - FIRST_BRANCH_HEIGHT) * np.concatenate(
        [[0.0], np.cumsum(gaps) / gaps.sum()]
    )
    phi0 = rnd.uniform(0.0, 2.0 * math.pi)
    branches = []
    for i, h in enumerate(heights):
        az = phi0 + math.radians(DIVERGENCE_DEG * i + rnd.uniform(-10.0, 10.0))
        branches.append(make_branch(rnd, i, float(h), az))
    return trunk, branches


# ------------------------------------------------------------------------------ writing


def _round(x: np.ndarray) -> np.ndarray:
    return np.round(np.asarray(x, dtype=np.float64), DECIMALS) + 0.0


def _num(x: float) -> str:
    s = f"{x:.{DECIMALS}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _vline(v: np.ndarray) -> str:
    return f"v {_num(v[0])} {_num(v[1])} {_num(v[2])}"


def render(seed: int = SEED) -> dict[str, bytes]:
    """The three files' contents: ``{"obj": ..., "mtl": ..., "json": ...}``."""
    trunk, branches = make_tree(seed)
    vert_blocks: list[np.ndarray] = []
    n_verts = 0

    def place(part_verts: list[np.ndarray]) -> int:
        nonlocal n_verts
        base = n_verts
        for v in part_verts:
            vert_blocks.append(v)
            n_verts += len(v)
        return base

    groups: list[tuple[str, bool, list[str]]] = []  # name, is_leaf, face lines

    def faces(quads: list[np.ndarray], base: int) -> list[str]:
        return [
            "f " + " ".join(str(int(i) + 1 + base) for i in q) for block in quads for q in block
        ]

    base = place(trunk.verts)
    groups.append(("trunk", False, faces(trunk.quads, base)))
    meta = []
    leaf_groups = []
    n_leaves_total = 0
    top = 0.0
    for br in branches:
        lines: list[str] = []
        base = place(br.axis_part.verts)
        lines += faces(br.axis_part.quads, base)
        unit_tris, unit_leaves = [], []
        leaf_lines: list[str] = []
        for part in br.units:
            base = place(part.verts)
            lines += faces(part.quads, base)
            unit_tris.append(2 * part.n_quads)
            cards = np.array(part.cards)
            base = place([cards.reshape(-1, 3)])
            leaf_lines += [
                "f " + " ".join(str(base + 4 * k + j + 1) for j in range(4))
                for k in range(len(cards))
            ]
            unit_leaves.append(len(cards))
            top = max(top, float(cards[:, :, 2].max()))
        groups.append((br.name, False, lines))
        leaf_groups.append((f"leaves_{br.name}", True, leaf_lines))
        n_leaves_total += sum(unit_leaves)
        meta.append(
            {
                "name": br.name,
                "bark_group": br.name,
                "leaf_group": f"leaves_{br.name}",
                "height": float(_round(br.height)),
                "axis": _round(br.axis).tolist(),
                "axis_bark_triangles": 2 * br.axis_part.n_quads,
                "subbranch_anchors": _round(np.array(br.anchors)).tolist(),
                "subbranch_bark_triangles": unit_tris,
                "subbranch_leaves": unit_leaves,
                "axis_tube": br.axis_part.skeleton()[0],
                "subbranch_tubes": [part.skeleton() for part in br.units],
            }
        )
    groups += leaf_groups
    verts = _round(np.concatenate(vert_blocks))
    height = float(_round(max(top, float(verts[:, 2].max()))))

    head = [
        f"# batecho reference tree, generated by tools/make_reference_tree.py (seed {seed})",
        f"# {n_leaves_total} leaves as rhombic quad cards, {N_BRANCHES} first-level branches, "
        f"height {height:.2f} m; z up, metres",
        "# structure (branch axes, sub-branch anchors): reference_tree.json",
        f"mtllib {NAME}.mtl",
    ]
    body = [_vline(v) for v in verts]
    for name, _, lines in groups:
        body += [f"g {name}", f"usemtl {name}", *lines]
    obj = ("\n".join(head + body) + "\n").encode("ascii")

    mtl_lines = ["# batecho reference tree materials"]
    for name, leafy, _ in groups:
        rgb = _LEAF_RGB if leafy else _BARK_RGB
        mtl_lines += ["", f"newmtl {name}", "Kd {:g} {:g} {:g}".format(*rgb), "d 1", "illum 1"]
    mtl = ("\n".join(mtl_lines) + "\n").encode("ascii")

    doc = {
        "format": "batecho-reference-tree",
        "version": 1,
        "generator": "tools/make_reference_tree.py",
        "seed": seed,
        "units": "m",
        "up": "z",
        "obj": f"{NAME}.obj",
        "height": height,
        "n_leaves": n_leaves_total,
        "trunk": {
            "bark_group": "trunk",
            "base": [0.0, 0.0, 0.0],
            "top": [0.0, 0.0, TRUNK_HEIGHT],
            "tube": trunk.skeleton()[0],
        },
        "branches": meta,
        "conventions": (
            "Each branch's bark group lists the axis tube's triangles first "
            "(axis_bark_triangles, each OBJ quad counts as two), then one block per sub-branch "
            "unit (subbranch_bark_triangles), in file order; its leaf group lists the units' "
            "leaves in the same order (subbranch_leaves). Anchors are arc lengths (m) along the "
            "axis polyline from its first point, which lies on the trunk axis."
        ),
    }
    js = (json.dumps(doc, indent=1, sort_keys=True) + "\n").encode("ascii")
    return {"obj": obj, "mtl": mtl, "json": js}


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def write(out_dir: str | Path, seed: int = SEED) -> dict[str, Path]:
    """Write ``reference_tree.{obj,mtl,json}`` into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for ext, data in render(seed).items():
        p = out / f"{NAME}.{ext}"
        p.write_bytes(data)
        paths[ext] = p
    return paths


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output folder")
    ap.add_argument(
        "--check", action="store_true", help="compare with the files in --out; write nothing"
    )
    args = ap.parse_args(argv)
    files = render()
    status = 0
    for ext, data in files.items():
        p = args.out / f"{NAME}.{ext}"
        if args.check:
            same = p.exists() and p.read_bytes() == data
            print(f"{p}: {'OK' if same else 'DIFFERS'}  sha256 {sha256(data)}")
            status |= not same
        else:
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(data)
            print(f"wrote {p} ({len(data)} bytes)  sha256 {sha256(data)}")
    return int(status)


if __name__ == "__main__":
    sys.exit(main())
