"""Where results are written: output folders checked before any work and made when needed,
write errors that name the file they were writing, and a standard output whose reader left."""

from __future__ import annotations

import errno
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "check_output_file",
    "check_output_folder",
    "make_output_folder",
    "stdout_reader_left",
    "writing",
]


def check_output_folder(path: str | os.PathLike) -> Path:
    """Refuse, before anything is made or computed, an output folder that cannot be made:
    ``path``, or one of the folders above it, is a file (:class:`NotADirectoryError` naming
    it). Nothing is created."""
    p = Path(path)
    for q in (p, *p.parents):
        if q.is_dir():
            break
        if q.exists():
            what = "is a file, not a folder" if q == p else f"cannot be made: {q} is a file"
            raise NotADirectoryError(errno.ENOTDIR, f"the output folder {what}", str(p))
    return p


def make_output_folder(path: str | os.PathLike) -> Path:
    """The output folder ``path``, made with its parents if missing (see
    :func:`check_output_folder` for what is refused)."""
    p = check_output_folder(path)
    p.mkdir(parents=True, exist_ok=True)
    return p


def check_output_file(path: str | os.PathLike) -> Path:
    """Refuse, before anything is computed, an output file that cannot be written: ``path``
    is a folder (:class:`IsADirectoryError`), or its folder cannot be made (see
    :func:`check_output_folder`). Nothing is created."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(errno.EISDIR, "the output file is a folder", str(p))
    check_output_folder(p.parent)
    return p


@contextmanager
def writing(path: str | os.PathLike) -> Iterator[None]:
    """An :class:`OSError` raised without a file name while writing ``path`` (a full disk)
    is raised again naming ``path``."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None and exc.errno is not None:
            raise type(exc)(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise


def stdout_reader_left() -> int:
    """After a BrokenPipeError on standard output (its reader left early, as ``| head`` does):
    the rest of the output goes to the null device, so that Python's last flush does not fail
    too. Returns the exit status, 1."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 1
