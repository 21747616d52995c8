#!/usr/bin/env python3
"""Mutational fuzzer of the OBJ reader (``batecho.load_obj``: the Rust pre-scan, tobj, the
mesh building and the Python ``Mesh``).

Each input is a seed mesh (the fixtures under tests/fixtures/obj, windows of the CC0 trees
under tests/data, generated meshes) mutated a few times: bytes flipped, inserted, deleted
or truncated; numbers replaced by NaN, infinities, 1e308, subnormals or malformed text;
indices replaced by 0, huge, negative or out-of-range values; polygons of up to 1e5
corners; names with control characters; odd blanks (tab, CR, form feed, vertical tab, NBSP)
and CRLF line ends; ``mtllib`` lines naming absolute paths, ``..``, a FIFO, a symbolic link
out of the folder. A load must either give a mesh whose arrays are finite and consistent or
raise a ValueError/OSError naming the problem; anything else (another exception, a crash,
an abort, a hang) is a failure.

    python tools/fuzz/obj_fuzz.py                    # short seeded run (CI)
    python tools/fuzz/obj_fuzz.py --long             # 1e6 inputs
    python tools/fuzz/obj_fuzz.py --seed 3 --case 17 --show   # write one input to stdout
"""

from __future__ import annotations

import argparse
import atexit
import os
import random
import shutil
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import child_main, run_campaign  # noqa: E402

ROOT = HERE.parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "obj"
TREES = ROOT / "tests" / "data" / "trees-cc0"

NUMBERS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e308",
    "-1e308",
    "1e309",
    "4.9e-324",
    "1e-320",
    "0",
    "-0",
    "1e",
    "--1",
    "0x10",
    "1_0",
    "",
    "99999999999999999999999",
    "+.5",
    ".",
    "1e-400",
]
INDICES = [
    "0",
    "-1",
    "-2",
    "1",
    "2",
    "-999999",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "9223372036854775807",
    "-9223372036854775808",
    "1/1/1",
    "1//1",
    "//",
    "1/",
    "a",
    "1/0/0",
]
BLANKS = ["\t", "\r", "\x0b", "\x0c", "\u00a0", "\u2028", "\x00", "  ", "\u3000"]
NAMES = [
    "leaf",
    "Leaves",
    "bark",
    "foliage",
    "needle*",
    "le?f",
    "leaf\x00x",
    "a\tb",
    "c\rd",
    "\u00a0leaf",
    "x" * 300,
    "é",
    "",
]


def sources() -> list[bytes]:
    """The seed meshes: the fixtures, windows of the CC0 trees, a generated card."""
    out = [p.read_bytes() for p in sorted(FIXTURES.glob("*.obj"))]
    for p in sorted(TREES.glob("*.obj")):
        lines = p.read_bytes().splitlines(keepends=True)
        verts = [ln for ln in lines if ln.startswith(b"v ")][:60]
        faces = [ln for ln in lines if ln.startswith((b"f ", b"g ", b"o ", b"usemtl"))][:80]
        out.append(b"".join(verts + faces))
    out.append(
        b"mtllib materials.mtl\no tree\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\n"
        b"g bark\nusemtl bark\nf 1 2 5\ng leaves\nusemtl leaf\nf 1 2 3 4\nf -4 -3 -2\n"
    )
    return out


