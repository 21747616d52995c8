"""What the ``batecho`` commands do: ``demo``, ``simulate``, ``paper figures`` and ``paper
table1``, with their progress messages and summaries."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path

DEMO_TOML = """\
# The scene and flight of "batecho demo". Rerun or change it with
#   batecho simulate demo.toml --out demo-again
seed = {seed}
description = "batecho demo: {what}"

[scene]
{scene}

[sonar]
beamwidth_deg = {beamwidth:g}
too_close = "skip"        # leave out leaves within 1 cm of a pulse instead of failing

[flight]
path = "circle"
radius = "clear"          # the smallest radius >= 6.2 m (the paper's) that keeps
                          # min_clearance_m outside every crown, around the mean tree position
altitude = {altitude:g}
heading = "center"        # the sonar looks at the centre of the circle
speed = 2.0               # m/s
{flight}
min_clearance_m = 0.5     # every pulse at least this far from leaves and bark, or refused

[output]
plots = ["scene", "impulses", "echo_image", "spectrogram"]
sample_points = 4
impulse = false           # keep echoes.npz small: impulse = 2 irfft(spectrum) (see band_bins)
"""


class UserError(Exception):
    """An error the user can fix; printed as one line, exit status 2."""


# --------------------------------------------------------------------------- progress


def say_fn(quiet: bool) -> Callable[[str], None]:
    def say(msg: str) -> None:
        if not quiet:
            print(f"batecho: {msg}", file=sys.stderr, flush=True)

    return say


def progress_fn(quiet: bool):
    """A wrapper ``(iterable, total, desc) -> iterable`` showing progress on stderr: tqdm if it
    is installed, else one line per step."""

    def wrap(iterable: Iterable, total: int | None = None, desc: str | None = None):
        if quiet:
            return iterable
        try:
            from tqdm import tqdm
        except ImportError:
            return _simple_progress(iterable, total, desc)
        return tqdm(iterable, total=total, desc=desc, file=sys.stderr, leave=False)

    return wrap


def _simple_progress(iterable: Iterable, total: int | None, desc: str | None):
    t0 = time.perf_counter()
    for k, item in enumerate(iterable):
        n = f"/{total}" if total else ""
        print(
            f"batecho: {desc or 'progress'} {k + 1}{n} ({time.perf_counter() - t0:.1f} s)",
            file=sys.stderr,
            flush=True,
        )
        yield item


# ------------------------------------------------------------------------------- demo


def _canonical(out: Path, seed: int) -> list[Path]:

    import numpy as np

    from ..echoes.canonical import canonical_leaf_box, canonical_pose, canonical_sonar
    from ..echoes.simulate import simulate
    from ..forest.scene import Scene
    from ..outputs.npz import write_npz
    from ..outputs.plots import plot_impulse, plot_spectrum
    from ..scenefile.run import sonar_params

    rng = np.random.default_rng(seed)
    leaves = canonical_leaf_box(rng)
    sonar = canonical_sonar()
    pose = canonical_pose()
    t0 = time.perf_counter()
    scene = Scene(leaves)
    echoes = simulate(scene, sonar, pose)
    dt = time.perf_counter() - t0
    print(
        f"canonical leaf box: {len(leaves)} leaves, {echoes.n_leaves[0]} in the main lobe, "
        f"simulated in {dt * 1e3:.1f} ms"
    )
    import matplotlib.pyplot as plt

    fig = plot_impulse(
        echoes,
        0,
        title=f"Ming's canonical leaf box: {echoes.n_leaves[0]} leaves "
        f"in a {sonar.beamwidth_deg:g} deg beam",
    )
    fig.savefig(out / "canonical_impulse.png", dpi=130)
    plt.close(fig)
    fig = plot_spectrum(echoes, 0)
    fig.savefig(out / "canonical_spectrum.png", dpi=130)
    plt.close(fig)
    write_npz(
        out / "canonical_echo.npz",
        {
            "impulse": echoes.impulse,
            "times": echoes.times,
            "spectrum": echoes.spectrum,
            "freqs": echoes.freqs,
            "n_leaves": echoes.n_leaves,
            "positions": echoes.poses.positions,
            "forward": echoes.poses.forward,
            "up": echoes.poses.up,
            "seed": seed,
        },
        {
            "scene_json": {"kind": "leaf_box", "function": "canonical_leaf_box"},
            "sonar_json": sonar_params(sonar),
        },
    )
    return [
        out / n for n in ("canonical_impulse.png", "canonical_spectrum.png", "canonical_echo.npz")
    ]


def demo_toml(seed: int, trees: int, beamwidth: float, quadrotor: str, pulse_rate: float) -> str:
    """The scene file the demo runs: a forest from the paper's IPP, circled."""
    what = f"{trees} trees from the paper's IPP"
    scene = (
        'kind = "forest"\n'
        f"n_trees = {trees}              # the paper's IPP, conditioned on {trees} trees"
    )
    altitude = 5.0
    if quadrotor == "none":
        what += ", kinematic pulses on a circle"
        flight = 'mode = "kinematic"\nn_pulses = 36'
    else:
        what += f", a flown {quadrotor} quadrotor circling"
        flight = (
            f'mode = "flown"\nquadrotor = "{quadrotor}"\n'
            f"pulse_rate_hz = {pulse_rate:g}       # one pulse every {1 / pulse_rate:g} s"
        )
    return DEMO_TOML.format(
        seed=seed, what=what, scene=scene, beamwidth=beamwidth, altitude=altitude, flight=flight
    )


