"""The memory limit: what one call may allocate before batecho refuses it with a
``MemoryError`` that names the parameter, the size and how to do the work in pieces.

The limit is one number, held by the Rust core (``budget``), which checks the sonar's tables
and ``simulate``'s outputs against it; the Python side checks what it allocates itself (leaf
boxes, flights, figures) against the same number. The default is 4 GiB
(:data:`DEFAULT_MEMORY_LIMIT_BYTES`); raise it with :func:`set_memory_limit` for large work on
a large machine, or do the work in pieces.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

from . import _core
from ._validate import integer

#: The default limit on what one call may allocate (bytes): 4 GiB, as the core's.
DEFAULT_MEMORY_LIMIT_BYTES = 4 * 2**30

#: Memory per leaf of a scene (bytes): its arrays here and in the core, and the BVH (as the
#: core's ``budget::BYTES_PER_LEAF``).
BYTES_PER_LEAF = 400.0


#: What ``simulate`` returns per pose (bytes) per band bin and per record sample, as the
#: core's ``budget::echoes_bytes``; and a pose's own arrays.
ECHO_BYTES_PER_BIN = 48.0
ECHO_BYTES_PER_SAMPLE = 16.0
BYTES_PER_POSE = 128.0


def echoes_bytes_per_pulse(n_bins: float, n_samples: float, n_receivers: int = 0) -> float:
    """Memory (bytes) one pulse's pose and echoes take: ``n_bins`` band bins, records of
    ``n_samples``, for each of ``n_receivers`` receivers of their own (0: heard at the
    emitter, one record)."""
    records = max(1, n_receivers)
    return (
        records * (ECHO_BYTES_PER_BIN * n_bins + ECHO_BYTES_PER_SAMPLE * n_samples) + BYTES_PER_POSE
    )


class SlowWarning(UserWarning):
    """A call that will run for minutes: it says so before it starts, with its estimate and
    how to make it shorter."""


#: A call expected to run longer than this (s) warns with :class:`SlowWarning` first.
SLOW_S = 60.0


def warn_if_slow(seconds: float, what: str, shorter: str, stacklevel: int = 2) -> bool:
    """Warn with :class:`SlowWarning` when ``seconds`` (an estimate) is over :data:`SLOW_S`:
    ``what`` takes about so many minutes, and ``shorter`` says how to make it shorter.
    ``stacklevel`` as for :func:`warnings.warn` from the caller. Whether it warned."""
    if not seconds > SLOW_S:
        return False
    warnings.warn(
        f"{what} takes about {seconds / 60:.0f} min; {shorter}",
        SlowWarning,
        stacklevel=stacklevel + 1,
    )
    return True


def memory_limit() -> int:
    """The limit in force (bytes) on what one call may allocate."""
    return int(_core.memory_limit())


def set_memory_limit(nbytes: Any) -> int:
    """Set the limit (bytes, at least 1 MiB; None restores the default of 4 GiB) on what one
    call may allocate; returns the previous limit. The limit is process-wide."""
    if nbytes is None:
        nbytes = DEFAULT_MEMORY_LIMIT_BYTES
    n = integer(nbytes, "nbytes", minimum=2**20, wrong_type=TypeError)
    return int(_core.set_memory_limit(n))


def human_bytes(nbytes: float) -> str:
    """A size for people, in binary units as the limit is set: ``"4.0 GiB"``, ``"512.0 MiB"``
    (as the core writes it); beyond a million TiB in three digits, ``"9.09e+287 TiB"``
    (an absurd request's size in full would be hundreds of digits long)."""
    if nbytes >= 2.0**60:
        return f"{nbytes / 2.0**40:.3g} TiB"
    for name, scale in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20), ("KiB", 2.0**10)):
        if nbytes >= scale:
            return f"{nbytes / scale:.1f} {name}"
    return f"{nbytes:.0f} bytes"


def check_memory(nbytes: float, what: str, pieces: str) -> None:
    """Refuse with ``MemoryError`` when ``nbytes`` (an estimate) is over the limit. ``what``
    names the request and its parameters, ``pieces`` says how to do the work in pieces."""
    limit = memory_limit()
    if math.isfinite(nbytes) and nbytes <= limit:
        return
    raise MemoryError(
        f"{what} needs about {human_bytes(nbytes)}, over batecho's memory limit of "
        f"{human_bytes(limit)}; {pieces} (or raise the limit with batecho.set_memory_limit)"
    )


def check_copies(**arrays: Any) -> None:
    """Refuse with ``MemoryError`` an array of ``arrays`` (name=array) whose float64 copy is
    over the limit, before it is made: a broadcast view costs nothing, its copy may."""
    for name, x in arrays.items():
        # (only arrays: a list's copy costs about what the list already holds, and taking its
        # shape would convert it once more)
        shape = getattr(x, "shape", None)
        if not isinstance(shape, tuple):
            continue
        size = math.prod(shape)
        check_memory(8.0 * size, f"a copy of {name} of shape {shape}", "pass less at once")


__all__ = [
    "BYTES_PER_LEAF",
    "BYTES_PER_POSE",
    "DEFAULT_MEMORY_LIMIT_BYTES",
    "ECHO_BYTES_PER_BIN",
    "ECHO_BYTES_PER_SAMPLE",
    "SLOW_S",
    "SlowWarning",
    "check_copies",
    "check_memory",
    "echoes_bytes_per_pulse",
    "human_bytes",
    "memory_limit",
    "set_memory_limit",
    "warn_if_slow",
]
