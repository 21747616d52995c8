"""Forests: trees placed on the ground, at positions from an inhomogeneous Poisson process.

A :class:`Forest` holds tree *variants* (each a :class:`~batecho.trees.Tree` around its own
base) and, per tree, a ground position (x, y) (m), a turn about the vertical through its base
(degrees) and a size factor: tree ``i`` is ``variants[variant_index[i]]`` moved by
``x -> (x_i, y_i, z_base) + scale_i * Rz(rotation_i) (x - base)``. Leaf radii keep their size
(``scale_leaves=False``: leaf size is a trait of the species, not of the tree's size).

With ``variants=k`` a forest grows ``k`` trees once and reuses them (instancing): a forest of
millions of leaves then builds in seconds, and only the placed leaves are held (for
:meth:`Forest.scene`); the bark is built only when asked for (:meth:`Forest.bark`), and so
are the trees' woody skeletons (:attr:`Forest.branches`, for ``scene(branches=True)``).

Seeds: ``from_ipp`` splits its ``rng`` into three child generators (``rng.spawn(3)``, i.e. the
generator's ``SeedSequence`` children 0, 1, 2 for a fresh generator): positions, placement
(rotations, then sizes, then the variant assignment) and trees; ``from_positions`` into two
(placement, trees). Tree ``j`` (or variant ``j``) is grown from child ``j`` of the trees'
generator, so it does not depend on how many trees are grown or in which order.
"""

from __future__ import annotations

import numbers
import os
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._geometry import rot_z
from .._pickle import ReadOnlyOnLoading
from .._random import generator, int_seed, spawn
from .._resources import BYTES_PER_LEAF, check_memory, warn_if_slow
from .._validate import finite_scalar, flag, integer, positive_scalar, real_array, vectors
from ..trees.branches import Branches
from ..trees.grow import grow_tree
from ..trees.leaves import Leaves
from ..trees.objfile import write_obj
from ..trees.tree import Tree
from .clearance import DEFAULT_MIN_CLEARANCE_M, BarkGrid
from .ipp import PAPER_WINDOW, _as_window, paper_intensity, sample_ipp
from .scene import Scene

__all__ = ["Forest"]

TreeFactory = Callable[..., Tree]


def guard_forest(t: int, n_grow: int, leaves_per_tree: int, first_s: float) -> None:
    """Before growing the rest of a forest: its leaves must fit the memory limit, those of its
    ``t`` placed trees and of its ``n_grow`` grown ones alike, and a growth of more than a minute
    says so first (:class:`batecho._resources.SlowWarning`)."""
    check_memory(
        max(t, n_grow) * leaves_per_tree * BYTES_PER_LEAF,
        f"a forest of {t} trees from {n_grow} grown, of about {leaves_per_tree} leaves",
        "use fewer trees (a smaller window or intensity, n_trees), fewer variants or smaller trees",
    )
    warn_if_slow(
        n_grow * first_s,
        f"growing {n_grow} trees ({first_s:.2g} s for the first)",
        "pass variants=k to grow k and reuse them",
        stacklevel=4,
    )


