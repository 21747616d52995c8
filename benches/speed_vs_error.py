"""Speed against error: the exact method and the fast method (tol 1e-3, 1e-6, 1e-9, 1e-12) for
1e3 to 1e6 leaves in the lobe, timed per pulse, errors measured against the exact sum.

Scene: N leaves uniform in x in [1, 9.5] m, y, z in [-2, 2] m, radius N(2, 0.2) cm, uniformly
random normals; the sonar at the origin looking along +x with a 75-degree hard cone, so that
every leaf counts (the defaults of docs/model.md otherwise: 1201 band bins). Times are
medians of warm repeats on this machine, with all threads (RAYON_NUM_THREADS to change);
"lobe" is the lobe query alone (lobe_members, which also builds and sorts the member list; a
fast pulse fuses the lobe test with the spectrum instead), for reference.

    python benches/speed_vs_error.py [--sizes 1e3,1e4,1e5,1e6] [--repeat 3] [--out benches/out]

Writes OUT/speed_vs_error.md (table) and OUT/speed_vs_error.png (time against error, one line
per leaf count).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

# the same warm-repeat median and machine line (benches/ is on sys.path)
from bench_canonical import machine, warm_median

import batecho

TOLS = (1e-3, 1e-6, 1e-9, 1e-12)


def scene(n: int, seed: int = 7) -> batecho.Scene:
    rng = np.random.default_rng(seed)
    centers = np.column_stack(
        [rng.uniform(1.0, 9.5, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)]
    )
    return batecho.Scene(
        batecho.Leaves(centers, rng.normal(size=(n, 3)), rng.normal(0.02, 0.002, n))
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e3,1e4,1e5,1e6")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default="benches/out")
    args = ap.parse_args()
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sonar = batecho.Sonar(lobe="cone", cone_half_angle_deg=75.0, beamwidth_deg=30.0)
    pose = batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    rows = []
    for n in sizes:
        sc = scene(n)
        t_build = sc.build_time_s
        _, t_lobe = warm_median(lambda sc=sc: batecho.lobe_members(sc, sonar, pose), args.repeat)
        exact, t_exact = warm_median(
            lambda sc=sc: batecho.simulate(sc, sonar, pose, method="exact"),
            max(1, args.repeat if n < 1_000_000 else 1),
        )
        assert exact.n_leaves[0] == n, (exact.n_leaves, n)
        norm = np.linalg.norm(exact.spectrum)
        rows.append(
            dict(n=n, method="exact", tol=None, t=t_exact, err=0.0, lobe=t_lobe, build=t_build)
        )
        print(
            f"N={n:>8}: exact {t_exact * 1e3:9.2f} ms (lobe query {t_lobe * 1e3:.2f} ms, "
            f"BVH build {t_build * 1e3:.1f} ms)",
            flush=True,
        )
        for tol in TOLS:
            fast, t_fast = warm_median(
                lambda sc=sc, tol=tol: batecho.simulate(sc, sonar, pose, method="fast", tol=tol),
                args.repeat,
            )
            err = float(np.linalg.norm(fast.spectrum - exact.spectrum) / norm)
            rows.append(
                dict(n=n, method="fast", tol=tol, t=t_fast, err=err, lobe=t_lobe, build=t_build)
            )
            print(
                f"           fast tol {tol:.0e}: {t_fast * 1e3:9.2f} ms, error {err:.1e}, "
                f"speed-up {t_exact / t_fast:6.1f}x",
                flush=True,
            )
    threads = os.environ.get("RAYON_NUM_THREADS", str(os.cpu_count()))
    lines = [
        f"Per-pulse time (ms, median of warm repeats, {threads} threads) and relative L2 error "
        "of the spectrum against the exact method; 1201 band bins; every leaf in the lobe. "
        "The lobe query alone (lobe_members) is shown for reference; every pulse time "
        "includes its own lobe test.",
        "",
        "| leaves | lobe query | exact | fast 1e-3 | fast 1e-6 | fast 1e-9 | fast 1e-12 |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for n in sizes:
        r = [x for x in rows if x["n"] == n]
        ex = r[0]
        cells = [f"{n:.0e}", f"{ex['lobe'] * 1e3:.2f}", f"{ex['t'] * 1e3:.1f}"]
        for x in r[1:]:
            cells.append(f"{x['t'] * 1e3:.2f} ({x['err']:.0e}, {ex['t'] / x['t']:.0f}x)")
        lines.append("| " + " | ".join(cells) + " |")
    lines += [
        "",
        "Cells: time (measured error, speed-up over exact).",
        "",
        f"Machine: {machine()}.",
    ]
    (out / "speed_vs_error.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for n in sizes:
        r = [x for x in rows if x["n"] == n]
        fast = [x for x in r if x["method"] == "fast"]
        (line,) = ax.plot(
            [x["t"] * 1e3 for x in fast],
            [max(x["err"], 1e-17) for x in fast],
            "o-",
            label=f"{n:.0e} leaves",
        )
        for x in fast:
            ax.annotate(
                f"{x['tol']:.0e}",
                (x["t"] * 1e3, max(x["err"], 1e-17)),
                fontsize=6,
                xytext=(3, 3),
                textcoords="offset points",
            )
        ax.axvline(r[0]["t"] * 1e3, color=line.get_color(), ls=":", lw=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per pulse (ms); dotted: exact method")
    ax.set_ylabel("relative L2 error of the spectrum")
    ax.set_title("batecho: fast method, speed against error (labels: tol)", fontsize=10)
    ax.legend(fontsize=8)
    fig.savefig(out / "speed_vs_error.png", dpi=130)
    print(f"wrote {out / 'speed_vs_error.md'} and {out / 'speed_vs_error.png'}")


if __name__ == "__main__":
    main()
