"""Sonar poses: pulse positions with an orthonormal frame (forward, up, left = up x forward)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .._geometry import crosses, dots, norms
from .._pickle import ReadOnlyOnLoading, loaded_arrays, refused_on_loading
from .._resources import check_copies, check_memory
from .._validate import readonly, real_array, unit_rows, vectors

#: What building the frames of one pose takes at its peak (bytes): the copies, the frames and
#: the temporaries of :class:`Poses` (measured 209-233), and of :func:`look_at` before them.
BUILD_BYTES_PER_POSE = 256.0
LOOK_AT_BYTES_PER_POSE = 96.0


def _check_build(p: int, extra: float = 0.0) -> None:
    check_memory(
        p * (BUILD_BYTES_PER_POSE + extra),
        f"the frames of {p} poses",
        "make the poses in pieces and simulate each",
    )


class Poses(ReadOnlyOnLoading):
    """``p`` sonar poses.

    Parameters
    ----------
    positions : array_like, shape (p, 3) or (3,)
        Pulse positions in metres.
    forward : array_like, shape (p, 3) or (3,)
        Beam axis directions (any non-zero length).
    up : array_like, shape (p, 3) or (3,), default (0, 0, 1)
        Up hint, re-orthogonalised against ``forward``; must not be parallel to it.

    Notes
    -----
    Azimuth is positive toward ``left = up x forward`` and elevation positive toward ``up``.
    """

    __slots__ = ("_forward", "_left", "_positions", "_up")

    def __init__(self, positions: Any, forward: Any, up: Any = (0.0, 0.0, 1.0)):
        check_copies(positions=positions, forward=forward, up=up)
        pos = vectors(positions, "positions")
        p = pos.shape[0]
        if p == 0:
            raise ValueError("Poses needs at least one pose; got empty arrays")
        _check_build(p)
        f = vectors(forward, "forward", p)
        u = vectors(up, "up", p)
        d = unit_rows(f, "forward", "pose")
        unit_rows(u, "up", "pose")  # (only its length is checked here)
        ud = dots(u, d)
        uo = u - ud[:, None] * d
        nu = norms(uo)
        bad = ~(nu > 1e-9 * norms(u))
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"pose {i}: up vector {u[i]} is parallel to forward {f[i]} (or zero); "
                "pass an up vector that is not along the beam axis"
            )
        uu = uo / nu[:, None]
        self._positions = readonly(pos)
        self._forward = readonly(np.ascontiguousarray(d))
        self._up = readonly(np.ascontiguousarray(uu))
        self._left = readonly(np.ascontiguousarray(crosses(uu, d)))

    def _check_loaded(self) -> None:
        pos, fwd, up, left = loaded_arrays(self, ("_positions", "_forward", "_up", "_left"))
        with refused_on_loading(self):
            made = Poses(pos, fwd, up)
            for name, got, want in (("forward", fwd, made.forward), ("up", up, made.up)):
                if got.shape != want.shape or not np.allclose(got, want, rtol=0.0, atol=1e-9):
                    raise ValueError(f"its {name} vectors are not an orthonormal frame's")
            if left.shape != made.left.shape or not np.allclose(
                left, made.left, rtol=0.0, atol=1e-9
            ):
                raise ValueError("its left vectors are not up x forward")

    @classmethod
    def _from_frames(
        cls, positions: np.ndarray, forward: np.ndarray, up: np.ndarray, left: np.ndarray
    ) -> Poses:
        obj = cls.__new__(cls)
        obj._positions = readonly(np.ascontiguousarray(positions, dtype=np.float64))
        obj._forward = readonly(np.ascontiguousarray(forward, dtype=np.float64))
        obj._up = readonly(np.ascontiguousarray(up, dtype=np.float64))
        obj._left = readonly(np.ascontiguousarray(left, dtype=np.float64))
        return obj

    @classmethod
    def from_rotations(cls, positions: Any, rotations: Any) -> Poses:
        """Poses from body rotation matrices (p, 3, 3) whose columns are (forward, left, up)."""
        check_copies(positions=positions, rotations=rotations)
        pos = vectors(positions, "positions")
        R = real_array(rotations, "rotations")
        if R.ndim == 2:
            R = R[None]
        if R.shape != (pos.shape[0], 3, 3):
            raise ValueError(f"rotations must have shape ({pos.shape[0]}, 3, 3), got {R.shape}")
        return cls(pos, R[:, :, 0], R[:, :, 2])

    @property
    def positions(self) -> np.ndarray:
        """(p, 3) positions, m."""
        return self._positions

    @property
    def forward(self) -> np.ndarray:
        """(p, 3) unit beam axes."""
        return self._forward

    @property
    def up(self) -> np.ndarray:
        """(p, 3) unit up vectors, orthogonal to forward."""
        return self._up

    @property
    def left(self) -> np.ndarray:
        """(p, 3) unit left vectors, ``up x forward``."""
        return self._left

    @property
    def rotations(self) -> np.ndarray:
        """(p, 3, 3) rotation matrices with columns (forward, left, up)."""
        return np.stack([self._forward, self._left, self._up], axis=-1)

    def __len__(self) -> int:
        return self._positions.shape[0]

    def __getitem__(self, index: Any) -> Poses:
        idx = np.atleast_1d(np.arange(len(self))[index])
        if idx.size == 0:
            raise ValueError("selection is empty; Poses needs at least one pose")
        return Poses._from_frames(
            self._positions[idx], self._forward[idx], self._up[idx], self._left[idx]
        )

    def __iter__(self):
        for i in range(len(self)):
            yield self[i]

    def __repr__(self) -> str:
        return f"Poses(p={len(self)})"

    @staticmethod
    def concatenate(parts: list[Poses]) -> Poses:
        if not parts:
            raise ValueError("concatenate needs at least one Poses")
        return Poses._from_frames(
            *(
                np.concatenate([getattr(p, a) for p in parts])
                for a in ("positions", "forward", "up", "left")
            )
        )

    def transformed(self, rotation: Any = None, translation: Any = (0.0, 0.0, 0.0)) -> Poses:
        """Poses moved rigidly: ``x -> R x + t``; the frames rotate with them."""
        R = np.eye(3) if rotation is None else real_array(rotation, "rotation")
        if R.shape != (3, 3) or not np.isfinite(R).all():
            raise ValueError(f"rotation must be a finite 3x3 matrix, got shape {R.shape}")
        if not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("rotation must be a proper rotation matrix (orthonormal, det +1)")
        t = vectors(translation, "translation")[0]
        return Poses(self._positions @ R.T + t, self._forward @ R.T, self._up @ R.T)


def look_at(positions: Any, targets: Any, up: Any = (0.0, 0.0, 1.0)) -> Poses:
    """Poses at ``positions`` whose beam axes point at ``targets`` (each (p, 3) or (3,))."""
    check_copies(positions=positions, targets=targets, up=up)
    pos = vectors(positions, "positions")
    _check_build(pos.shape[0], LOOK_AT_BYTES_PER_POSE)
    tgt = vectors(targets, "targets", pos.shape[0])
    fwd = tgt - pos
    zero = ~(norms(fwd) > 0)
    if zero.any():
        i = int(np.argmax(zero))
        raise ValueError(f"pose {i}: target {tgt[i]} coincides with the position")
    return Poses(pos, fwd, up)


__all__ = ["Poses", "look_at"]
