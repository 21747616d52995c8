"""The Zarr store: layout, creation, chunk writes with completion markers, and checks.

Layout (Zarr format 3, consolidated metadata; opens with ``xarray.open_zarr``)::

    OUT.zarr/
      zarr.json                 group attributes: batecho_format, spec_toml, spec_sha256, ...
      sample, pulse, chunk      (n,), (p,), (n_chunks,) int64 index coordinates
      time (time,) s, range (time,) m, freq (freq,) Hz      coordinates
      impulse  (sample, pulse, time)  float32|float64       when output.impulse
      spectrum (sample, pulse, freq)  complex64|complex128  when output.spectrum
      wood_spectrum (sample, pulse, freq)  as spectrum  when output.spectrum, with branches
      received (sample, pulse, time)  float32|float64       with a [call]
      n_leaves, nearest_range_m, lobe_mean_radius_m (sample, pulse)     per-pulse labels
      receiver (receiver,)            with two ears: every per-pulse variable above gains
                                      a receiver dimension after pulse (0 left, 1 right)
      n_shaded (sample, pulse[, receiver])      with sonar.shading
      nearest_wood_m (sample, pulse), n_pieces (sample, pulse[, receiver])
                                                with scene.forest.branches
      position, forward, up (sample, pulse, xyz) m / unit vectors        the poses
      scene_index, beamwidth_deg, <pose and scene labels> (sample,)      per-sample labels
      chunk_checksum (chunk,) uint64                                     completion markers

Every ``sample`` variable is chunked ``chunk_size`` samples at a time (whole pulses, whole
records). A chunk's data is written first, then its ``chunk_checksum`` entry (one object per
chunk): 0 means "not complete", anything else is the first 8 bytes of the SHA-256 of the
chunk's data, which :func:`verify` recomputes.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._validate import flag
from .scenes import scene_label_info, scene_label_names
from .spec import DatasetSpec, SpecError

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "DatasetError",
    "SpecMismatchError",
    "VerifyReport",
    "open_dataset",
    "read_spec",
    "verify",
]

#: The ``batecho_format`` attribute of a batecho dataset store.
FORMAT = "batecho-dataset"
#: Bumped when the layout changes incompatibly.
FORMAT_VERSION = 1
MARKER = "chunk_checksum"


class DatasetError(ValueError):
    """A store is foreign, corrupt or incomplete."""


class SpecMismatchError(DatasetError):
    """A store was made from another spec than the one given."""


StoreLike = str | Path


def _zarr():
    try:
        import zarr
    except ImportError:  # pragma: no cover - depends on the installation
        raise ImportError("batecho.dataset needs zarr (>= 3): pip install 'zarr>=3'") from None
    return zarr


# ------------------------------------------------------------------------------ schema


@dataclass(frozen=True)
class Var:
    """One stored array: dims, dtype, fill value, units and description."""

    name: str
    dims: tuple[str, ...]
    dtype: str
    fill: Any
    units: str
    long_name: str


def _label_dtype(name: str) -> str:
    return "int64" if name.startswith("n_") else "float64"


_POSE_LABEL_INFO = {
    "altitude_m": ("m", "flight altitude (z of the pulses)"),
    "circle_radius_m": ("m", "radius of the flight circle"),
    "start_angle_deg": ("degree", "angle of the first pulse on the circle, from +x"),
    "bearing_deg": ("degree", "bearing of the run's start from the scene centre, from +x"),
    "start_distance_m": ("m", "horizontal distance of the run's start from the scene centre"),
    "run_length_m": ("m", "length of the straight run"),
}


def schema(spec: DatasetSpec) -> list[Var]:
    """The per-sample variables of ``spec``'s store (first dim ``sample``), in write order."""
    real = spec.output.dtype
    cplx = "complex64" if real == "float32" else "complex128"
    nan = float("nan")
    out: list[Var] = []
    # (with two ears, a receiver dimension after pulse)
    sp = ("sample", "pulse", "receiver") if spec.sonar.n_receivers else ("sample", "pulse")
    if spec.output.impulse:
        out.append(
            Var(
                "impulse",
                (*sp, "time"),
                real,
                nan,
                "1",
                "impulse response 2 irfft(Y, n_samples) (docs/model.md), cropped to the time coord",
            )
        )
    if spec.output.spectrum:
        out.append(
            Var(
                "spectrum",
                (*sp, "freq"),
                cplx,
                complex(nan, nan),
                "1",
                "windowed band spectrum Y_k at freq",
            )
        )
    if spec.output.spectrum and spec.has_wood:
        out.append(
            Var(
                "wood_spectrum",
                (*sp, "freq"),
                cplx,
                complex(nan, nan),
                "1",
                "the branches' share of the spectrum at freq (docs/model.md §9)",
            )
        )
    if spec.call is not None:
        out.append(
            Var(
                "received",
                (*sp, "time"),
                real,
                nan,
                "1",
                "the impulse response convolved with the call, plus the noise, cropped",
            )
        )
    out += [
        Var("n_leaves", sp, "int32", -1, "1", "leaves that counted for the pulse (in the lobe)"),
        Var(
            "nearest_range_m",
            sp,
            "float64",
            nan,
            "m",
            "range to the nearest counting leaf centre (NaN: none counted)",
        ),
        Var(
            "lobe_mean_radius_m",
            sp,
            "float64",
            nan,
            "m",
            "mean radius of the counting leaves (NaN: none counted)",
        ),
    ]
    pulse = ("sample", "pulse")  # (the pose, not the receiver: nearest_wood_m)
    if spec.sonar.shading:
        out.append(
            Var(
                "n_shaded",
                sp,
                "int32",
                -1,
                "1",
                "counting leaves whose echo shading dimmed or silenced (docs/model.md §10)",
            )
        )
    if spec.has_wood:
        out += [
            Var(
                "nearest_wood_m",
                pulse,
                "float64",
                nan,
                "m",
                "distance from the pulse to the nearest wood surface (trunk, branch or twig) "
                "in the scene",
            ),
            Var("n_pieces", sp, "int32", -1, "1", "branch pieces that counted for the pulse"),
        ]
    out += [
        Var("position", ("sample", "pulse", "xyz"), "float64", nan, "m", "pulse position"),
        Var("forward", ("sample", "pulse", "xyz"), "float64", nan, "1", "beam axis, unit"),
        Var("up", ("sample", "pulse", "xyz"), "float64", nan, "1", "sonar up, unit vector"),
        Var("scene_index", ("sample",), "int64", -1, "1", "index of the scene the sample used"),
        Var("beamwidth_deg", ("sample",), "float64", nan, "degree", "full -3 dB beamwidth drawn"),
    ]
    for name in spec.poses.label_names():
        units, desc = _POSE_LABEL_INFO[name]
        out.append(Var(name, ("sample",), "float64", nan, units, desc))
    for name in scene_label_names(spec):
        units, desc = scene_label_info(name)
        dt = _label_dtype(name)
        out.append(Var(name, ("sample",), dt, -1 if dt == "int64" else nan, units, desc))
    return out


