"""The ``batecho`` command line."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path


def _demo(args: argparse.Namespace) -> int:
    import numpy as np

    import batecho
    from batecho.examples import canonical_leaf_box, canonical_pose, canonical_sonar
    from batecho.plotting import plot_impulse, plot_spectrum

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    leaves = canonical_leaf_box(rng)
    sonar = canonical_sonar()
    pose = canonical_pose()
    t0 = time.perf_counter()
    scene = batecho.Scene(leaves)
    echoes = batecho.simulate(scene, sonar, pose)
    dt = time.perf_counter() - t0
    print(
        f"canonical leaf box: {len(leaves)} leaves, {echoes.n_leaves[0]} in the main lobe, "
        f"simulated in {dt * 1e3:.1f} ms"
    )
    fig = plot_impulse(
        echoes,
        0,
        title=f"Ming's canonical leaf box: {echoes.n_leaves[0]} leaves "
        f"in a {sonar.beam.beamwidth_deg:g} deg beam",
    )
    fig.savefig(out / "canonical_impulse.png", dpi=130)
    fig = plot_spectrum(echoes, 0)
    fig.savefig(out / "canonical_spectrum.png", dpi=130)
    np.savez(
        out / "canonical_echo.npz",
        impulse=echoes.impulse,
        times=echoes.times,
        spectrum=echoes.spectrum,
        freqs=echoes.freqs,
        n_leaves=echoes.n_leaves,
        seed=args.seed,
    )
    for name in ("canonical_impulse.png", "canonical_spectrum.png", "canonical_echo.npz"):
        print(f"wrote {out / name}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="batecho",
        description="Foliage echoes for bat-inspired sonar: forests, flights, impulse responses.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    d = sub.add_parser(
        "demo",
        help="simulate a small scene and write plots and data",
        description="Simulate Ming's canonical leaf box and write the impulse "
        "response and spectrum as PNG, and the echo as NPZ.",
    )
    d.add_argument("--out", default="demo-out", help="output folder (default: demo-out)")
    d.add_argument("--seed", type=int, default=2017, help="random seed (default: 2017)")
    d.set_defaults(func=_demo)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except (ValueError, TypeError, FileNotFoundError) as exc:
        print(f"batecho {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
