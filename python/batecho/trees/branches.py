"""Branches as straight cylinder segments: starts and ends (m) and radii (m)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from .._geometry import norms
from .._pickle import ReadOnlyOnLoading, loaded_arrays, refused_on_loading
from .._resources import check_copies
from .._validate import finite, readonly, real_array, vectors
from .leaves import MAX_COORDINATE_M


class Branches(ReadOnlyOnLoading):
    """A set of ``k`` cylinder segments: a tree's woody skeleton (trunk, branches, twigs).

    Parameters
    ----------
    starts, ends : array_like, shape (k, 3)
        The end points of each segment's axis, in metres (world frame, z up); distinct.
    radii : array_like, shape (k,)
        Segment radii in metres, > 0.

    Notes
    -----
    Segments that share an end point exactly (bit for bit) are joints of one skeleton: they
    never block the rays to each other's echoes (docs/model.md §10). The caller's arrays are
    never modified or kept: ``Branches`` holds read-only float64 copies.
    """

    __slots__ = ("_ends", "_radii", "_starts")

    def __init__(self, starts: Any, ends: Any, radii: Any):
        check_copies(starts=starts, ends=ends, radii=radii)
        s = vectors(starts, "starts", allow_single=False)
        k = s.shape[0]
        if k == 0:
            raise ValueError("Branches needs at least one segment; got empty arrays")
        e = vectors(ends, "ends", k, allow_single=False)
        r = real_array(radii, "radii")
        if r.ndim != 1 or r.shape[0] != k:
            raise ValueError(f"radii must have shape ({k},), got {r.shape}")
        finite(r, "radii")
        if (r <= 0).any():
            i = int(np.argmax(r <= 0))
            raise ValueError(f"radii must be > 0; branch {i} has radius {r[i]}")
        if (r > MAX_COORDINATE_M).any():
            i = int(np.argmax(r > MAX_COORDINATE_M))
            raise ValueError(f"radii must be at most {MAX_COORDINATE_M:g} m; branch {i} has {r[i]}")
        for name, pts in (("start", s), ("end", e)):
            far = np.abs(pts) > MAX_COORDINATE_M
            if far.any():
                i = int(np.argwhere(far)[0, 0])
                raise ValueError(
                    f"branch {i} has a {name} coordinate beyond {MAX_COORDINATE_M:g} m: {pts[i]}"
                )
        length = norms(e - s)
        if not (length > 0).all():
            i = int(np.argmax(~(length > 0)))
            why = (
                f"start {s[i]} equals end {e[i]}"
                if (s[i] == e[i]).all()
                else f"start {s[i]} and end {e[i]} are so near that it underflows"
            )
            raise ValueError(f"branch {i} has zero length ({why})")
        self._starts = readonly(s)
        self._ends = readonly(e)
        self._radii = readonly(r)

    def _check_loaded(self) -> None:
        s, e, r = loaded_arrays(self, ("_starts", "_ends", "_radii"))
        with refused_on_loading(self):
            Branches(s, e, r)

    @classmethod
    def _trusted(cls, starts: np.ndarray, ends: np.ndarray, radii: np.ndarray) -> Branches:
        """Wrap arrays that are already validated float64 (no copy)."""
        obj = cls.__new__(cls)
        obj._starts = readonly(np.ascontiguousarray(starts, dtype=np.float64))
        obj._ends = readonly(np.ascontiguousarray(ends, dtype=np.float64))
        obj._radii = readonly(np.ascontiguousarray(radii, dtype=np.float64))
        return obj

    @property
    def starts(self) -> np.ndarray:
        """(k, 3) start points, m (read-only)."""
        return self._starts

    @property
    def ends(self) -> np.ndarray:
        """(k, 3) end points, m (read-only)."""
        return self._ends

    @property
    def radii(self) -> np.ndarray:
        """(k,) radii, m (read-only)."""
        return self._radii

    @property
    def lengths(self) -> np.ndarray:
        """(k,) segment lengths, m."""
        return norms(self._ends - self._starts)

    def __len__(self) -> int:
        return self._starts.shape[0]

    def __repr__(self) -> str:
        return (
            f"Branches(n={len(self)}, length {self.lengths.sum():.3g} m, "
            f"radius {self._radii.min():.3g}..{self._radii.max():.3g} m)"
        )

    def __getitem__(self, index: Any) -> Branches:
        """A subset (integer array, boolean mask or slice)."""
        idx = np.atleast_1d(np.arange(len(self))[index])
        if idx.size == 0:
            raise ValueError("selection is empty; Branches needs at least one segment")
        return Branches._trusted(self._starts[idx], self._ends[idx], self._radii[idx])

    def transformed(
        self, rotation: Any = None, translation: Any = (0.0, 0.0, 0.0), scale: float = 1.0
    ) -> Branches:
        """Segments moved rigidly: ``x -> scale * R x + t`` (radii scale)."""
        R = np.eye(3) if rotation is None else real_array(rotation, "rotation")
        if R.shape != (3, 3):
            raise ValueError(f"rotation must be a 3x3 matrix, got shape {R.shape}")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("rotation must be a proper rotation matrix (orthonormal, det +1)")
        t = vectors(translation, "translation")[0]
        s = float(scale)
        if not (np.isfinite(s) and s > 0):
            raise ValueError(f"scale must be finite and > 0, got {scale}")
        with np.errstate(over="ignore", under="ignore"):
            moved = (s * (self._starts @ R.T) + t, s * (self._ends @ R.T) + t, self._radii * s)
        try:
            return Branches(*moved)  # checked again: a scale or shift may leave the bounds
        except ValueError as exc:
            raise ValueError(f"the segments moved by scale={s:g}, translation={t}: {exc}") from None

    @staticmethod
    def concatenate(parts: Iterable[Branches]) -> Branches:
        """All segments of ``parts``, in order."""
        parts = list(parts)
        if not parts:
            raise ValueError("concatenate needs at least one Branches")
        return Branches._trusted(
            np.concatenate([p.starts for p in parts]),
            np.concatenate([p.ends for p in parts]),
            np.concatenate([p.radii for p in parts]),
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box of the segments' axes, (min, max)."""
        both = np.concatenate([self._starts, self._ends])
        return both.min(axis=0), both.max(axis=0)

    def distance_to(self, point: Any) -> np.ndarray:
        """(k,) distance (m) from ``point`` to each segment's surface, a solid capped cylinder
        as in :meth:`Scene.clearance <batecho.Scene.clearance>` (docs/model.md §6); inside, minus
        the depth to the nearest face (side or cap)."""
        p = vectors(point, "point")[0]
        length = self.lengths
        u = (self._ends - self._starts) / length[:, None]
        m = p - self._starts
        along = np.einsum("ij,ij->i", m, u)
        rho = norms(m - along[:, None] * u)
        axial = np.maximum(np.maximum(-along, along - length), 0.0)
        radial = np.maximum(rho - self._radii, 0.0)
        depth = np.minimum(self._radii - rho, np.minimum(along, length - along))
        return np.where((axial > 0) | (radial > 0), np.hypot(axial, radial), 0.0 - depth)


__all__: Sequence[str] = ["Branches"]
