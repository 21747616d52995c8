"""Dataset throughput: samples per second of ``batecho.dataset.generate`` on one process and
on a 2-worker Dask ``LocalCluster`` (and with the default 2-process local runner), with the
same spec, in one run (the machine is shared
and noisy: compare the two numbers, not runs on different days).

Spec: ``examples/dataset-small.toml`` (leaf boxes, 4 pulses per sample, a 12000-sample
record), with ``--samples`` samples. Each run writes a fresh store in a temporary folder and
is verified afterwards.

    python benches/bench_dataset.py [--samples 192] [--chunk 8] [--spec examples/dataset-small.toml]
"""

from __future__ import annotations

import argparse
import importlib
import os
import tempfile
import time
from pathlib import Path

from batecho.dataset import DatasetSpec, generate, verify

ROOT = Path(__file__).resolve().parents[1]

SCALING_NOTE = """\
How it scales: a chunk of samples is the unit of work. Each chunk is a pure function of
(spec, chunk index) (SeedSequence spawning), is written by the worker that computed it straight
into its own Zarr objects, and is then marked complete; the client only hands out chunk indices
and counts markers. Workers share nothing but the store, so throughput grows with the number
of worker processes until the store's write bandwidth is the limit (per chunk here: the size
printed above). On more machines: start a Dask scheduler and workers
(`dask scheduler`, `dask worker tcp://HOST:8786 --nworkers N --nthreads 1` on each machine,
RAYON_NUM_THREADS=1 in their environment), put the store on a shared file system or an
object store URL (s3://..., via fsspec), and run the same command with --scheduler
tcp://HOST:8786. A worker that dies loses at most its current chunk: Dask retries it
elsewhere, and a killed run is finished by running the command again."""


def run(spec: DatasetSpec, store: Path, **kwargs) -> float:
    report = generate(spec, store, progress=False, **kwargs)
    verify(store, deep=False)
    return report.samples_computed / report.elapsed_s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", default=str(ROOT / "examples" / "dataset-small.toml"))
    ap.add_argument("--samples", type=int, default=192)
    ap.add_argument("--chunk", type=int, default=8)
    args = ap.parse_args()

    spec = DatasetSpec.from_toml(args.spec).with_values(
        {"n_samples": args.samples, "output.chunk_size": args.chunk}
    )
    t0, t1 = spec.sonar.time_slice()
    per_sample = spec.pulses_per_sample * (t1 - t0) * 4 / 2**20
    print(
        f"spec {spec.name!r}: {spec.n_samples} samples x {spec.pulses_per_sample} pulses, "
        f"{spec.sonar.n_samples}-sample record, chunks of {spec.chunk_size} "
        f"(~{per_sample * spec.chunk_size:.1f} MiB of impulse per chunk); "
        f"{os.cpu_count()} CPUs"
    )
    with tempfile.TemporaryDirectory() as tmp:
        one = run(spec, Path(tmp) / "one.zarr", workers=1)
        print(f"one process (in-process, RAYON threads = all cores): {one:8.2f} samples/s")
        pool = run(spec, Path(tmp) / "pool.zarr", workers=2)
        print(
            f"2 local processes (the default runner here):          {pool:8.2f} samples/s "
            f"(x{pool / one:.2f}; pool start-up counted)"
        )

        try:
            from distributed import Client, LocalCluster
        except ImportError:
            print("2-worker LocalCluster: skipped (dask[distributed] is not installed)")
        else:
            t = time.perf_counter()
            with (
                LocalCluster(
                    n_workers=2,
                    threads_per_worker=1,
                    processes=True,
                    dashboard_address=None,
                    env={"RAYON_NUM_THREADS": "1"},
                ) as cluster,
                Client(cluster) as client,
            ):
                # Workers import batecho once; not part of the steady-state rate.
                client.run(importlib.import_module, "batecho.dataset.pipeline")
                start = time.perf_counter() - t
                two = run(spec, Path(tmp) / "dask.zarr", client=client)
            print(
                f"2-worker LocalCluster (1 thread each):                {two:8.2f} samples/s "
                f"(x{two / one:.2f}; cluster start-up and imports {start:.1f} s not counted)"
            )
    print()
    print(SCALING_NOTE)


if __name__ == "__main__":
    main()
