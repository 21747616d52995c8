"""Equality by value for frozen dataclasses that hold arrays: the generated ``__eq__`` compares
the fields' tuples, and so arrays element by element, whose truth is ambiguous (a copy or a
loaded pickle raised ValueError instead of comparing equal)."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np


def same(a: Any, b: Any) -> bool:
    """Whether ``a`` and ``b`` hold the same values: arrays of one dtype and shape and equal
    entries (NaN equal to NaN), sequences and mappings entry by entry, anything else by
    ``==``."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        if a.dtype != b.dtype or a.shape != b.shape:
            return False
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"))
    if isinstance(a, (tuple, list)) or isinstance(b, (tuple, list)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, dict) or isinstance(b, dict):
        return type(a) is type(b) and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return bool(a == b)


class EqualByValue:
    """Mixin for a frozen dataclass (made with ``eq=False``) that holds arrays: ``==`` compares
    the fields by :meth:`_same_field` (:func:`same` unless a class says otherwise);
    unhashable, as its arrays are."""

    __slots__ = ()

    def _same_field(self, name: str, a: Any, b: Any) -> bool:
        return same(a, b)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return all(
            self._same_field(f.name, getattr(self, f.name), getattr(other, f.name))
            for f in dataclasses.fields(self)  # type: ignore[arg-type]
            if f.compare
        )

    __hash__ = None  # type: ignore[assignment]