class Forest(ReadOnlyOnLoading):
    """Trees placed on the ground (see the module docstring).

    Parameters
    ----------
    variants : sequence of Tree
        The distinct trees.
    positions : (t, 2) array_like
        Ground positions of the trees' bases, m.
    rotations_deg : (t,) array_like, optional
        Turns about the vertical, degrees (default 0).
    scales : (t,) array_like, optional
        Size factors, > 0 (default 1).
    variant_index : (t,) int array_like, optional
        Which variant stands at each position (default ``0, 1, ..., t-1``: one variant each).
    window, intensity : optional
        The region and intensity the positions were drawn from (kept for plots).
    scale_leaves : bool
        Scale the leaf radii with the trees (default False).
    params : dict, optional
        How the forest was made (kept as ``.params``).
    """

    def __init__(
        self,
        variants: Sequence[Tree],
        positions: Any,
        rotations_deg: Any = None,
        scales: Any = None,
        variant_index: Any = None,
        *,
        window: Any = None,
        intensity: Any = None,
        scale_leaves: bool = False,
        params: Mapping[str, Any] | None = None,
    ):
        vs = tuple(variants)
        for i, v in enumerate(vs):
            if not isinstance(v, Tree):
                raise TypeError(f"variants[{i}] must be a Tree, got {type(v).__name__}")
        pos = _ground_positions(positions)
        t = len(pos)
        rot = np.zeros(t) if rotations_deg is None else real_array(rotations_deg, "rotations_deg")
        sc = np.ones(t) if scales is None else real_array(scales, "scales")
        if rot.shape != (t,) or not np.isfinite(rot).all():
            raise ValueError(f"rotations_deg must be {t} finite angles (degrees)")
        if sc.shape != (t,) or not (np.isfinite(sc).all() and (sc > 0).all()):
            raise ValueError(f"scales must be {t} finite factors > 0")
        if variant_index is None:
            if len(vs) != t:
                raise ValueError(
                    f"{len(vs)} variants for {t} positions: give variant_index to reuse them"
                )
            vi = np.arange(t)
        else:
            vi = np.array(variant_index)
            if vi.dtype.kind not in "iu" or vi.shape != (t,):
                raise ValueError(f"variant_index must be {t} integers")
            if t and (vi.min() < 0 or vi.max() >= len(vs)):
                raise ValueError(f"variant_index must lie in [0, {len(vs)})")
        if t and not vs:
            raise ValueError("a forest with trees needs at least one variant")
        self._variants = vs
        self._positions = pos
        self._rotations = rot
        self._scales = sc
        self._vi = vi.astype(np.int64)
        for a in (self._positions, self._rotations, self._scales, self._vi):
            a.setflags(write=False)
        self.window = None if window is None else _as_window(window)
        self.intensity = intensity
        self.scale_leaves = flag(scale_leaves, "scale_leaves")
        self.params: dict[str, Any] = dict(params or {})
        self._leaves: Leaves | None = None
        self._scene: Scene | None = None
        self._wood_scene: Scene | None = None
        self._branches: Branches | None = None
        self._bark: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._bark_grid: BarkGrid | None = None

    # -- construction ---------------------------------------------------------------------------

    @classmethod
    def from_positions(
        cls,
        positions: Any,
        rng: np.random.Generator | int | None,
        tree: TreeFactory | Tree = grow_tree,
        tree_params: Mapping[str, Any] | None = None,
        variants: int | None = None,
        scale_sd: float = 0.0,
        *,
        window: Any = None,
        intensity: Any = None,
        scale_leaves: bool = False,
    ) -> Forest:
        """Trees at the given ground positions (t, 2) m, each turned by a uniform random angle
        about the vertical and scaled by ``exp(scale_sd * z)``, z ~ N(0, 1) (``scale_sd = 0``:
        all full size). ``tree`` is a function ``tree(rng, **tree_params) -> Tree`` (default
        :func:`~batecho.trees.grow_tree`) or one Tree to stand everywhere (then without
        ``tree_params`` or ``variants``, which it refuses). ``variants=None``
        grows one tree per position; ``variants=k`` grows ``k`` and reuses them, assigned by a
        random permutation of ``0, 1, ..., k-1, 0, 1, ...`` (all used when ``t >= k``)."""
        gen, seed = generator(rng), int_seed(rng)
        place, trees = spawn(gen, 2)
        return cls._build(
            positions,
            place,
            trees,
            tree,
            tree_params,
            variants,
            scale_sd,
            window=window,
            intensity=intensity,
            scale_leaves=scale_leaves,
            params={"seed": seed, "scheme": "from_positions"},
        )

    @classmethod
    def from_ipp(
        cls,
        intensity: Any,
        window: Any,
        rng: np.random.Generator | int | None,
        tree: TreeFactory | Tree = grow_tree,
        tree_params: Mapping[str, Any] | None = None,
        variants: int | None = None,
        scale_sd: float = 0.0,
        lambda_max: float | None = None,
        *,
        scale_leaves: bool = False,
    ) -> Forest:
        """Trees at the points of an inhomogeneous Poisson process with ``intensity`` (trees
        per m², a callable ``f(x, y)``) on ``window`` (see :func:`~batecho.forest.ipp.sample_ipp`),
        then as :meth:`from_positions`."""
        gen, seed = generator(rng), int_seed(rng)
        pos_gen, place, trees = spawn(gen, 3)
        positions = sample_ipp(intensity, window, pos_gen, lambda_max=lambda_max)
        return cls._build(
            positions,
            place,
            trees,
            tree,
            tree_params,
            variants,
            scale_sd,
            window=window,
            intensity=intensity,
            scale_leaves=scale_leaves,
            params={"seed": seed, "scheme": "from_ipp", "lambda_max": lambda_max},
        )

    @classmethod
    def paper_example(
        cls,
        rng: np.random.Generator | int | None,
        tree: TreeFactory | Tree = grow_tree,
        tree_params: Mapping[str, Any] | None = None,
        variants: int | None = None,
        scale_sd: float = 0.0,
    ) -> Forest:
        """The paper's forest: :func:`~batecho.forest.ipp.paper_intensity` (two
        squared-exponential clumps, about 6.6 trees expected) on the 20 m x 20 m
        :data:`~batecho.forest.ipp.PAPER_WINDOW`."""
        return cls.from_ipp(
            paper_intensity(), PAPER_WINDOW, rng, tree, tree_params, variants, scale_sd
        )

    @classmethod
    def _build(
        cls,
        positions: Any,
        place: np.random.Generator,
        tree_gen: np.random.Generator,
        tree: TreeFactory | Tree,
        tree_params: Mapping[str, Any] | None,
        variants: int | None,
        scale_sd: float,
        *,
        window: Any,
        intensity: Any,
        scale_leaves: bool,
        params: dict[str, Any],
    ) -> Forest:
        pos = _ground_positions(positions)  # (checked before any tree grows)
        t = len(pos)
        sd = positive_scalar(scale_sd, "scale_sd", allow_zero=True, strict=True)
        if variants is not None:
            integer(variants, "variants", 1)
        if tree_params is not None and not isinstance(tree_params, Mapping):
            raise TypeError(f"tree_params must be a mapping, got {type(tree_params).__name__}")
        rotations = place.uniform(0.0, 360.0, t)
        with np.errstate(over="ignore", under="ignore"):
            scales = np.exp(sd * place.standard_normal(t))
        bad = ~(np.isfinite(scales) & (scales > 0))
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"scale_sd = {scale_sd!r} makes tree {i}'s size factor exp(scale_sd * z) "
                f"{scales[i]!r}, outside float64's positive numbers; use a scale_sd nearer 0"
            )
        if isinstance(tree, Tree):
            # (one Tree stands everywhere as it is: nothing is grown, so nothing to apply these to)
            if tree_params:
                raise ValueError(
                    f"tree_params {dict(tree_params)!r} are for a tree function; tree is one Tree, "
                    "which stands everywhere as it is (pass tree=grow_tree or your function)"
                )
            if variants is not None:
                raise ValueError(
                    f"variants = {variants!r} is for a tree function; tree is one Tree, which "
                    "stands everywhere as it is (pass tree=grow_tree or your function)"
                )
            vs: list[Tree] = [tree]
            vi = np.zeros(t, np.int64)
            name = "Tree"
        elif callable(tree):
            k = t if variants is None else int(variants)
            n_grow = min(k, t) if variants is None else k
            vi = np.arange(t) if variants is None else place.permutation(np.arange(t) % k)
            kwargs = dict(tree_params or {})
            # The first tree alone, to size the rest before growing them (the children of a
            # generator spawned one, then n - 1, are those spawned n at once).
            t0 = time.perf_counter()
            vs = [tree(g, **kwargs) for g in spawn(tree_gen, 1)] if n_grow else []
            if n_grow:
                _check_grown(vs[0], 0)
                guard_forest(t, n_grow, vs[0].n_leaves, time.perf_counter() - t0)
            for i, g in enumerate(spawn(tree_gen, n_grow - 1) if n_grow > 1 else [], start=1):
                vs.append(_check_grown(tree(g, **kwargs), i))
            name = getattr(tree, "__name__", type(tree).__name__)
        else:
            raise TypeError(f"tree must be a Tree or a function returning one, got {tree!r}")
        params = {
            **params,
            "tree": name,
            "tree_params": dict(tree_params or {}),
            "variants": None if variants is None else int(variants),
            "scale_sd": float(scale_sd),
        }
        return cls(
            vs,
            pos,
            rotations,
            scales,
            vi,
            window=window,
            intensity=intensity,
            scale_leaves=scale_leaves,
            params=params,
        )

    # -- placement ------------------------------------------------------------------------------

    @property
    def positions(self) -> np.ndarray:
        """(t, 2) ground positions of the trees' bases, m (read-only)."""
        return self._positions

    @property
    def rotations_deg(self) -> np.ndarray:
        """(t,) turns about the vertical, degrees (read-only)."""
        return self._rotations

    @property
    def scales(self) -> np.ndarray:
        """(t,) size factors (read-only)."""
        return self._scales

    @property
    def variant_index(self) -> np.ndarray:
        """(t,) the variant standing at each position (read-only)."""
        return self._vi

    @property
    def variants(self) -> tuple[Tree, ...]:
        """The distinct trees, each around its own base."""
        return self._variants

    @property
    def trees(self) -> list[Tree]:
        """One Tree per position, unplaced (the shared variant objects); see :meth:`placed`."""
        return [self._variants[i] for i in self._vi]

    @property
    def n_trees(self) -> int:
        return len(self._positions)

    def __len__(self) -> int:
        return self.n_trees

    @property
    def n_leaves(self) -> int:
        return int(sum(self._variants[i].n_leaves for i in self._vi))

    @property
    def mean_position(self) -> np.ndarray:
        """(2,) mean of the tree positions, m: the centre of the paper's circular flights."""
        if self.n_trees == 0:
            raise ValueError("the forest has no trees")
        return self._positions.mean(axis=0)

    def _move(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(rotation, base, translation, scale) of tree ``i``: x -> b + s R (x - b) + t."""
        v = self._variants[self._vi[i]]
        b = v.base
        t = np.array([self._positions[i, 0] - b[0], self._positions[i, 1] - b[1], 0.0])
        return rot_z(float(self._rotations[i])), b, t, float(self._scales[i])

    def placed(self, i: int) -> Tree:
        """Tree ``i`` in place (a new Tree)."""
        if isinstance(i, bool) or not isinstance(i, numbers.Integral):
            raise TypeError(f"tree index must be an integer, got {i!r}")
        if not -self.n_trees <= i < self.n_trees:
            raise IndexError(f"tree {i} out of range for {self.n_trees} trees")
        i %= self.n_trees
        v = self._variants[self._vi[i]]
        b = v.base
        return v.transformed(
            float(self._rotations[i]),
            (self._positions[i, 0] - b[0], self._positions[i, 1] - b[1], 0.0),
            float(self._scales[i]),
            scale_leaves=self.scale_leaves,
        )

    @property
    def crown_radii(self) -> np.ndarray:
        """(t,) each tree's largest horizontal leaf distance from its trunk axis, m."""
        r = np.array([v.crown_radius for v in self._variants])
        return r[self._vi] * self._scales if self.n_trees else np.zeros(0)

    @property
    def trunk_bases(self) -> np.ndarray:
        """(t, 3) trunk bases in place, m."""
        z = np.array([v.base[2] for v in self._variants])
        return np.column_stack([self._positions, z[self._vi]]) if self.n_trees else np.zeros((0, 3))

    @property
    def trunk_tops(self) -> np.ndarray:
        """(t, 3) trunk tops in place, m."""
        if not self.n_trees:
            return np.zeros((0, 3))
        h = np.array([v.trunk_top[2] - v.base[2] for v in self._variants])
        out = self.trunk_bases.copy()
        out[:, 2] += h[self._vi] * self._scales
        return out

    # -- geometry -------------------------------------------------------------------------------

    @property
    def leaves(self) -> Leaves:
        """All leaves, tree by tree in position order (built once)."""
        if self._leaves is None:
            if self.n_trees == 0:
                raise ValueError("the forest has no trees, hence no leaves")
            n = self.n_leaves
            c = np.empty((n, 3))
            nv = np.empty((n, 3))
            r = np.empty(n)
            k = 0
            for i in range(self.n_trees):
                lv = self._variants[self._vi[i]].leaves
                rot, b, t, s = self._move(i)
                m = len(lv)
                c[k : k + m] = (lv.centers - b) @ (s * rot.T) + (b + t)
                nv[k : k + m] = lv.normals @ rot.T
                r[k : k + m] = lv.radii * s if self.scale_leaves else lv.radii
                k += m
            self._leaves = Leaves._trusted(c, nv, r)
        return self._leaves

    @property
    def branches(self) -> Branches | None:
        """The woody skeletons of all trees in place, tree by tree in position order (built
        once; radii scale with each tree), or None where no tree has one (OBJ trees)."""
        if self._branches is None:
            starts, ends, radii = [], [], []
            for i in range(self.n_trees):
                wood = self._variants[self._vi[i]].branches
                if wood is None:
                    continue
                rot, b, t, s = self._move(i)
                starts.append((wood.starts - b) @ (s * rot.T) + (b + t))
                ends.append((wood.ends - b) @ (s * rot.T) + (b + t))
                radii.append(wood.radii * s)
            if not starts:
                return None
            self._branches = Branches._trusted(
                np.concatenate(starts), np.concatenate(ends), np.concatenate(radii)
            )
        return self._branches

    def scene(self, branches: bool = False) -> Scene:
        """The :class:`~batecho.Scene` of all leaves (built once); with ``branches=True``, of
        the leaves and the trees' woody skeletons (:attr:`branches`), which then echo and may
        block (docs/model.md §9-§10). The default is the paper's model: leaves alone."""
        if not flag(branches, "branches"):
            if self._scene is None:
                self._scene = Scene(self.leaves)
            return self._scene
        if self._wood_scene is None:
            leaves = self.leaves  # (a forest without trees says so)
            wood = self.branches
            if wood is None:
                raise ValueError(
                    "no tree of this forest has a woody skeleton (trees loaded from OBJ files "
                    "have silent wood; give them one with Tree.with_branches), so "
                    "scene(branches=True) has no branches to place"
                )
            self._wood_scene = Scene(leaves, branches=wood)
        return self._wood_scene

    def reaches(self, altitude: float | None = None, band: float = 0.0) -> np.ndarray:
        """(t,) each tree's horizontal reach from its trunk axis, m: the farthest its leaf
        disks (centre plus radius) and bark triangles extend, as placed and scaled. With
        ``altitude`` (m), only the parts that come within ``band`` (m) of that height count
        (a disk spans its centre's height +- its radius, a triangle its corners' heights)."""
        if altitude is not None:
            altitude = finite_scalar(altitude, "altitude")
        band = positive_scalar(band, "band", allow_zero=True)
        out = np.zeros(self.n_trees)
        for i in range(self.n_trees):
            v = self._variants[self._vi[i]]
            s = float(self._scales[i])
            bz = float(v.base[2])
            c = v.leaves.centers
            a = v.leaves.radii * (s if self.scale_leaves else 1.0)
            rho = s * np.hypot(c[:, 0] - v.base[0], c[:, 1] - v.base[1]) + a
            if altitude is not None:
                z = bz + s * (c[:, 2] - bz)
                rho = rho[np.abs(z - altitude) < band + a]
            tri = v.bark_vertices[v.bark_faces]
            trho = s * np.hypot(tri[..., 0] - v.base[0], tri[..., 1] - v.base[1]).max(axis=1)
            if altitude is not None:
                z = bz + s * (tri[..., 2] - bz)
                trho = trho[(z.min(axis=1) < altitude + band) & (z.max(axis=1) > altitude - band)]
            out[i] = max(rho.max(initial=0.0), trho.max(initial=0.0))
        return out

    def clear_circle_radius(
        self,
        center: Any,
        min_radius: float,
        margin: float = DEFAULT_MIN_CLEARANCE_M,
        altitude: float | None = None,
    ) -> float:
        """The smallest radius ``>= min_radius`` (m) of a horizontal circle about ``center``
        (x, y) that passes at least ``margin`` (m) from every tree: tree ``i`` at horizontal
        distance ``d_i`` from the centre rules out the radii in
        ``(d_i - reach_i - margin, d_i + reach_i + margin)``, with ``reach_i`` its reach
        (:meth:`reaches`) over all its parts, or, given the circle's ``altitude`` (m), over
        the parts within ``margin`` of that height."""
        c = real_array(center, "center")
        if c.shape != (2,) or not np.isfinite(c).all():
            raise ValueError(f"center must be a finite (x, y), m; got {center!r}")
        r = positive_scalar(min_radius, "min_radius", allow_zero=True, strict=True, unit="m")
        m = positive_scalar(margin, "margin", allow_zero=True, strict=True, unit="m")
        d = np.hypot(self._positions[:, 0] - c[0], self._positions[:, 1] - c[1])
        reach = self.reaches(altitude, m)
        lo, hi = d - reach - m, d + reach + m
        while True:
            inside = (lo < r) & (r < hi)
            if not inside.any():
                return r
            r = float(hi[inside].max())

    def clearance(self, points: Any, *, bark: bool = True) -> np.ndarray:
        """Distance (m) from each point (n, 3) to the nearest part of the placed forest: its
        leaf disks (:meth:`Scene.clearance`, on the BVH) and, with ``bark``, its bark
        triangles (:func:`~batecho.forest.clearance.bark_clearance`). Returns (n,) float64;
        a forest without trees (a Poisson draw may hold none) is ``inf`` away."""
        from .clearance import solid_clearance

        bark = flag(bark, "bark")
        if self.n_trees == 0:
            return np.full(len(vectors(points, "points")), np.inf)
        return solid_clearance(self, points, bark=bark).distance

    def bark(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """All bark in place: vertices (v, 3) m, triangles (f, 3) int64 and the tree of each
        triangle (f,) (built once, on first call)."""
        if self._bark is None:
            verts, faces, owner = [], [], []
            n = 0
            for i in range(self.n_trees):
                v = self._variants[self._vi[i]]
                rot, b, t, s = self._move(i)
                verts.append((v.bark_vertices - b) @ (s * rot.T) + (b + t))
                faces.append(v.bark_faces + n)
                owner.append(np.full(len(v.bark_faces), i, np.int64))
                n += len(v.bark_vertices)
            if verts:
                self._bark = (np.concatenate(verts), np.concatenate(faces), np.concatenate(owner))
            else:
                self._bark = (np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64))
            for a in self._bark:
                a.setflags(write=False)
        return self._bark

    def bark_grid(self) -> BarkGrid:
        """The bark triangles filed by horizontal cells for nearest-triangle queries
        (:class:`~batecho.forest.clearance.BarkGrid`; built once, on first call)."""
        if self._bark_grid is None:
            v, f = self.bark()[:2]
            self._bark_grid = BarkGrid(v, f)
        return self._bark_grid

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box ``(min, max)`` of all leaf disks and bark, m."""
        if self.n_trees == 0:
            raise ValueError("the forest has no trees")
        lv = self.leaves
        ext = lv.radii[:, None] * np.sqrt(np.clip(1.0 - lv.normals**2, 0.0, None))
        lo = [(lv.centers - ext).min(axis=0)]
        hi = [(lv.centers + ext).max(axis=0)]
        hulls = [_hull_points(v.bark_vertices) for v in self._variants]
        for i in range(self.n_trees):
            h = hulls[self._vi[i]]
            if len(h):
                rot, b, t, s = self._move(i)
                p = (h - b) @ (s * rot.T) + (b + t)
                lo.append(p.min(axis=0))
                hi.append(p.max(axis=0))
        return np.min(lo, axis=0), np.max(hi, axis=0)

    def to_obj(self, path: str | os.PathLike, sides: int = 8, mtl: bool = True) -> Path:
        """Write the whole forest as one OBJ (+ MTL): bark groups ``tree_000_trunk``,
        ``tree_000_branch_00``, ... and leaf groups ``tree_000_leaves``, ... (leaves as
        ``sides``-gon cards). Returns the path."""
        verts, faces, _ = self.bark()
        names: list[str] = []
        groups = np.zeros(len(faces), np.int64)
        k = 0
        for i in range(self.n_trees):
            v = self._variants[self._vi[i]]
            m = len(v.bark_faces)
            groups[k : k + m] = v.bark_groups + len(names)
            names += [f"tree_{i:03d}_{g}" for g in v.bark_group_names]
            k += m
        counts = [self._variants[i].n_leaves for i in self._vi]
        return write_obj(
            path,
            verts,
            faces,
            self.leaves,
            bark_groups=groups,
            bark_group_names=names or None,
            leaf_groups=np.repeat(np.arange(self.n_trees), counts),
            leaf_group_names=[f"tree_{i:03d}_leaves" for i in range(self.n_trees)],
            sides=sides,
            mtl=mtl,
            comment=f"batecho forest: {self.n_trees} trees, {self.n_leaves} leaves",
        )

    def __repr__(self) -> str:
        return (
            f"Forest(n_trees={self.n_trees}, variants={len(self._variants)}, "
            f"n_leaves={self.n_leaves})"
        )


def _check_grown(v: Any, i: int) -> Tree:
    """``v``, call ``i``'s result of a tree function; TypeError unless it is a Tree."""
    if not isinstance(v, Tree):
        raise TypeError(f"tree(...) must return a Tree; call {i} gave {type(v)}")
    return v


def _ground_positions(positions: Any) -> np.ndarray:
    """A new finite (t, 2) float64 array of ground positions (m); an empty one is (0, 2)."""
    pos = real_array(positions, "positions")
    if pos.size == 0:
        pos = pos.reshape(0, 2)
    if pos.ndim != 2 or pos.shape[1] != 2:
        raise ValueError(f"positions must have shape (t, 2), got {pos.shape}")
    if not np.isfinite(pos).all():
        raise ValueError("positions must be finite")
    return pos


def _hull_points(points: np.ndarray) -> np.ndarray:
    """Points whose rotations about z bound the whole set: the xy convex hull's vertices at
    the lowest and the highest z of the set."""
    if len(points) < 4:
        return points
    from scipy.spatial import ConvexHull

    try:
        idx = ConvexHull(points[:, :2]).vertices
    except Exception:  # flat or degenerate sets (scipy's QhullError)
        return points
    xy = points[idx, :2]
    z0, z1 = points[:, 2].min(), points[:, 2].max()
    return np.concatenate(
        [np.column_stack([xy, np.full(len(xy), z0)]), np.column_stack([xy, np.full(len(xy), z1)])]
    )
