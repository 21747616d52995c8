#!/usr/bin/env python3
"""Datasets under faults: ``batecho dataset generate`` killed (SIGKILL) at random times and
resumed, two ``generate`` runs started on one store at once, and stores corrupted byte by
byte (flipped bytes, truncated or deleted chunk and metadata files) for ``verify``.

What must hold: a killed run's children die with it; a resumed store equals an uninterrupted
one bit for bit (no sample lost or doubled); two writers never leave a broken store; verify
refuses every corrupted store and names what it found, in one line, without a traceback.

    python tools/fuzz/dataset_faults.py               # short seeded run (CI)
    python tools/fuzz/dataset_faults.py --long        # many kills, corruptions and races

Exit status 1 on any failure; the counts are printed either way.
"""

from __future__ import annotations

import argparse
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import run_argv  # noqa: E402

ROOT = HERE.parents[1]
EXAMPLE = ROOT / "examples" / "dataset-small.toml"
CLI = [sys.executable, "-m", "batecho", "dataset"]
MEMORY = 3 * 2**30


def tiny_spec_toml(n_samples: int) -> str:
    from batecho.dataset import DatasetSpec

    spec = DatasetSpec.from_toml(EXAMPLE).with_values(
        {
            "n_samples": n_samples,
            "pulses_per_sample": 2,
            "output.chunk_size": 2,
            "sonar.fs": 200e3,
            "sonar.n_samples": 2000,
            "scene.leaf_box.density_per_m3": {"uniform": [2.0, 6.0]},
            "poses.circle_radius_m": {"uniform": [4.5, 5.5]},
        }
    )
    return spec.to_toml()


def generate_argv(spec: Path, store: Path, workers: int) -> list[str]:
    return [*CLI, "generate", str(spec), str(store), "--workers", str(workers), "--quiet"]


def arrays_of(store: Path) -> dict[str, bytes]:
    import warnings

    import numpy as np
    import zarr

    warnings.simplefilter("ignore")  # (damaged stores: "not recognized as a component")

    g = zarr.open_group(str(store), mode="r", use_consolidated=False)
    return {name: np.asarray(a[...]).tobytes() for name, a in g.arrays()}


def samples_differing(ref: dict[str, bytes], store: Path, n_samples: int) -> int:
    """How many samples of ``store`` differ from the reference in any per-sample array (a
    sample lost, doubled or damaged); every sample when an array is unreadable."""
    import numpy as np
    import zarr

    g = zarr.open_group(str(store), mode="r", use_consolidated=False)
    bad = np.zeros(n_samples, dtype=bool)
    gr = zarr.open_group(str(REF), mode="r", use_consolidated=False)
    for name, a in gr.arrays():
        try:
            b = np.asarray(g[name][...])
        except Exception:
            return n_samples
        x = np.asarray(a[...])
        if a.shape and a.shape[0] == n_samples and x.shape == b.shape:
            rows = x.reshape(n_samples, -1).view(np.uint8) != b.reshape(n_samples, -1).view(
                np.uint8
            )
            bad |= rows.any(axis=1)
        elif x.tobytes() != b.tobytes():
            return n_samples
    return int(bad.sum())


def live_children(session: int) -> list[int]:
    """Processes still in the session ``session`` (the killed run's workers and helpers)."""
    out = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] != "Z" and int(fields[3]) == session:
            out.append(int(d.name))
    return out


def start(argv: list[str]) -> subprocess.Popen:
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    return subprocess.Popen(
        argv,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )


REF = Path()


def kill_campaign(
    rng: random.Random,
    work: Path,
    spec: Path,
    n_samples: int,
    kills: int,
    full_s: float,
    failures: list[str],
) -> tuple[int, int, int]:
    """Kill generate at random times, resume each store to the end, compare with the
    reference. Returns (kills survived, samples lost or doubled, orphans)."""
    survived = lost = orphans = 0
    trial = 0
    ref = arrays_of(REF)
    while survived < kills:
        store = work / f"kill{trial}.zarr"
        trial += 1
        for _ in range(rng.randint(1, 3)):  # one to three kills per store
            workers = rng.choice([1, 2])
            proc = start(generate_argv(spec, store, workers))
            time.sleep(rng.uniform(0.0, full_s))
            if proc.poll() is not None:
                break
            proc.send_signal(signal.SIGKILL)  # the main process only: children must follow
            proc.wait()
            deadline = time.monotonic() + 10.0
            while live_children(proc.pid) and time.monotonic() < deadline:
                time.sleep(0.1)
            left = live_children(proc.pid)
            if left:
                orphans += 1
                failures.append(f"kill {survived}: {len(left)} children outlived the kill")
                for pid in left:
                    os.kill(pid, signal.SIGKILL)
            survived += 1
        oc = run_argv(generate_argv(spec, store, 1), timeout_s=600, memory_bytes=MEMORY)
        if oc.returncode != 0:
            failures.append(f"resume of {store.name} failed: {oc.last_line}")
            lost += n_samples
            continue
        d = samples_differing(ref, store, n_samples)
        if d:
            failures.append(f"{store.name}: {d} samples differ from the uninterrupted run")
        lost += d
        shutil.rmtree(store, ignore_errors=True)
    return survived, lost, orphans


