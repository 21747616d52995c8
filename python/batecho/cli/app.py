"""The ``batecho`` command line's parser and entry point: ``demo``, ``simulate``, ``paper
figures``, ``paper table1`` and ``dataset``. User errors (bad arguments, a bad scene file, a
missing file) and the file system's errors (a path that is a file, not a folder, unwritable,
a full disk) print one line naming the problem, and the path, and exit with status 2,
without a traceback."""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

from ..echoes.simulate import DEFAULT_METHOD, DEFAULT_TOL, METHODS
from ..forest.models import TREE_MODELS
from ..outputs.files import stdout_reader_left
from ..scenefile.schema import MAX_DPI
from .commands import UserError, run_demo, run_paper_figures, run_paper_table1, run_simulate

EPILOG = """\
examples:
  batecho demo --out demo-out              a forest, a flown circle, plots and data
  batecho simulate examples/flight.toml    a scene and flight described in TOML
  batecho paper figures --out paper-figs   the paper's Figures 5-10 (in spirit)
  batecho paper table1 --points 1,5 --trees 1,2 --out table1.md
  batecho dataset --help                   echo datasets for learning

Run "batecho COMMAND --help" for the options of each command. Units: metres, seconds,
degrees; results are NPZ files (numpy.load) holding every parameter needed to rerun them.
"""


def _int_list(text: str) -> list[int]:
    try:
        vals = [int(v) for v in text.replace(" ", "").split(",") if v]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected integers separated by commas (e.g. 1,5,10), got {text!r}"
        ) from None
    if not vals or any(v < 1 for v in vals):
        raise argparse.ArgumentTypeError(f"expected integers >= 1, got {text!r}")
    return vals


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return v


def _dpi(text: str) -> int:
    v = _positive_int(text)
    if v > MAX_DPI:
        raise argparse.ArgumentTypeError(
            f"at most {MAX_DPI} dots per inch (print quality is 300-600), got {text!r}"
        )
    return v


def _seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 0 <= v < 2**128:
        raise argparse.ArgumentTypeError(f"a seed is an integer in [0, 2^128), got {text!r}")
    return v


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v > 0.0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a number > 0, got {text!r}")
    return v