def coordinates(spec: DatasetSpec) -> dict[str, tuple[tuple[str, ...], np.ndarray, str, str]]:
    """Coordinate arrays: name -> (dims, values, units, description)."""
    sonar = spec.sonar.make(spec.sonar.beamwidth_deg.low)
    t0, t1 = spec.sonar.time_slice()
    times = sonar.times[t0:t1]
    out: dict[str, tuple[tuple[str, ...], np.ndarray, str, str]] = {
        "sample": (("sample",), np.arange(spec.n_samples, dtype=np.int64), "1", "sample index"),
        "pulse": (
            ("pulse",),
            np.arange(spec.pulses_per_sample, dtype=np.int64),
            "1",
            "pulse index within the sample",
        ),
        "chunk": (("chunk",), np.arange(spec.n_chunks, dtype=np.int64), "1", "chunk index"),
    }
    if spec.sonar.n_receivers:
        out["receiver"] = (
            ("receiver",),
            np.arange(spec.sonar.n_receivers, dtype=np.int64),
            "1",
            "receiver: 0 the left ear, 1 the right ear",
        )
    if spec.output.impulse or spec.call is not None:
        out["time"] = (("time",), times, "s", "time since the pulse")
        out["range"] = (("time",), sonar.sound_speed * times / 2.0, "m", "range v t / 2")
    if spec.output.spectrum:
        out["freq"] = (
            ("freq",),
            np.asarray(sonar.freqs, dtype=np.float64),
            "Hz",
            "band-bin frequency",
        )
    return out


