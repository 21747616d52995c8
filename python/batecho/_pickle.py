"""Pickling (by processes, Dask workers and ``copy.deepcopy`` alike) of frozen dataclasses
that hold Rust objects, which do not pickle: such a dataclass travels as the arguments that
made it and is made again on loading; and of objects whose arrays are read-only, which are
made read-only again on loading."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from contextlib import contextmanager
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
        self._check_loaded()

    def _check_loaded(self) -> None:
        """Raise ValueError if the loaded state is not one the class makes (pickles can be
        edited); a hook, checking nothing unless a class says what to check."""


@contextmanager
def refused_on_loading(obj: Any) -> Iterator[None]:
    """The TypeErrors and ValueErrors of checking ``obj``'s loaded state, as a ValueError
    naming its class."""
    try:
        yield
    except (TypeError, ValueError) as exc:
        raise ValueError(f"refusing this pickled {type(obj).__name__}: {exc}") from None


def loaded_arrays(obj: Any, names: tuple[str, ...]) -> list[np.ndarray]:
    """``obj``'s loaded attributes ``names``, each a float64 array; ValueError otherwise."""
    out = []
    for name in names:
        value = getattr(obj, name, None)
        if not isinstance(value, np.ndarray) or value.dtype != np.float64:
            what = value.dtype if isinstance(value, np.ndarray) else type(value).__name__
            raise ValueError(
                f"refusing this pickled {type(obj).__name__}: its {name.lstrip('_')} is "
                f"{what}, not a float64 array"
            )
        out.append(value)
    return out