def _beamwidth(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of degrees, got {text!r}") from None
    if not 0.0 < v < 180.0:
        raise argparse.ArgumentTypeError(f"the beamwidth must be in (0, 180) deg, got {text!r}")
    return v


# ---------------------------------------------------------------------------- dataset


def _dataset_missing(reason: str) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        raise UserError(
            f"the dataset command is not available in this installation ({reason}); "
            "install batecho with its dataset extras, or update it"
        )

    return run


def _add_dataset(sub, wanted: bool) -> None:
    """Hook in ``batecho.dataset.cli`` -- imported only when the command is ``dataset``."""
    reason = "not requested"
    if wanted:
        try:
            from ..dataset.cli import add_subparser
        except ImportError as exc:
            reason = f"cannot import batecho.dataset.cli: {exc}"
        else:
            add_subparser(sub)
            return
    p = sub.add_parser(
        "dataset",
        help="generate datasets of echoes along flights (see batecho dataset --help)",
        add_help=False,
    )
    p.add_argument("args", nargs=argparse.REMAINDER)
    p.set_defaults(func=_dataset_missing(reason))


# ----------------------------------------------------------------------------- parser


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The argument parser (``argv`` tells whether the dataset command must be loaded)."""
    from .._core import __version__

    fmt = argparse.RawDescriptionHelpFormatter
    p = argparse.ArgumentParser(
        prog="batecho",
        description="Foliage echoes for bat-inspired sonar: forests, flights, impulse "
        "responses (Tanveer et al.; Ming et al. 2017).",
        epilog=EPILOG,
        formatter_class=fmt,
    )
    p.add_argument("--version", action="version", version=f"batecho {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    d = sub.add_parser(
        "demo",
        help="simulate a small forest and a flight; write plots and data",
        description="Ming's canonical leaf box (canonical_*.png/.npz), then a few trees from "
        "the paper's IPP and a Crazyflie circling them at 5 m (6.2 m out, or wider to keep "
        "0.5 m from every crown) with its sonar looking at the centre: scene_3d.png, "
        "impulses.png, echo_image.png, spectrogram.png and echoes.npz. The scene file it ran is "
        "written as demo.toml.",
        epilog="example:\n  batecho demo --out demo-out --trees 2 --beamwidth 20",
        formatter_class=fmt,
    )
    d.add_argument("--out", default="demo-out", help="output folder (default: demo-out)")
    d.add_argument("--seed", type=_seed, default=2017, help="random seed (default: 2017)")
    d.add_argument("--trees", type=_positive_int, default=3, help="number of trees (default 3)")
    d.add_argument(
        "--beamwidth", type=_beamwidth, default=30.0, help="sonar beamwidth, deg (default 30)"
    )
    d.add_argument(
        "--quadrotor",
        choices=("crazyflie", "research", "none"),
        default="crazyflie",
        help="airframe flown (default crazyflie); none: kinematic pulse positions",
    )
    d.add_argument(
        "--pulse-rate",
        type=_positive_float,
        default=5.0,
        help="pulses per second when flown (default 5)",
    )
    d.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    d.set_defaults(func=run_demo)

    s = sub.add_parser(
        "simulate",
        help="simulate a scene and flight described in a TOML file",
        description="Simulate the scene, sonar and flight of a TOML scene file and write "
        "echoes.npz and the plots of its [output] table. Tables: [scene] (kind = leaf_box, "
        "obj, tree or forest), [sonar] (any batecho.Sonar parameter), [flight] (path = "
        "circle, line, figure_eight or waypoints; mode = kinematic or flown; n_pulses or "
        "pulse_rate_hz; [flight.mount]), [call] and [output]. See examples/flight.toml and, "
        "for two ears and a call, examples/two_ears.toml.",
        epilog="examples:\n  batecho simulate examples/flight.toml --out flight-out\n"
        "  batecho simulate my-scene.toml --seed 3 --no-plots\n"
        "  batecho simulate examples/two_ears.toml --wav --mat",
        formatter_class=fmt,
    )
    s.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    s.add_argument("--out", help="output folder (default: ./SCENE-out, named after the file)")
    s.add_argument("--seed", type=_seed, help="override the file's seed")
    s.add_argument("--no-plots", action="store_true", help="write the NPZ only")
    s.add_argument("--wav", action="store_true", help="also write echoes.wav ([output] wav = true)")
    s.add_argument("--mat", action="store_true", help="also write echoes.mat ([output] mat = true)")
    s.add_argument(
        "--xarray",
        action="store_true",
        help="also write echoes.zarr, the xarray Dataset ([output] xarray = true)",
    )
    s.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=run_simulate)

    pp = sub.add_parser(
        "paper",
        help="rerun the paper's experiments (figures, Table 1)",
        description="The experiments of Tanveer et al.: Figures 5-10 and Table 1.",
        epilog="examples:\n  batecho paper figures --out paper-figs\n"
        "  batecho paper table1 --repeats 3 --out table1.md",
        formatter_class=fmt,
    )
    psub = pp.add_subparsers(dest="paper_command", required=True, metavar="EXPERIMENT")
    pf = psub.add_parser(
        "figures",
        help="write Figures 5-10 (in spirit) as PNG",
        description="One tree with a pose whose lobe holds no leaf (its echo is exactly zero, "
        "Fig. 5) and one facing the crown (Figs. 6-7, beams of 10, 20, 50 deg); two trees "
        "with the circle at 5 m (the paper's 6.2 m, widened where needed to keep 0.5 m from "
        "every crown) and 4 sample points (Figs. 8-9); two and three trees "
        "with 15 points (Fig. 10); echo images around the circle; a straight run toward a "
        "tree. Also paper_figures.npz with the data behind them.",
        formatter_class=fmt,
    )
    pf.add_argument("--out", default="paper-figures", help="output folder")
    pf.add_argument("--seed", type=_seed, default=2021, help="random seed (default 2021)")
    pf.add_argument(
        "--echo-pulses",
        type=_positive_int,
        default=72,
        help="pulses in the echo images around the circle (default 72)",
    )
    pf.add_argument(
        "--dpi", type=_dpi, default=110, help=f"PNG resolution, at most {MAX_DPI} (default 110)"
    )
    pf.add_argument(
        "--tree-model",
        choices=tuple(TREE_MODELS),
        default="grow_tree",
        help="grow_tree: L-system branching + reference CAD branches (the paper's way, "
        "default); lsystem: the authors' ginkgo L-system",
    )
    pf.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    pf.set_defaults(func=run_paper_figures)
    pt = psub.add_parser(
        "table1",
        help="time a whole circle for 1-15 pulses and 1-5 trees, beside the paper's Table 1",
        description="For T trees from the paper's IPP (conditioned on T), a circle at 5 m "
        "around their mean position (the paper's 6.2 m, widened where needed to keep 0.5 m "
        "from every crown) and N pulses at equal angles, time the impulse "
        "computation of the whole circle (one batecho.simulate call) and count the leaves. "
        "Prints a Markdown table beside the paper's MATLAB times, with the settings to rerun.",
        epilog="example:\n  batecho paper table1 --points 1,5 --trees 1,2 --repeats 2",
        formatter_class=fmt,
    )
    pt.add_argument(
        "--points",
        type=_int_list,
        default=[1, 5, 10, 15],
        help="pulse counts on the circle (default 1,5,10,15)",
    )
    pt.add_argument(
        "--trees",
        type=_int_list,
        default=[1, 2, 3, 4, 5],
        help="numbers of trees (default 1,2,3,4,5)",
    )
    pt.add_argument(
        "--repeats",
        type=_positive_int,
        default=3,
        help="forests per number of trees, averaged (default 3)",
    )
    pt.add_argument(
        "--timing-runs",
        type=_positive_int,
        default=3,
        help="simulate calls per cell, the fastest kept (default 3)",
    )
    pt.add_argument("--seed", type=_seed, default=2021, help="random seed (default 2021)")
    pt.add_argument(
        "--beamwidth",
        type=_beamwidth,
        default=50.0,
        help="sonar beamwidth, deg (default 50, the paper's widest)",
    )
    pt.add_argument(
        "--heading",
        choices=("center", "velocity"),
        default="center",
        help="sonar looks at the centre (default) or along the circle",
    )
    pt.add_argument(
        "--method",
        choices=METHODS,
        default=DEFAULT_METHOD,
        help="batecho.simulate method: exact (every leaf-bin term), fast (NUFFT within --tol) "
        f"or auto (the cheaper of the two per pulse); default {DEFAULT_METHOD}",
    )
    pt.add_argument(
        "--tol",
        type=_positive_float,
        default=DEFAULT_TOL,
        help=f"tolerance of fast/auto ({DEFAULT_TOL:g})",
    )
    pt.add_argument("--out", help="also write the Markdown table to this file")
    pt.add_argument("--npz", help="also write the raw timings and settings to this NPZ")
    pt.add_argument(
        "--tree-model",
        choices=tuple(TREE_MODELS),
        default="grow_tree",
        help="grow_tree: L-system branching + reference CAD branches (the paper's way, "
        "default); lsystem: the authors' ginkgo L-system",
    )
    pt.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    pt.set_defaults(func=run_paper_table1)

    args = list(sys.argv[1:] if argv is None else argv)
    wanted = next((a for a in args if not a.startswith("-")), None) == "dataset"
    _add_dataset(sub, wanted)
    return p


def _warning_printer(name: str, fallback: Callable[..., None]) -> Callable[..., None]:
    """``warnings.showwarning`` that prints batecho's own warnings as one line,
    ``batecho NAME: warning: ...``, and others as Python does. batecho's own are its warning
    classes and any warning raised from its code (a dataset's damaged chunk): the user has
    no use for the file and line of batecho's source that raised it."""
    from .._resources import SlowWarning
    from ..forest.clearance import ClearanceWarning
    from ..forest.ipp import IPPWarning
    from ..trees.objfile import ObjWarning

    ours = (ClearanceWarning, ObjWarning, SlowWarning, IPPWarning)
    package = Path(__file__).resolve().parents[1]

    def show(message, category, filename, lineno, file=None, line=None) -> None:
        if issubclass(category, ours) or package in Path(filename).resolve().parents:
            print(f"batecho {name}: warning: {message}", file=file or sys.stderr)
        else:
            fallback(message, category, filename, lineno, file, line)

    return show


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 2 user error)."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(args_list)
    try:
        args = parser.parse_args(args_list)
    except SystemExit as exc:  # --help, --version, or an argparse error (status 2)
        return int(exc.code or 0) if not isinstance(exc.code, str) else 2
    from ..scenefile.schema import ScenefileError

    name = args.command + (f" {args.paper_command}" if args.command == "paper" else "")
    try:
        from ..forest.clearance import ClearanceWarning

        with warnings.catch_warnings():
            warnings.simplefilter("always", ClearanceWarning)  # a run's warnings are its news
            warnings.showwarning = _warning_printer(name, warnings.showwarning)
            return int(args.func(args) or 0)
    except (
        UserError,
        ScenefileError,
        ValueError,
        TypeError,
        RuntimeError,
        MemoryError,
    ) as exc:
        print(f"batecho {name}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"batecho {name}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. "batecho paper table1 | head": the reader left
        return stdout_reader_left()
    except OSError as exc:
        print(f"batecho {name}: error: {os_error_message(exc)}", file=sys.stderr)
        return 2


def os_error_message(exc: OSError) -> str:
    """One line for a file system error: the path(s) it names, then what went wrong."""
    if exc.filename is None:
        return str(exc)
    paths = " -> ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
    return f"{paths}: {exc.strerror or exc}"


if __name__ == "__main__":
    sys.exit(main())