def _shape(spec: DatasetSpec, dims: tuple[str, ...]) -> tuple[int, ...]:
    t0, t1 = spec.sonar.time_slice()
    size = {
        "sample": spec.n_samples,
        "pulse": spec.pulses_per_sample,
        "time": t1 - t0,
        "freq": spec.sonar.n_bins,
        "xyz": 3,
        "receiver": spec.sonar.n_receivers,
    }
    return tuple(size[d] for d in dims)


# ----------------------------------------------------------------------- checksums


def chunk_checksum(block: Mapping[str, np.ndarray]) -> int:
    """Nonzero uint64 fingerprint of a chunk's arrays: the first 8 bytes (little-endian) of
    SHA-256 over (name, dtype, shape, bytes) of each array, by name."""
    h = hashlib.sha256()
    for name in sorted(block):
        a = np.ascontiguousarray(block[name])
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    value = int.from_bytes(h.digest()[:8], "little")
    return value or 1


# ------------------------------------------------------------------ create and open


def _is_url(store: StoreLike) -> bool:
    return isinstance(store, str) and "://" in store


def _open_group(store: StoreLike, mode: str = "r"):
    zarr = _zarr()
    try:
        # The store's own metadata, not the consolidated copy (which is for readers).
        return zarr.open_group(str(store), mode=mode, use_consolidated=False)
    except FileNotFoundError:
        return None
    except Exception as exc:  # an array at the root, unreadable metadata, ...
        raise DatasetError(f"{store} is not a readable zarr group ({exc})") from None


def _no_store(store: StoreLike) -> DatasetError:
    """The error for a path that holds no zarr store: missing, a file (a TOML spec?), or a
    folder without a store's metadata."""
    p = Path(store)
    if "://" not in str(store) and p.is_file():
        what = "a TOML spec" if p.suffix.lower() == ".toml" else "a file"
        return DatasetError(
            f"{store} is {what}, not a dataset: this expects a zarr store (a folder such as "
            "small.zarr, written by batecho dataset generate SPEC.toml STORE.zarr)"
        )
    if "://" not in str(store) and p.is_dir():
        return DatasetError(
            f"{store} is a folder but not a zarr store (it has no zarr.json): this expects a "
            "store written by batecho dataset generate SPEC.toml STORE.zarr"
        )
    return DatasetError(f"{store} does not exist (no zarr store there)")


def read_spec(store: StoreLike, group: Any = None) -> DatasetSpec:
    """The spec stored in a batecho dataset store, checked against its stored hash.

    Raises :class:`DatasetError` if ``store`` is missing, foreign, or its spec was altered.
    """
    g = group if group is not None else _open_group(store)
    if g is None:
        raise _no_store(store)
    attrs = dict(g.attrs)
    if attrs.get("batecho_format") != FORMAT:
        raise DatasetError(
            f"{store} is a zarr store but not a batecho dataset (no batecho_format "
            f"= {FORMAT!r} attribute); refusing to use it"
        )
    version = attrs.get("batecho_format_version")
    if version != FORMAT_VERSION:
        raise DatasetError(
            f"{store} has batecho dataset format version {version!r}; this batecho reads "
            f"version {FORMAT_VERSION}"
        )
    text, digest = attrs.get("spec_toml"), attrs.get("spec_sha256")
    if not isinstance(text, str) or not isinstance(digest, str):
        raise DatasetError(f"{store} lacks its spec (spec_toml / spec_sha256 attributes)")
    if hashlib.sha256(text.encode("utf-8")).hexdigest() != digest:
        raise DatasetError(
            f"{store}: the stored spec does not match its SHA-256 (spec_sha256); the store's "
            "attributes were altered, refusing to trust it"
        )
    try:
        spec = DatasetSpec.from_toml_string(text)
    except SpecError as exc:
        raise DatasetError(f"{store}: the stored spec is not valid: {exc}") from None
    if spec.sha256 != digest:
        raise DatasetError(
            f"{store}: the stored spec is not in canonical form (written by another version "
            "of batecho, or altered); refusing to use it"
        )
    return spec


