"""Random generators from the ``rng`` arguments of the public functions, their independent
children, and the record that reproduces a draw."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np


def _is_int_seed(rng: Any) -> bool:
    return isinstance(rng, numbers.Integral) and not isinstance(rng, bool)


def generator(rng: Any) -> np.random.Generator:
    """``rng`` itself if it is a Generator, else ``numpy.random.default_rng(rng)`` for an int
    seed (>= 0; ValueError for a negative one), a SeedSequence or None; TypeError for anything
    else."""
    if isinstance(rng, np.random.Generator):
        return rng
    if _is_int_seed(rng) and rng < 0:
        raise ValueError(f"rng must be a non-negative int seed (or a numpy Generator), got {rng!r}")
    if rng is None or _is_int_seed(rng) or isinstance(rng, np.random.SeedSequence):
        return np.random.default_rng(rng)
    raise TypeError(f"rng must be a numpy Generator, an int seed or None, got {rng!r}")


def int_seed(rng: Any) -> int | None:
    """The int seed ``rng`` is, or None."""
    return int(rng) if _is_int_seed(rng) else None


def seed_record(rng: Any, gen: np.random.Generator) -> dict[str, Any]:
    """What reproduces a draw: the int seed (if one was given) and the bit generator state."""
    return {"seed": int_seed(rng), "rng_state": gen.bit_generator.state}


def spawn(gen: np.random.Generator, n: int) -> list[np.random.Generator]:
    """``gen.spawn(n)`` (also on NumPy < 1.25): children of its bit generator's SeedSequence."""
    if hasattr(gen, "spawn"):
        return list(gen.spawn(n))
    bg = gen.bit_generator
    seq = getattr(bg, "seed_seq", None) or bg._seed_seq  # type: ignore[attr-defined]
    return [np.random.Generator(type(bg)(s)) for s in seq.spawn(n)]
