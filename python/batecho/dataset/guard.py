"""Guards of a dataset run: the store's lock (one ``generate`` at a time per store), and the
lifeline that ends a worker process when the run that started it dies.

The lock is ``OUT.zarr.lock`` beside the store, held with ``flock`` for the whole run (the
system releases it when the process ends, however it ends; the file itself stays). It is
beside the store, not inside it, because creating a store clears its folder. Stores given as
URLs (object stores, reached by Dask workers) are not locked: their writers must be kept
apart by the user.

A worker of a local run watches the run's process (a ``pidfd`` where Linux has one, else a
poll of its pid) and exits at once when it is gone, so that a run killed with SIGKILL leaves
no worker behind writing to the store.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path
from typing import IO, Any

__all__ = ["StoreLock", "StoreLockedError", "watch_parent"]


class StoreLockedError(RuntimeError):
    """Another ``generate`` holds the store."""


class StoreLock:
    """``with StoreLock(path):`` holds ``path + ".lock"`` for the block, or raises
    :class:`StoreLockedError` naming the process that holds it."""

    def __init__(self, store: str | os.PathLike):
        self.store = Path(store)
        self.path = self.store.with_name(self.store.name + ".lock")
        self._file: IO[str] | None = None

    def __enter__(self) -> StoreLock:
        import fcntl

        self.path.parent.mkdir(parents=True, exist_ok=True)
        f = open(self.path, "a+", encoding="utf-8", errors="replace")
        try:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            f.close()
            raise StoreLockedError(
                f"{self.store} is being written by another 'batecho dataset generate' "
                f"({holder}); wait for it to end, or stop it, then run again to resume"
            ) from None
        f.seek(0)
        before = f.read(64)
        if before and not before.startswith("pid "):
            f.close()  # (a file of the user's in the lock's place is left as it was)
            raise ValueError(
                f"{self.path} exists and is not a lock of 'batecho dataset generate' (which "
                f"keeps one there while it writes {self.store}); move it away and run again"
            )
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        f.flush()
        self._file = f
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._file is not None:
            self._file.close()  # (closing releases the lock)
            self._file = None


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:  # a zombie (killed, not yet reaped) is gone too
        stat = Path(f"/proc/{pid}/stat").read_text()
        return stat[stat.rindex(")") + 2] != "Z"
    except (OSError, ValueError, IndexError):
        return True


def watch_parent(pid: int, poll_s: float = 0.25) -> None:
    """End this process (``os._exit``) as soon as process ``pid`` is gone: a daemon thread
    that waits on a pidfd of ``pid``, or polls it where pidfds are missing."""

    def wait_pidfd(fd: int) -> None:
        import select

        select.select([fd], [], [])
        os._exit(1)

    def poll() -> None:
        while _alive(pid):
            time.sleep(poll_s)
        os._exit(1)

    target: Any = poll
    args: tuple = ()
    pidfd_open = getattr(os, "pidfd_open", None)
    if pidfd_open is not None:
        try:
            fd = pidfd_open(pid)
        except OSError:
            if not _alive(pid):
                os._exit(1)
        else:
            target, args = wait_pidfd, (fd,)
    threading.Thread(target=target, args=args, name="batecho-lifeline", daemon=True).start()
