"""A smoke test of an installed batecho (e.g. from the wheel, in a fresh venv without a Rust
toolchain): a small simulation by both methods agrees with the NumPy reference, and the
command line answers.

    python tools/smoke_test.py
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np

import batecho
from batecho import reference


def main() -> None:
    rng = np.random.default_rng(0)
    n = 500
    leaves = batecho.Leaves(
        np.column_stack([rng.uniform(1, 9, n), rng.uniform(-2, 2, n), rng.uniform(-2, 2, n)]),
        rng.normal(size=(n, 3)),
        rng.normal(0.02, 0.002, n),
    )
    sonar = batecho.Sonar(beamwidth_deg=40)
    poses = batecho.Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    want = reference.simulate(leaves, sonar, poses)
    scale = np.abs(want.spectrum).max()
    for method, tol in (("exact", 1e-12), ("fast", 1e-6)):
        got = batecho.simulate(batecho.Scene(leaves), sonar, poses, method=method, tol=tol)
        err = float(np.abs(got.spectrum - want.spectrum).max() / scale)
        assert got.n_leaves[0] == want.n_leaves[0] > 0, (got.n_leaves, want.n_leaves)
        assert err < max(1e-10, 10 * tol), (method, err)
        print(f"{method}: {got.n_leaves[0]} leaves, max error {err:.1e} of the peak")
    out = subprocess.run(
        [sys.executable, "-m", "batecho", "--version"], capture_output=True, text=True, check=True
    )
    print(out.stdout.strip(), "on Python", sys.version.split()[0])


if __name__ == "__main__":
    main()