def _layout_problems(g: Any, spec: DatasetSpec) -> list[str]:
    problems = []
    expected: dict[str, tuple[tuple[int, ...], str, tuple[int, ...] | None]] = {}
    for v in schema(spec):
        shape = _shape(spec, v.dims)
        expected[v.name] = (shape, v.dtype, (spec.chunk_size, *shape[1:]))
    for name, (_dims, values, _, _) in coordinates(spec).items():
        expected[name] = (values.shape, str(values.dtype), None)
    expected[MARKER] = ((spec.n_chunks,), "uint64", (1,))
    for name, (shape, dtype, chunks) in expected.items():
        # One array at a time (not g.arrays(), whose concurrent reads leave tasks behind on
        # the first broken metadata file).
        try:
            a = g[name]
        except KeyError:
            problems.append(f"array {name!r} is missing")
            continue
        except Exception as exc:
            problems.append(f"array {name!r} has unreadable metadata ({_why(exc)})")
            continue
        if tuple(a.shape) != shape or str(a.dtype) != dtype:
            problems.append(
                f"array {name!r} is {a.dtype}{list(a.shape)}, expected {dtype}{list(shape)}"
            )
        elif chunks is not None and tuple(a.chunks) != chunks:
            problems.append(f"array {name!r} has chunks {a.chunks}, expected {chunks}")
    return problems


def _why(exc: BaseException) -> str:
    """An exception as a short reason: its type and first line."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0][:200]}" if text else type(exc).__name__


def _coordinate_problems(g: Any, spec: DatasetSpec) -> list[str]:
    """The coordinate arrays must hold exactly what the spec makes of them."""
    problems = []
    for name, (_dims, values, _, _) in coordinates(spec).items():
        try:
            stored = np.asarray(g[name][...])
        except Exception as exc:
            problems.append(f"coordinate {name!r} cannot be read ({_why(exc)})")
            continue
        if stored.shape != values.shape or stored.tobytes() != values.tobytes():
            bad = (
                int(np.count_nonzero(stored != values))
                if stored.shape == values.shape
                else stored.size
            )
            problems.append(
                f"coordinate {name!r} differs from what the spec gives ({bad} of "
                f"{values.size} values)"
            )
    return problems


#: Compressors whose settings change how a chunk is stored, not what it holds: their
#: configuration may differ between zarr versions and is not compared.
_COMPRESSORS = ("zstd", "blosc", "gzip")


def _comparable(meta: Any) -> Any:
    """An array's metadata as compared by verify (JSON types; NaN fill values as text)."""
    import json

    d = json.loads(json.dumps(meta.to_dict(), default=str))
    d["codecs"] = [
        {"name": c.get("name")} if c.get("name") in _COMPRESSORS else c for c in d.get("codecs", [])
    ]
    return d


def _metadata_problems(g: Any, spec: DatasetSpec) -> list[str]:
    """Every array's metadata (attributes, dimension names, fill value, codecs) must be what
    the spec lays out: built afresh in a temporary folder and compared."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="batecho-verify-") as tmp:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            expected = _lay_out(Path(tmp) / "expected.zarr", spec, False)
        return _compare_metadata(g, expected)


def _compare_metadata(g: Any, expected: Any) -> list[str]:
    """The arrays of group ``g`` whose metadata differs from that of ``expected``'s."""
    problems = []
    for name, want in expected.arrays():
        try:
            got = g[name]
        except Exception:  # (missing or unreadable: the layout check names it)
            continue
        a, b = _comparable(got.metadata), _comparable(want.metadata)
        if a != b:
            keys = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            problems.append(f"array {name!r} has altered metadata ({', '.join(keys)})")
    return problems


def _read_markers(g: Any, n_chunks: int) -> np.ndarray:
    """(n_chunks,) uint64 markers; an unreadable marker object reads as 0 (incomplete)."""
    arr = g[MARKER]
    try:
        return np.asarray(arr[:], dtype=np.uint64)
    except Exception:
        out = np.zeros(n_chunks, dtype=np.uint64)
        for k in range(n_chunks):
            try:
                out[k] = arr[k]
            except Exception:
                out[k] = 0
        return out


