"""Leaves as circular disks: centres (m), unit normals and radii (m)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from .._geometry import norms
from .._pickle import ReadOnlyOnLoading, loaded_arrays, refused_on_loading
from .._resources import check_copies
from .._validate import finite, positive_scalar, readonly, real_array, unit_rows, vectors

#: Coordinates beyond this (m) are refused (the BVH stores f32 boxes).
MAX_COORDINATE_M = 1e15


class Leaves(ReadOnlyOnLoading):
    """A set of ``n`` leaf disks.

    Parameters
    ----------
    centers : array_like, shape (n, 3)
        Disk centres in metres (world frame, z up).
    normals : array_like, shape (n, 3)
        Disk normals, any non-zero length; they are normalised on a copy. The sign does not
        matter (the incidence angle is folded to [0, 90] degrees).
    radii : array_like, shape (n,)
        Disk radii in metres, > 0.

    Notes
    -----
    The caller's arrays are never modified or kept: ``Leaves`` holds read-only float64 copies.
    """

    __slots__ = ("_centers", "_normals", "_radii")

    def __init__(self, centers: Any, normals: Any, radii: Any):
        check_copies(centers=centers, normals=normals, radii=radii)
        c = vectors(centers, "centers", allow_single=False)
        n = c.shape[0]
        if n == 0:
            raise ValueError("Leaves needs at least one leaf; got empty arrays")
        nv = vectors(normals, "normals", n, allow_single=False)
        r = real_array(radii, "radii")
        if r.ndim != 1 or r.shape[0] != n:
            raise ValueError(f"radii must have shape ({n},), got {r.shape}")
        finite(r, "radii")
        if (r <= 0).any():
            i = int(np.argmax(r <= 0))
            raise ValueError(f"radii must be > 0; leaf {i} has radius {r[i]}")
        _check_extent(c, r)
        nv = unit_rows(nv, "normal", "leaf")
        self._centers = readonly(c)
        self._normals = readonly(np.ascontiguousarray(nv))
        self._radii = readonly(r)

    def _check_loaded(self) -> None:
        c, nv, r = loaded_arrays(self, self.__slots__)
        with refused_on_loading(self):
            Leaves(c, nv, r)
            length2 = np.einsum("ij,ij->i", nv, nv)
            off = ~(np.abs(length2 - 1.0) <= 1e-6)  # (the core's test)
            if off.any():
                i = int(np.argmax(off))
                raise ValueError(f"leaf {i}'s normal {nv[i]} is not a unit vector")

    @classmethod
    def _trusted(cls, centers: np.ndarray, normals: np.ndarray, radii: np.ndarray) -> Leaves:
        """Wrap arrays that are already validated float64 with unit normals (no copy)."""
        obj = cls.__new__(cls)
        obj._centers = readonly(np.ascontiguousarray(centers, dtype=np.float64))
        obj._normals = readonly(np.ascontiguousarray(normals, dtype=np.float64))
        obj._radii = readonly(np.ascontiguousarray(radii, dtype=np.float64))
        return obj

    @property
    def centers(self) -> np.ndarray:
        """(n, 3) centres, m (read-only)."""
        return self._centers

    @property
    def normals(self) -> np.ndarray:
        """(n, 3) unit normals (read-only)."""
        return self._normals

    @property
    def radii(self) -> np.ndarray:
        """(n,) radii, m (read-only)."""
        return self._radii

    def __len__(self) -> int:
        return self._centers.shape[0]

    @property
    def n(self) -> int:
        return len(self)

    def __repr__(self) -> str:
        lo = self._centers.min(axis=0)
        hi = self._centers.max(axis=0)
        return (
            f"Leaves(n={len(self)}, bbox=[{lo.round(3).tolist()}, {hi.round(3).tolist()}] m, "
            f"radius {self._radii.min():.3g}..{self._radii.max():.3g} m)"
        )

    def __getitem__(self, index: Any) -> Leaves:
        """A subset (integer array, boolean mask or slice)."""
        idx = np.atleast_1d(np.arange(len(self))[index])
        if idx.ndim != 1:  # (True, None or a 2-D index add an axis: the leaves' arrays would too)
            raise IndexError(
                f"Leaves index must select leaves along one axis (an int, a slice, a 1-D int "
                f"array or a boolean mask of {len(self)}); got {index!r}"
            )
        if idx.size == 0:
            raise ValueError("selection is empty; Leaves needs at least one leaf")
        return Leaves._trusted(self._centers[idx], self._normals[idx], self._radii[idx])

    def transformed(
        self, rotation: Any = None, translation: Any = (0.0, 0.0, 0.0), scale: float = 1.0
    ) -> Leaves:
        """Leaves moved rigidly: ``x -> scale * R x + t`` (normals rotate, radii scale)."""
        R = np.eye(3) if rotation is None else real_array(rotation, "rotation")
        if R.shape != (3, 3):
            raise ValueError(f"rotation must be a 3x3 matrix, got shape {R.shape}")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("rotation must be a proper rotation matrix (orthonormal, det +1)")
        t = vectors(translation, "translation")[0]
        s = positive_scalar(scale, "scale", strict=True)
        with np.errstate(over="ignore", under="ignore"):
            c = s * (self._centers @ R.T) + t
            r = self._radii * s
        try:
            _check_extent(c, r)  # a scale or shift may leave the bounds
        except ValueError as exc:
            raise ValueError(f"the leaves moved by scale={s:g}, translation={t}: {exc}") from None
        nv = self._normals @ R.T
        nv = nv / norms(nv)[:, None]
        return Leaves._trusted(c, nv, r)

    @staticmethod
    def concatenate(parts: Iterable[Leaves]) -> Leaves:
        """All leaves of ``parts``, in order."""
        parts = list(parts)
        if not parts:
            raise ValueError("concatenate needs at least one Leaves")
        for i, p in enumerate(parts):
            if not isinstance(p, Leaves):
                raise TypeError(f"concatenate takes Leaves; part {i} is {type(p).__name__}")
        return Leaves._trusted(
            np.concatenate([p.centers for p in parts]),
            np.concatenate([p.normals for p in parts]),
            np.concatenate([p.radii for p in parts]),
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box of the centres, (min, max)."""
        return self._centers.min(axis=0), self._centers.max(axis=0)


def _check_extent(c: np.ndarray, r: np.ndarray) -> None:
    """ValueError naming the first leaf whose centre (m) is not finite or lies beyond
    :data:`MAX_COORDINATE_M`, or whose radius (m) is not in (0, MAX_COORDINATE_M]."""
    bad = ~(np.abs(c) <= MAX_COORDINATE_M)
    if bad.any():
        i = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"leaf {i} has a centre coordinate beyond {MAX_COORDINATE_M:g} m: {c[i]}")
    if (r > MAX_COORDINATE_M).any():
        i = int(np.argmax(r > MAX_COORDINATE_M))
        raise ValueError(f"radii must be at most {MAX_COORDINATE_M:g} m; leaf {i} has {r[i]}")
    if (r <= 0).any():
        i = int(np.argmax(r <= 0))
        raise ValueError(f"radii must be > 0; leaf {i} has radius {r[i]}")


def as_leaves(obj: Any) -> Leaves:
    if isinstance(obj, Leaves):
        return obj
    leaves = getattr(obj, "leaves", None)
    if isinstance(leaves, Leaves):
        return leaves
    raise TypeError(f"expected Leaves (or an object with .leaves), got {type(obj).__name__}")


__all__: Sequence[str] = ["MAX_COORDINATE_M", "Leaves", "as_leaves"]
