"""Input checks shared by the public classes and functions: clear exceptions, and copies,
never views of the caller's arrays."""

from __future__ import annotations

import numbers
from collections.abc import Iterable
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
    """``arr`` itself; ValueError naming the first entry that is NaN or infinite."""
    bad = ~np.isfinite(arr)
    if bad.any():
        where = tuple(int(k) for k in np.argwhere(bad)[0])
        raise ValueError(
            f"{name} must be finite; entry {where} is {arr[where]}"
            + (f" (row {where[0]})" if arr.ndim > 1 else "")
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


#: The shortest and longest direction vectors normalised (as the core's ``MIN_NORM`` and
#: ``MAX_NORM``): within them ``|v|^2`` is a normal float64 with room to spare, so ``v / |v|``
#: is a unit vector to a few ulp. Shorter or longer ones are refused where they enter.
MIN_NORM = 1e-150
MAX_NORM = 1e150


def unit_rows(v: np.ndarray, name: str, what: str = "row") -> np.ndarray:
    """``v / |v|`` row by row (``|v|`` summed as the core does); ValueError naming the first
    row whose length is outside [:data:`MIN_NORM`, :data:`MAX_NORM`] (zero included)."""
    with np.errstate(over="ignore", under="ignore"):
        length = np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])
    bad = ~((length >= MIN_NORM) & (length <= MAX_NORM))
    if bad.any():
        i = int(np.argmax(bad))
        big = float(np.abs(v[i]).max())
        true = big * float(np.linalg.norm(v[i] / big)) if big > 0 else 0.0
        raise ValueError(
            f"{what} {i}: {name} {v[i]} has length {true:.3g}, outside "
            f"[{MIN_NORM:g}, {MAX_NORM:g}]: zero, or too short or long to normalise in float64 "
            "without losing precision; give a direction of ordinary length"
        )
    return v / length[:, None]


def point3(x: Any, name: str) -> np.ndarray:
    """A new finite (3,) float64 vector from anything with three entries."""
    try:
        v = np.array(x, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a 3-vector of real numbers, got {x!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name} must be a finite 3-vector, got {x!r}")
    return v


def python_value(x: Any) -> Any:
    """``x`` with NumPy scalars as Python numbers and arrays and lists as tuples (nested), other
    values as they are: a parameter kept so compares, hashes and writes as JSON as the same
    value given in Python does."""
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        x = x.tolist()
    if isinstance(x, (list, tuple)):
        return tuple(python_value(v) for v in x)
    return x


def keep_python_values(obj: Any, names: Iterable[str]) -> None:
    """Set the fields ``names`` of the frozen dataclass ``obj`` to their :func:`python_value`."""
    for name in names:
        object.__setattr__(obj, name, python_value(getattr(obj, name)))


def readonly(arr: np.ndarray) -> np.ndarray:
    """``arr`` itself, made read-only."""
    arr.setflags(write=False)
    return arr


def frozen(a: Any, dtype: Any = np.float64) -> np.ndarray:
    """A read-only C-contiguous array of ``dtype`` that shares no memory with ``a``."""
    out = np.ascontiguousarray(a, dtype=dtype)
    if out is a or out.base is not None:
        out = out.copy()
    out.setflags(write=False)
    return out


def _number(x: Any, name: str, strict: bool) -> float:
    # (a flag is never a number: True would be taken as 1)
    if isinstance(x, (bool, np.bool_)) or (strict and not isinstance(x, numbers.Real)):
        raise TypeError(f"{name} must be a real number, got {x!r}")
    try:
        return float(x)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {x!r}") from None


def positive_scalar(
    x: Any, name: str, allow_zero: bool = False, *, strict: bool = False, unit: str = ""
) -> float:
    """``x`` as a finite float > 0 (>= 0 with ``allow_zero``). A bool is refused with
    TypeError, and with ``strict`` anything but a real number (strings included); ``unit`` is
    named in the message."""
    v = _number(x, name, strict)
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        op = ">=" if allow_zero else ">"
        raise ValueError(f"{name} must be finite and {op} 0{' ' + unit if unit else ''}, got {x!r}")
    return v


def finite_scalar(x: Any, name: str, *, strict: bool = False) -> float:
    """``x`` as a finite float; ``strict`` as in :func:`positive_scalar`."""
    v = _number(x, name, strict)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return v


def flag(x: Any, name: str) -> bool:
    """``x`` as a bool; TypeError for anything but a bool (NumPy's included), so that text such
    as ``"no"`` is refused rather than taken as true."""
    if not isinstance(x, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {x!r}")
    return bool(x)


def integer(x: Any, name: str, minimum: int = 0, *, wrong_type: type = ValueError) -> int:
    """``x`` as an int >= ``minimum``. A bool or a non-integer raises ``wrong_type``, a
    smaller integer ValueError."""
    if isinstance(x, bool) or not isinstance(x, numbers.Integral):
        raise wrong_type(f"{name} must be an integer >= {minimum}, got {x!r}")
    if x < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {x!r}")
    return int(x)