def _consolidate(store: StoreLike) -> None:
    """Write the consolidated metadata that lets xarray open the store in one read."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "consolidated metadata is not in the v3 spec"
        _zarr().consolidate_metadata(str(store))


def _create(store: StoreLike, spec: DatasetSpec, overwrite: bool = False) -> Any:
    """Lay out a new store. A local store is built beside its path (``OUT.zarr.partial``)
    and renamed into place when whole, so that a run killed while creating it leaves no
    half-made store (the caller holds the store's lock)."""
    if _is_url(store):
        return _lay_out(store, spec, overwrite)
    path = Path(store)
    partial = path.with_name(path.name + ".partial")
    if not _left_by_a_killed_run(partial):
        raise DatasetError(
            f"{partial} exists and is not a store left by a killed run; refusing to delete it "
            f"(batecho dataset generate builds {path.name} there): move it or choose another path"
        )
    shutil.rmtree(partial, ignore_errors=True)
    _lay_out(partial, spec, False)
    if path.exists():
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    os.replace(partial, path)
    return _zarr().open_group(str(store), mode="r+", use_consolidated=False)


# zarr's local store writes each file through a temporary ``<stem>.<32 hex>.partial`` beside
# it, which a run killed in that write leaves behind.
_ZARR_TEMPORARY = re.compile(r"zarr\.[0-9a-f]{32}\.partial")


def _left_by_a_killed_run(partial: Path) -> bool:
    """Whether ``partial`` (``OUT.zarr.partial``) may be deleted: missing, an empty folder,
    or a zarr hierarchy as a run killed while laying out its store leaves it (a ``zarr.json``
    or zarr's temporary for it, and folders); not a file or a folder of anything else."""
    if not partial.exists() and not partial.is_symlink():
        return True
    if partial.is_symlink() or not partial.is_dir():
        return False
    entries = list(partial.iterdir())
    if not entries:
        return True

    def root_file(e: Path) -> bool:
        return (e.name == "zarr.json" or _ZARR_TEMPORARY.fullmatch(e.name) is not None) and (
            e.is_file() and not e.is_symlink()
        )

    return any(root_file(e) for e in entries) and all(
        root_file(e) or (e.is_dir() and not e.is_symlink()) for e in entries
    )


def _lay_out(store: StoreLike, spec: DatasetSpec, overwrite: bool) -> Any:
    zarr = _zarr()
    from .._core import __version__

    g = zarr.open_group(str(store), mode="w" if overwrite else "w-", zarr_format=3)
    for name, (dims, values, units, desc) in coordinates(spec).items():
        a = g.create_array(
            name,
            shape=values.shape,
            chunks=values.shape,
            dtype=values.dtype,
            dimension_names=dims,
            attributes={"units": units, "long_name": desc},
        )
        a[:] = values
    has_range = spec.output.impulse or spec.call is not None
    for v in schema(spec):
        shape = _shape(spec, v.dims)
        attrs = {"units": v.units, "long_name": v.long_name}
        if has_range and "time" in v.dims:
            attrs["coordinates"] = "range"
        g.create_array(
            v.name,
            shape=shape,
            chunks=(spec.chunk_size, *shape[1:]),
            dtype=v.dtype,
            fill_value=v.fill,
            dimension_names=v.dims,
            attributes=attrs,
        )
    g.create_array(
        MARKER,
        shape=(spec.n_chunks,),
        chunks=(1,),
        dtype="uint64",
        fill_value=0,
        compressors=None,
        dimension_names=("chunk",),
        attributes={
            "long_name": "chunk completion marker: 0 = not complete, else the first 8 bytes "
            "(little-endian) of the SHA-256 of the chunk's data",
        },
    )
    # The attributes go last: a store without them is not taken for a finished layout.
    g.attrs.update(
        {
            "batecho_format": FORMAT,
            "batecho_format_version": FORMAT_VERSION,
            "batecho_version": __version__,
            "title": spec.name,
            "spec_toml": spec.to_toml(),
            "spec_sha256": spec.sha256,
            "n_samples": spec.n_samples,
            "pulses_per_sample": spec.pulses_per_sample,
            "chunk_size": spec.chunk_size,
            "n_chunks": spec.n_chunks,
            "scene_kind": spec.scene.kind,
            "dims": "sample, pulse, "
            + ("receiver (0 left, 1 right ear), " if spec.sonar.n_receivers else "")
            + "time (s), freq (Hz), xyz (x, y, z; world frame, z up)",
        }
    )
    _consolidate(store)
    return zarr.open_group(str(store), mode="r+", use_consolidated=False)


def _spec_diff(a: DatasetSpec, b: DatasetSpec) -> list[str]:
    def flat(d: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
        out: dict[str, Any] = {}
        for k, v in d.items():
            key = f"{prefix}{k}"
            if (
                isinstance(v, dict)
                and v
                and not (len(v) == 1 and isinstance(next(iter(v.values())), list))
            ):
                out.update(flat(v, key + "."))
            else:
                out[key] = v
        return out

    fa, fb = flat(a.to_dict()), flat(b.to_dict())
    return [
        f"{k}: stored {fa.get(k, '(absent)')!r}, given {fb.get(k, '(absent)')!r}"
        for k in sorted(set(fa) | set(fb))
        if fa.get(k) != fb.get(k)
    ]


def _interrupted_layout(g: Any, spec: DatasetSpec) -> bool:
    """Whether ``g`` holds only arrays of ``spec``'s layout and no completed chunk."""
    ours = {v.name for v in schema(spec)} | set(coordinates(spec)) | {MARKER}
    names = set(g.array_keys())
    if not names <= ours or any(True for _ in g.group_keys()):
        return False
    return MARKER not in names or not np.any(_read_markers(g, spec.n_chunks))


def open_for_generate(store: StoreLike, spec: DatasetSpec) -> tuple[Any, np.ndarray]:
    """Create the store, or reopen it to resume. Returns (group, markers).

    Refuses a path that holds something other than a batecho store made from ``spec``.
    """
    g = _open_group(store, mode="r")
    if g is None:
        if not _is_url(store):
            p = Path(store)
            if p.exists() and (not p.is_dir() or any(p.iterdir())):
                raise DatasetError(
                    f"{store} exists and is not a zarr store; refusing to write into it "
                    "(choose a new path)"
                )
        g = _create(store, spec, overwrite=not _is_url(store) and Path(store).exists())
        return g, np.zeros(spec.n_chunks, dtype=np.uint64)
    if "batecho_format" not in g.attrs and _interrupted_layout(g, spec):
        # Our own layout, cut short before its attributes (written last): nothing lost.
        return _create(store, spec, overwrite=True), np.zeros(spec.n_chunks, dtype=np.uint64)
    stored = read_spec(store, g)
    if stored.sha256 != spec.sha256:
        diff = _spec_diff(stored, spec)
        shown = "; ".join(diff[:8]) + (f"; ... ({len(diff) - 8} more)" if len(diff) > 8 else "")
        raise SpecMismatchError(
            f"{store} was made from a different spec (sha256 {stored.sha256[:12]}, given "
            f"{spec.sha256[:12]}): {shown}. Resume with the stored spec "
            "(batecho dataset show) or write to a new store"
        )
    g = _zarr().open_group(str(store), mode="r+", use_consolidated=False)
    problems = _layout_problems(g, spec)
    problems = problems or _coordinate_problems(g, spec)
    if problems:
        raise DatasetError(f"{store} is corrupt: " + "; ".join(problems[:8]))
    if g.metadata.consolidated_metadata is None:  # cut short just before consolidating
        _consolidate(store)
    markers = _read_markers(g, spec.n_chunks)
    # A chunk marked complete is trusted only if its data still matches its checksum: one
    # damaged since (a disk error, a hand edit) is computed again.
    for k in np.flatnonzero(markers):
        found = _chunk_problems(g, spec, int(k), int(markers[k]))
        if found:
            warnings.warn(
                f"{store}: chunk {int(k)} was marked complete but is damaged ({found[0]}); "
                "computing it again",
                stacklevel=2,
            )
            markers[k] = 0
    return g, markers


def write_chunk(g: Any, spec: DatasetSpec, k: int, block: Mapping[str, np.ndarray]) -> int:
    """Write chunk ``k`` (every per-sample array, one region each), then its marker.

    Returns the marker (checksum). A crash before the marker leaves the chunk incomplete,
    and the next run writes it again.
    """
    i0, i1 = spec.chunk_range(k)
    names = [v.name for v in schema(spec)]
    missing = set(names) ^ set(block)
    if missing:
        raise ValueError(f"chunk {k}: arrays {sorted(missing)} missing or unexpected")
    cast = {}
    for v in schema(spec):
        a = np.asarray(block[v.name]).astype(v.dtype, copy=False)
        if a.shape[0] != i1 - i0:
            raise ValueError(f"chunk {k}: {v.name} has {a.shape[0]} samples, expected {i1 - i0}")
        cast[v.name] = a
    for name in names:
        g[name][i0:i1] = cast[name]
    value = chunk_checksum(cast)
    g[MARKER][k] = np.uint64(value)
    return value


# ----------------------------------------------------------------------------- verify


@dataclass(frozen=True)
class VerifyReport:
    """What :func:`verify` checked. ``deep``: the data was read and checksummed."""

    store: str
    spec: DatasetSpec
    n_samples: int
    n_chunks: int
    deep: bool
    elapsed_s: float

    def summary(self) -> str:
        how = "data checksummed" if self.deep else "markers only"
        return (
            f"{self.store}: OK - {self.n_samples} samples in {self.n_chunks} chunks, complete "
            f"({how}); spec {self.spec.name!r} sha256 {self.spec.sha256[:12]}"
        )


def _chunk_problems(g: Any, spec: DatasetSpec, k: int, marker: int) -> list[str]:
    i0, i1 = spec.chunk_range(k)
    block = {}
    problems = []
    for v in schema(spec):
        try:
            block[v.name] = np.asarray(g[v.name][i0:i1])
        except Exception as exc:
            problems.append(f"chunk {k}: array {v.name!r} cannot be read ({_why(exc)})")
    if problems:
        return problems
    if chunk_checksum(block) != int(marker):
        problems.append(f"chunk {k} (samples {i0}..{i1 - 1}): data does not match its checksum")
    for v in schema(spec):
        a = block[v.name]
        if v.name in ("nearest_range_m", "lobe_mean_radius_m"):
            bad = np.isnan(a) != (block["n_leaves"] == 0)
        elif a.dtype.kind in "fc":
            bad = np.isnan(a)
        else:
            bad = a < 0
        if bad.any():
            problems.append(f"chunk {k}: {v.name} has {int(bad.sum())} missing or invalid values")
    return problems


def verify(store: StoreLike, deep: bool = True) -> VerifyReport:
    """Check a store: it is a batecho dataset, its spec matches its hash, its layout matches
    the spec, every chunk is marked complete, and (``deep``) every chunk's data matches its
    checksum with no NaN where data is expected.

    Returns a :class:`VerifyReport`; raises :class:`DatasetError` naming what is wrong.
    """
    deep = flag(deep, "deep")
    t0 = time.perf_counter()
    g = _open_group(store, mode="r")
    if g is None:
        raise _no_store(store)
    spec = read_spec(store, g)
    problems = _layout_problems(g, spec)
    problems = problems or _metadata_problems(g, spec) + _coordinate_problems(g, spec)
    if problems:
        raise DatasetError(f"{store} is corrupt: " + "; ".join(problems[:8]))
    markers = _read_markers(g, spec.n_chunks)
    missing = np.flatnonzero(markers == 0)
    if missing.size:
        raise DatasetError(
            f"{store} is incomplete: {missing.size} of {spec.n_chunks} chunks are not marked "
            f"complete (chunks {missing[:10].tolist()}{' ...' if missing.size > 10 else ''}); "
            "run generate again with the same spec to finish it"
        )
    if deep:
        found: list[str] = []
        for k in range(spec.n_chunks):
            found += _chunk_problems(g, spec, k, int(markers[k]))
        if found:
            more = f" ... ({len(found) - 8} more)" if len(found) > 8 else ""
            raise DatasetError(f"{store} is corrupt: " + "; ".join(found[:8]) + more)
    return VerifyReport(
        str(store), spec, spec.n_samples, spec.n_chunks, deep, time.perf_counter() - t0
    )


def open_dataset(store: StoreLike, check: bool = False) -> Any:
    """The store as an ``xarray.Dataset`` (lazy, dask-backed). ``check=True`` runs
    :func:`verify` first; otherwise only that it is a batecho store with an intact spec."""
    import xarray as xr

    if flag(check, "check"):
        verify(store)
    else:
        g = _open_group(store, mode="r")
        if g is None:
            raise _no_store(store)
        read_spec(store, g)
    return xr.open_zarr(str(store))