def race_campaign(
    rng: random.Random, work: Path, spec: Path, n_samples: int, races: int, failures: list[str]
) -> int:
    """Two generate runs on one new store, started 0.05-0.3 s apart; then the store must
    finish (a third run) and equal the reference. Returns the number of broken stores."""
    broken = 0
    ref = arrays_of(REF)
    for r in range(races):
        store = work / f"race{r}.zarr"
        a = start(generate_argv(spec, store, 1))
        time.sleep(rng.uniform(0.05, 0.3))
        b = start(generate_argv(spec, store, 1))
        a.wait(timeout=600)
        b.wait(timeout=600)
        oc = run_argv(generate_argv(spec, store, 1), timeout_s=600, memory_bytes=MEMORY)
        d = n_samples if oc.returncode != 0 else samples_differing(ref, store, n_samples)
        if d:
            broken += 1
            failures.append(f"race {r}: the store did not finish whole ({oc.last_line})")
        shutil.rmtree(store, ignore_errors=True)
    return broken


def corrupt(rng: random.Random, store: Path) -> str:
    """Damage one file of ``store``; returns what was done."""
    files = sorted(p for p in store.rglob("*") if p.is_file() and p.name != ".batecho-lock")
    f = rng.choice(files)
    rel = f.relative_to(store)
    how = rng.choice(["flip", "flip", "truncate", "delete"])
    data = f.read_bytes()
    if how == "flip" and data:
        i = rng.randrange(len(data))
        f.write_bytes(data[:i] + bytes([data[i] ^ (1 << rng.randrange(8))]) + data[i + 1 :])
        return f"flipped a bit of byte {i} of {rel}"
    if how == "truncate" and data:
        n = rng.randrange(len(data))
        f.write_bytes(data[:n])
        return f"truncated {rel} to {n} of {len(data)} bytes"
    f.unlink()
    return f"deleted {rel}"


def corruption_campaign(
    rng: random.Random, work: Path, cases: int, failures: list[str]
) -> tuple[int, int]:
    """Corrupt copies of the reference store; verify must refuse each (or the damage must
    leave the data intact) with a one-line message. Returns (cases, missed)."""
    missed = 0
    for c in range(cases):
        store = work / f"corrupt{c}.zarr"
        shutil.copytree(REF, store)
        what = corrupt(rng, store)
        oc = run_argv([*CLI, "verify", str(store)], timeout_s=120, memory_bytes=MEMORY)
        intact = samples_differing_safe(store)
        lines = oc.stderr.strip().splitlines()
        if oc.returncode == 0 and not intact:
            missed += 1
            failures.append(f"verify passed a corrupt store: {what}")
        elif oc.returncode not in (0, 1, 2) or oc.kind != ("ok" if oc.returncode == 0 else "exit"):
            failures.append(
                f"verify of a corrupt store ({what}) ended with {oc.kind}: {oc.last_line}"
            )
        elif oc.returncode and (len(lines) != 1 or "Traceback" in oc.stderr):
            failures.append(f"verify's message ({what}) is not one line: {oc.stderr[-300:]}")
        shutil.rmtree(store, ignore_errors=True)
    return cases, missed


def samples_differing_safe(store: Path) -> bool:
    """True when the damaged store still reads exactly as the reference (the damage hit
    nothing verify must see, e.g. the consolidated metadata copy)."""
    try:
        return arrays_of(store) == arrays_of(REF) and _metadata_same(store)
    except Exception:
        return False


def _metadata_same(store: Path) -> bool:
    for f in REF.rglob("zarr.json"):
        g = store / f.relative_to(REF)
        if f.parent != REF and (not g.exists() or g.read_bytes() != f.read_bytes()):
            return False
    return True


def main(argv: list[str] | None = None) -> int:
    global REF
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--long", action="store_true", help="the long campaign")
    ap.add_argument("--seed", type=int, default=36)
    ap.add_argument("--kills", type=int)
    ap.add_argument("--races", type=int)
    ap.add_argument("--corruptions", type=int)
    ap.add_argument("--samples", type=int, default=24)
    args = ap.parse_args(argv)
    kills = args.kills if args.kills is not None else (200 if args.long else 3)
    races = args.races if args.races is not None else (30 if args.long else 1)
    corruptions = args.corruptions if args.corruptions is not None else (500 if args.long else 20)
    rng = random.Random(args.seed)
    failures: list[str] = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="batecho-faults-") as tmp:
        work = Path(tmp)
        spec = work / "spec.toml"
        spec.write_text(tiny_spec_toml(args.samples))
        REF = work / "reference.zarr"
        t_ref = time.perf_counter()
        oc = run_argv(generate_argv(spec, REF, 1), timeout_s=600, memory_bytes=MEMORY)
        if oc.returncode != 0:
            print(f"dataset faults: the reference run failed: {oc.stderr[-2000:]}")
            return 1
        full_s = time.perf_counter() - t_ref
        survived, lost, orphans = kill_campaign(
            rng, work, spec, args.samples, kills, full_s, failures
        )
        broken = race_campaign(rng, work, spec, args.samples, races, failures)
        n_cases, missed = corruption_campaign(rng, work, corruptions, failures)
    for f in failures[:40]:
        print(f"FAIL {f}")
    print(
        f"dataset faults: {survived} kills survived, {lost} samples lost or doubled, "
        f"{orphans} kills left children alive; {races} two-writer races, {broken} broken "
        f"stores; {n_cases} corruptions, {missed} passed verify; "
        f"{time.perf_counter() - t0:.0f} s"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