def run_demo(args: argparse.Namespace) -> int:
    from ..outputs.files import make_output_folder
    from ..scenefile.file import SceneFile
    from ..scenefile.run import run_scenefile

    say = say_fn(args.quiet)
    out = make_output_folder(args.out)
    t0 = time.perf_counter()
    files = _canonical(out, args.seed)
    text = demo_toml(args.seed, args.trees, args.beamwidth, args.quadrotor, args.pulse_rate)
    (out / "demo.toml").write_text(text, encoding="utf-8")
    files.append(out / "demo.toml")
    sf = SceneFile.from_string(text, out / "demo.toml")
    res = run_scenefile(sf, out, progress=say)
    _summary(res)
    files += res.files
    for f in files:
        print(f"wrote {f}")
    print(f"demo done in {time.perf_counter() - t0:.1f} s")
    return 0


def _summary(res) -> None:
    import numpy as np

    st, e = res.setup, res.echoes
    n = e.n_leaves if not e.n_receivers else e.n_leaves.max(axis=1)
    t = res.timings_s
    kind = st.scenefile.config["scene"]["kind"]
    nt = 0 if st.tree_positions is None else len(st.tree_positions)
    trees = "" if not nt else f" ({nt} tree{'s' if nt != 1 else ''})"
    flown = " (flown)" if st.plan.flight is not None else ""
    print(
        f"scene: {kind}{trees}, {st.scene.n_leaves:,} leaves, built in {t['scene_s']:.2f} s "
        f"+ BVH {t['bvh_s'] * 1e3:.1f} ms"
    )
    print(
        f"flight{flown}: {len(e)} pulses"
        + (f", {e.n_receivers} receivers" if e.n_receivers else "")
        + f", leaves in the lobe per pulse {n.min()}..{n.max()} "
        f"(mean {n.mean():.0f}), {int((n == 0).sum())} silent; simulated in "
        f"{t['simulate_s']:.3f} s"
    )
    if st.plan.radius and st.scenefile.config["flight"]["path"] == "circle":
        print(
            f"circle: radius {st.plan.radius:.2f} m around ({st.center_xy[0]:.2f}, "
            f"{st.center_xy[1]:.2f}) m"
        )
    cl = res.clearance
    if cl is not None:
        d = cl.distance
        i = int(np.argmin(d))
        print(
            f"clearance: every pulse at least {float(d[i]):.2f} m from leaves and bark "
            f"(pulse {i}, nearest {cl.part(i)}; margin "
            f"{st.scenefile.config['flight']['min_clearance_m']:g} m)"
        )
    if res.min_clearance_m is not None:
        when = (
            "" if res.min_clearance_time_s is None else f" at t = {res.min_clearance_time_s:.3f} s"
        )
        what = "every recorded step of the flight" if st.plan.flight is not None else "the pulses"
        print(f"min_clearance_m: {res.min_clearance_m:.3f} m{when} (over {what})")


# --------------------------------------------------------------------------- simulate


def run_simulate(args: argparse.Namespace) -> int:
    from ..outputs.files import check_output_folder
    from ..scenefile.file import SceneFile
    from ..scenefile.run import run_scenefile

    say = say_fn(args.quiet)
    out = check_output_folder(args.out if args.out else f"{Path(args.scene).stem}-out")
    sf = SceneFile.from_path(args.scene)
    if args.seed is not None:
        sf = sf.with_seed(args.seed)
    for key in ("wav", "mat", "xarray"):
        if getattr(args, key, False):
            sf.config["output"][key] = True
    t0 = time.perf_counter()
    res = run_scenefile(sf, out, plots=not args.no_plots, progress=say)
    _summary(res)
    for f in res.files:
        print(f"wrote {f}")
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# ------------------------------------------------------------------------------ paper


def run_paper_figures(args: argparse.Namespace) -> int:
    from ..outputs.files import check_output_folder
    from ..paper.figures import paper_figures

    check_output_folder(args.out)
    t0 = time.perf_counter()
    written = paper_figures(
        args.out,
        seed=args.seed,
        echo_pulses=args.echo_pulses,
        dpi=args.dpi,
        tree_model=args.tree_model,
        progress=progress_fn(args.quiet),
    )
    for p in written.values():
        print(f"wrote {p}")
    print(f"paper figures done in {time.perf_counter() - t0:.1f} s")
    return 0


def run_paper_table1(args: argparse.Namespace) -> int:
    from ..outputs.files import check_output_file, make_output_folder, writing
    from ..paper.table1 import table1

    for path in (args.out, args.npz):
        if path:
            check_output_file(path)
    res = table1(
        points=args.points,
        trees=args.trees,
        seed=args.seed,
        repeats=args.repeats,
        beamwidth_deg=args.beamwidth,
        heading=args.heading,
        timing_runs=args.timing_runs,
        tree_model=args.tree_model,
        method=args.method,
        tol=args.tol,
        progress=progress_fn(args.quiet),
    )
    md = res.to_markdown()
    wrote = []
    if args.out:
        make_output_folder(Path(args.out).parent)
        with writing(args.out):
            Path(args.out).write_text(md, encoding="utf-8")
        wrote.append(args.out)
    if args.npz:
        make_output_folder(Path(args.npz).parent)
        with writing(args.npz):
            wrote.append(res.to_npz(args.npz))
    print(md)
    for w in wrote:
        print(f"wrote {w}")
    return 0
