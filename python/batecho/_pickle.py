"""Pickling of frozen dataclasses that hold Rust objects: the Rust objects do not pickle, so
such a dataclass travels as the arguments that made it and is made again on loading (by
processes, Dask workers and ``copy.deepcopy`` alike)."""

from __future__ import annotations

import dataclasses
from typing import Any


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
