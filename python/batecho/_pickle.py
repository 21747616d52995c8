"""Pickling (by processes, Dask workers and ``copy.deepcopy`` alike) of frozen dataclasses
that hold Rust objects, which do not pickle: such a dataclass travels as the arguments that
made it and is made again on loading; and of objects whose arrays are read-only, which are
made read-only again on loading."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np


def remake(cls: type, params: dict[str, Any]) -> Any:
    """An object made again from its pickled arguments."""
    return cls(**params)


class MadeAgainOnLoading:
    """Mixin for a frozen dataclass whose ``__post_init__`` builds what it holds from its
    ``init`` fields."""

    def _init_parameters(self) -> dict[str, Any]:
        """The keyword arguments that make this object again."""
        fields = dataclasses.fields(self)  # type: ignore[arg-type]
        return {f.name: getattr(self, f.name) for f in fields if f.init}

    def __reduce__(self) -> tuple[Any, ...]:
        return (remake, (type(self), self._init_parameters()))


def _read_only(value: Any) -> Any:
    """``value``, made read-only if it is an array or a tuple holding arrays."""
    if isinstance(value, np.ndarray):
        value.setflags(write=False)
    elif isinstance(value, tuple):
        for v in value:
            _read_only(v)
    return value


class ReadOnlyOnLoading:
    """Mixin for a class whose arrays are read-only: pickle and ``copy.deepcopy`` make arrays
    writeable again, so loading makes them read-only as the original's were."""

    __slots__ = ()

    def __setstate__(self, state: Any) -> None:
        # the instance dict, or (dict or None, slots) for a class with __slots__
        for part in state if isinstance(state, tuple) else (state,):
            for name, value in (part or {}).items():
                object.__setattr__(self, name, _read_only(value))