def mutate(rng: random.Random, data: bytes) -> bytes:
    """One mutation of ``data``."""
    text = data.decode("utf-8", "replace")
    lines = text.split("\n")
    kind = rng.randrange(16)
    if kind == 0 and data:  # flip bytes
        b = bytearray(data)
        for _ in range(rng.randint(1, 8)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        return bytes(b)
    if kind == 1:  # insert random bytes
        i = rng.randrange(len(data) + 1)
        junk = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        return data[:i] + junk + data[i:]
    if kind == 2 and data:  # delete or truncate
        i = rng.randrange(len(data))
        return data[:i] if rng.random() < 0.5 else data[:i] + data[i + rng.randint(1, 64) :]
    if kind == 3:  # a number replaced
        li = rng.randrange(len(lines))
        toks = lines[li].split(" ")
        if len(toks) > 1:
            toks[rng.randrange(1, len(toks))] = rng.choice(NUMBERS)
            lines[li] = " ".join(toks)
    elif kind == 4:  # a face index replaced
        faces = [i for i, ln in enumerate(lines) if ln.startswith(("f ", "l "))]
        if faces:
            li = rng.choice(faces)
            toks = lines[li].split(" ")
            toks[rng.randrange(1, len(toks))] = rng.choice(INDICES)
            lines[li] = " ".join(toks)
    elif kind == 5:  # a huge polygon
        n = rng.choice([3, 50, 1000, 20000, 100000])
        nv = sum(1 for ln in lines if ln.startswith("v "))
        lines.append("f " + " ".join(str(1 + (k % max(nv, 1))) for k in range(n)))
    elif kind == 6:  # a name with odd characters
        key = rng.choice(["o", "g", "usemtl"])
        lines.insert(rng.randrange(len(lines) + 1), f"{key} {rng.choice(NAMES)}")
    elif kind == 7:  # odd blanks
        li = rng.randrange(len(lines))
        ln = lines[li]
        i = rng.randrange(len(ln) + 1)
        lines[li] = ln[:i] + rng.choice(BLANKS) + ln[i:]
    elif kind == 8:  # usemtl / keyword followed by an odd blank
        lines.insert(
            rng.randrange(len(lines) + 1),
            rng.choice(["usemtl", "g", "o", "mtllib"]) + rng.choice(BLANKS) + rng.choice(NAMES),
        )
    elif kind == 9:  # CRLF
        return "\r\n".join(lines).encode()
    elif kind == 10:  # mtllib to somewhere it must not read
        lines.insert(
            0,
            "mtllib "
            + rng.choice(
                [
                    "/etc/hostname",
                    "../outside.mtl",
                    "sub/../../x.mtl",
                    "pipe.mtl",
                    "link.mtl",
                    "C:\\\\x.mtl",
                    "\\\\server\\\\x.mtl",
                    "materials.mtl",
                    "missing.mtl",
                    "sub",
                    "zero.mtl",
                    "a b.mtl",
                ]
            ),
        )
    elif kind == 11:  # duplicate or shuffle lines
        if rng.random() < 0.5:
            li = rng.randrange(len(lines))
            lines[li:li] = [lines[li]] * rng.randint(1, 5)
        else:
            rng.shuffle(lines)
    elif kind == 12:  # vertices with w or colours, mixed
        lines.insert(
            rng.randrange(len(lines) + 1),
            rng.choice(
                [
                    "v 1 2 3 0",
                    "v 1 2 3 1 0 0",
                    "v 1 2",
                    "v 1 2 3 4 5",
                    "vn 0 0 0",
                    "vt",
                    "vn nan 0 1",
                    "v 1e308 1e308 1e308",
                    "v -1e308 0 0",
                ]
            ),
        )
    elif kind == 13:  # degenerate geometry
        lines.append("v 0 0 0\nv 0 0 0\nv 0 0 0\nusemtl leaf\nf -1 -2 -3")
    elif kind == 14:  # a line of NULs or invalid UTF-8
        return data + rng.choice([b"\x00" * 64, b"\xff\xfe", b"\xc3", b"f \xe2\x80\n"])
    else:  # empty or nearly
        return rng.choice([b"", b"\n", b" ", b"f", b"v", b"\xef\xbb\xbf" + data])
    return "\n".join(lines).encode("utf-8", "surrogatepass")


def make_input(seed: int, i: int, srcs: list[bytes]) -> tuple[bytes, dict]:
    rng = random.Random(seed * 1_000_003 + i)
    data = rng.choice(srcs)
    for _ in range(rng.choice([1, 1, 2, 3, 5])):
        data = mutate(rng, data)
    opts: dict = {}
    if rng.random() < 0.15:
        opts = {
            "per": rng.choice(["patch", "face"]),
            "up": rng.choice(["z", "y"]),
            "scale": rng.choice([1.0, 0.01, 1e-300, 1e300, 7.0]),
        }
        if rng.random() < 0.3:
            opts["leaf_patterns"] = rng.choice([["*"], ["bark"], ["le?f", "x"], ["\x00"], [""]])
    return data, opts


_STATE: dict = {}


def _folder() -> Path:
    """The child's folder: an MTL beside the OBJ, a FIFO, a link out of the folder."""
    if "dir" not in _STATE:
        d = Path(tempfile.mkdtemp(prefix="batecho-objfuzz-"))
        for p in FIXTURES.glob("*.mtl"):
            (d / p.name).write_bytes(p.read_bytes())
        (d / "sub").mkdir()
        os.mkfifo(d / "pipe.mtl")
        os.symlink("/etc/hostname", d / "link.mtl")
        os.symlink("/dev/zero", d / "zero.mtl")
        atexit.register(shutil.rmtree, d, True)
        _STATE["dir"] = d
        _STATE["srcs"] = sources()
    return _STATE["dir"]


def check_mesh(m) -> str | None:
    """Why a loaded mesh is inconsistent, or None."""
    import numpy as np

    if m.leaves is not None:
        lv = m.leaves
        if not (np.isfinite(lv.centers).all() and np.isfinite(lv.normals).all()):
            return "non-finite leaf centre or normal"
        if not (np.isfinite(lv.radii).all() and (lv.radii > 0).all()):
            return "leaf radius not finite and > 0"
        if not np.allclose(np.linalg.norm(lv.normals, axis=1), 1.0, atol=1e-9):
            return "leaf normal not unit"
    bv, bf = m.bark_vertices, m.bark_faces
    if not np.isfinite(bv).all():
        return "non-finite bark vertex"
    if bf.size and (bf.min() < 0 or bf.max() >= len(bv)):
        return "bark face index out of range"
    return None


def run_case(seed: int, i: int, payload: dict) -> str:
    import warnings

    import batecho

    d = _folder()
    data, opts = make_input(seed, i, _STATE["srcs"])
    path = d / "case.obj"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            mesh = batecho.load_obj(path, **opts)
        except (ValueError, OSError, MemoryError) as exc:
            msg = str(exc)
            if not msg or "panicked" in msg:
                return f"BUG: {type(exc).__name__} with message {msg!r}"
            return "refused"
        except Exception as exc:
            return f"BUG: {type(exc).__name__}: {exc}"
    why = check_mesh(mesh)
    return f"BUG: {why}" if why else "loaded"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--long", action="store_true", help="1e6 inputs")
    ap.add_argument("-n", type=int, help="number of inputs")
    ap.add_argument("--seed", type=int, default=36)
    ap.add_argument("--budget-s", type=float, help="stop after this many seconds")
    ap.add_argument("--case", type=int, help="with --show: the input to write")
    ap.add_argument("--show", action="store_true", help="write input --case to stdout")
    args = ap.parse_args(argv)
    if args.child:
        child_main(run_case)
        return 0
    if args.show:
        data, opts = make_input(args.seed, args.case or 0, sources())
        sys.stderr.write(f"options: {opts}\n")
        sys.stdout.buffer.write(data)
        return 0
    n = args.n or (1_000_000 if args.long else 4000)
    return run_campaign(
        Path(__file__),
        "obj fuzz",
        n,
        batch_size=2000,
        timeout_s=300.0,
        seed=args.seed,
        budget_s=args.budget_s,
    )


if __name__ == "__main__":
    sys.exit(main())
