"""Input checks shared by the public classes: clear exceptions, and copies, never views of
the caller's arrays."""

from __future__ import annotations

from typing import Any

import numpy as np


def real_array(x: Any, name: str) -> np.ndarray:
    """``x`` as a new C-contiguous float64 array; refuses non-real dtypes with TypeError."""
    try:
        arr = np.asarray(x)
    except Exception as exc:  # ragged lists and the like
        raise TypeError(f"{name} must be an array of real numbers: {exc}") from None
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers (int or float), got dtype {arr.dtype}")
    return np.array(arr, dtype=np.float64, order="C", copy=True)


def finite(arr: np.ndarray, name: str) -> np.ndarray:
    bad = ~np.isfinite(arr)
    if bad.any():
        where = np.argwhere(bad)[0]
        idx = where[0] if arr.ndim > 0 else ()
        raise ValueError(
            f"{name} must be finite; entry {tuple(where)} is {arr[tuple(where)]}"
            + (f" (row {idx})" if arr.ndim > 1 else "")
        )
    return arr


def vectors(x: Any, name: str, n: int | None = None, allow_single: bool = True) -> np.ndarray:
    """An (n, 3) float64 array. A single (3,) vector is broadcast to n rows when n is given."""
    arr = real_array(x, name)
    if arr.ndim == 1 and allow_single:
        if arr.shape != (3,):
            raise ValueError(f"{name} must have shape (3,) or (n, 3), got {arr.shape}")
        arr = arr[None, :]
        if n is not None:
            arr = np.repeat(arr, n, axis=0)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name} has {arr.shape[0]} rows, expected {n}")
    return finite(arr, name)


def norms(v: np.ndarray) -> np.ndarray:
    """Row norms ``sqrt(x^2 + y^2 + z^2)``, summed in that order (the Rust core does the same)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def dots(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row dot products ``ax bx + ay by + az bz`` in that order (no BLAS, no FMA)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def crosses(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row cross products, component by component as in the Rust core."""
    return np.stack(
        [
            a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1],
            a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2],
            a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0],
        ],
        axis=-1,
    )


def readonly(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


def positive_scalar(x: Any, name: str, allow_zero: bool = False) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {x!r}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise ValueError(f"{name} must be finite and {'>=' if allow_zero else '>'} 0, got {x!r}")
    return v


def finite_scalar(x: Any, name: str) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {x!r}") from None
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return v
