"""``batecho dataset ...``: generate, verify and inspect echo datasets.

    batecho dataset generate SPEC.toml OUT.zarr [--scheduler ADDR] [--workers N] [-q]
    batecho dataset verify OUT.zarr [--quick]
    batecho dataset show OUT.zarr          # the stored spec and how much is done
    batecho dataset template               # a spec with every key at its default

Also runs as ``python -m batecho.dataset.cli ...``. Exit status: 0 success, 1 the store
failed verification, 2 bad input (spec, store, arguments).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

__all__ = ["add_subparser", "build_parser", "main"]


def _configure(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="dataset_command", required=True, metavar="ACTION")
    g = sub.add_parser(
        "generate",
        help="generate (or resume) a dataset into a Zarr store",
        description="Draw the samples of SPEC, simulate their echoes and write them to OUT "
        "(a Zarr store). Runs on this machine in worker processes, or on a Dask cluster with "
        "--scheduler. Rerunning on an unfinished store writes only the missing chunks.",
    )
    g.add_argument("spec", help="dataset spec (TOML)")
    g.add_argument("out", help="output Zarr store (path or URL)")
    g.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="Dask scheduler address (e.g. tcp://10.0.0.1:8786); its workers must reach OUT",
    )
    g.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="local worker processes (default: one per CPU; 1 runs in this process)",
    )
    g.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    v = sub.add_parser(
        "verify",
        help="check that a store is complete and intact",
        description="Check that STORE is a batecho dataset, that its spec matches its hash, "
        "that every chunk is marked complete and (unless --quick) that every chunk's data "
        "matches its checksum.",
    )
    v.add_argument("store", help="Zarr store (path or URL)")
    v.add_argument("--quick", action="store_true", help="check markers only, not the data")
    s = sub.add_parser("show", help="print a store's spec and progress")
    s.add_argument("store", help="Zarr store (path or URL)")
    sub.add_parser("template", help="print a spec with every key at its default")


def add_subparser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``dataset`` to the ``batecho`` command's subparsers; sets ``func=main``."""
    p = subparsers.add_parser(
        "dataset",
        help="generate and verify echo datasets (Zarr, local or Dask)",
        description="Echo datasets at scale: generate SPEC.toml into a Zarr store on this "
        "machine or a Dask cluster, verify it, inspect it.",
    )
    _configure(p)
    p.set_defaults(func=main)
    return p


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="batecho dataset",
        description="Echo datasets at scale: generate, verify and inspect Zarr stores.",
    )
    _configure(p)
    return p


class _Terminated(KeyboardInterrupt):
    """SIGTERM during ``generate``: stopped as Ctrl-C stops it (workers shut down, one line)."""


def _raise_terminated(signum: int, frame: Any) -> None:
    raise _Terminated


def _generate(args: argparse.Namespace) -> int:
    import signal
    import threading

    from .pipeline import generate
    from .spec import DatasetSpec

    spec = DatasetSpec.from_toml(args.spec)
    main_thread = threading.current_thread() is threading.main_thread()
    before = signal.signal(signal.SIGTERM, _raise_terminated) if main_thread else None
    try:
        report = generate(
            spec,
            args.out,
            client=args.scheduler,
            workers=args.workers,
            progress=not args.quiet,
        )
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, before)
    print(report.summary())
    return 0


def _verify(args: argparse.Namespace) -> int:
    from .store import DatasetError, verify

    try:
        report = verify(args.store, deep=not args.quick)
    except DatasetError as exc:
        print(f"batecho dataset verify: FAILED: {exc}", file=sys.stderr)
        return 1
    print(report.summary())
    return 0


def _show(args: argparse.Namespace) -> int:
    import numpy as np

    from .store import _open_group, _read_markers, read_spec

    g = _open_group(args.store, mode="r")
    spec = read_spec(args.store, g)
    markers = _read_markers(g, spec.n_chunks)
    done = int(np.count_nonzero(markers))
    print(
        f"# {args.store}: {done}/{spec.n_chunks} chunks complete "
        f"({spec.n_samples} samples x {spec.pulses_per_sample} pulses), "
        f"spec sha256 {spec.sha256}"
    )
    print(spec.to_toml(), end="")
    return 0


def _template(args: argparse.Namespace) -> int:
    from .spec import DatasetSpec

    print(DatasetSpec().to_toml(full=True), end="")
    return 0


_ACTIONS = {"generate": _generate, "verify": _verify, "show": _show, "template": _template}


def main(args: argparse.Namespace | Sequence[str] | None = None) -> int:
    """Run ``batecho dataset``: ``args`` is the parsed namespace (from :func:`add_subparser`)
    or the arguments after ``dataset`` (default ``sys.argv[1:]``). Returns the exit status."""
    if not isinstance(args, argparse.Namespace):
        args = build_parser().parse_args(sys.argv[1:] if args is None else list(args))
    action = args.dataset_command
    try:
        return _ACTIONS[action](args)
    except BrokenPipeError:  # e.g. "batecho dataset show STORE | head": the reader left
        from ..outputs.files import stdout_reader_left

        return stdout_reader_left()
    # Bad spec or store (ValueError), a chunk that failed (RuntimeError), no scheduler or no
    # file (OSError), a missing optional package (ImportError): one line, no traceback.
    except (ValueError, TypeError, RuntimeError, OSError, ImportError) as exc:
        print(f"batecho dataset {action}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        print(
            f"batecho dataset {action}: interrupted; complete chunks are kept, run the same "
            "command again to finish",
            file=sys.stderr,
        )
        return 143 if isinstance(exc, _Terminated) else 130


if __name__ == "__main__":
    sys.exit(main())
