"""Tree meshes from Wavefront OBJ files: leaves as disks, bark as triangles.

``load_obj`` reads an OBJ (and the MTL files in its own folder) in the Rust core (tobj). Faces
are leaf or bark faces by the name of their object (``o``), group (``g``) or material
(``usemtl``): a name matching one of ``leaf_patterns`` (case-insensitive; a pattern with ``*``
or ``?`` is a glob over the whole name, any other pattern a substring) makes a leaf face.
Leaf faces become disks (area-weighted centroid, area-weighted unit normal, radius
``sqrt(area / pi)``), one per connected patch of leaf faces or one per polygon; bark polygons
become triangles. ``write_obj`` / ``Mesh.to_obj`` write meshes back, each disk as a regular
polygon card of the same centre, normal and area.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import _core
from .._geometry import crosses, norms
from .._pickle import ReadOnlyOnLoading
from .._validate import flag, positive_scalar, readonly, real_array
from .leaves import MAX_COORDINATE_M, Leaves

#: The largest OBJ or MTL file a load reads (bytes), as the core's: 1 GiB. A load also needs
#: about eight times the file's size in memory, within :func:`batecho.memory_limit`.
MAX_OBJ_BYTES = 2**30

#: Leaf patterns used when ``leaf_patterns`` is None (the Rust core's defaults).
DEFAULT_LEAF_PATTERNS: tuple[str, ...] = ("leaf", "leaves", "foliage", "needle")

_LEAF_RGB = (0.25, 0.55, 0.2)
_BARK_RGB = (0.45, 0.32, 0.22)


class ObjWarning(UserWarning):
    """Something in an OBJ file was skipped or assumed (degenerate faces, a missing MTL...)."""


@dataclass(frozen=True, eq=False)
class Mesh(ReadOnlyOnLoading):
    """A tree mesh: leaf disks plus bark triangles, z-up, in metres.

    Returned by :func:`load_obj`; can also be built from generated geometry (then ``leaf_areas``
    defaults to ``pi r^2``, leaves go in a group ``"leaves"`` and bark in ``"bark"``).

    Attributes
    ----------
    leaves : Leaves or None
        The leaf disks (None when the mesh has no leaf faces).
    bark_vertices : (v, 3) float64
    bark_faces : (f, 3) int64
        Triangles, indices into ``bark_vertices``.
    leaf_areas : (n,) float64
        Area of the faces behind each disk (``pi * radius**2``).
    leaf_groups, bark_face_groups : (n,), (f,) int64
        Index into ``group_names`` of the object/group/material each leaf or triangle came
        from.
    group_names : tuple of str
    n_degenerate_faces : int
        Faces skipped while loading (fewer than 3 vertices, repeated vertices, ~zero area).
    source : Path or None
        The file it was loaded from.
    warnings : tuple of str
        The loader's warnings (also emitted as :class:`ObjWarning`).
    """

    leaves: Leaves | None
    bark_vertices: Any = None
    bark_faces: Any = None
    leaf_areas: Any = None
    leaf_groups: Any = None
    bark_face_groups: Any = None
    group_names: Sequence[str] = ()
    n_degenerate_faces: int = 0
    source: Path | None = None
    warnings: tuple[str, ...] = field(default=(), repr=False)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        lv = self.leaves
        if lv is not None and not isinstance(lv, Leaves):
            raise TypeError(f"leaves must be Leaves or None, got {type(lv).__name__}")
        n = 0 if lv is None else len(lv)
        names = [_check_name(s, "group name") for s in self.group_names]
        bv = _vertices(self.bark_vertices, "bark_vertices")
        bf = _faces(self.bark_faces, len(bv), "bark_faces")
        if self.leaf_areas is None:
            areas = np.pi * lv.radii**2 if lv is not None else np.zeros(0)
        else:
            areas = real_array(self.leaf_areas, "leaf_areas")
            if areas.shape != (n,):
                raise ValueError(f"leaf_areas must have shape ({n},), got {areas.shape}")
            if not (np.isfinite(areas).all() and (areas > 0).all()):
                raise ValueError("leaf_areas must be finite and > 0")
        lg = _groups(self.leaf_groups, n, names, "leaves", "leaf_groups")
        bg = _groups(self.bark_face_groups, len(bf), names, "bark", "bark_face_groups")
        set_(self, "bark_vertices", readonly(bv))
        set_(self, "bark_faces", readonly(bf))
        set_(self, "leaf_areas", readonly(np.ascontiguousarray(areas, dtype=np.float64)))
        set_(self, "leaf_groups", readonly(lg))
        set_(self, "bark_face_groups", readonly(bg))
        set_(self, "group_names", tuple(names))
        set_(self, "n_degenerate_faces", int(self.n_degenerate_faces))
        set_(self, "source", None if self.source is None else Path(self.source))
        set_(self, "warnings", tuple(str(w) for w in self.warnings))

    @property
    def n_leaves(self) -> int:
        return 0 if self.leaves is None else len(self.leaves)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box ``(min, max)`` of the bark vertices and the leaf disks
        (each disk's exact extent: ``centre +- radius * sqrt(1 - n_i^2)`` along axis i)."""
        lo, hi = [], []
        if len(self.bark_vertices):
            lo.append(self.bark_vertices.min(axis=0))
            hi.append(self.bark_vertices.max(axis=0))
        if self.leaves is not None:
            nv = self.leaves.normals
            ext = self.leaves.radii[:, None] * np.sqrt(np.clip(1.0 - nv * nv, 0.0, None))
            lo.append((self.leaves.centers - ext).min(axis=0))
            hi.append((self.leaves.centers + ext).max(axis=0))
        if not lo:
            raise ValueError("the mesh is empty: no bark faces and no leaves")
        return np.min(lo, axis=0), np.max(hi, axis=0)

    def to_obj(self, path: str | os.PathLike, sides: int = 8, mtl: bool = True) -> Path:
        """Write the mesh as an OBJ (+ MTL beside it): bark triangles in groups named as
        loaded, each leaf disk as a regular ``sides``-gon card of the same centre, normal and
        area in a ``leaves`` group. ``load_obj`` of the result gives back the same disks.
        Returns the OBJ path."""
        return write_obj(
            path,
            self.bark_vertices,
            self.bark_faces,
            self.leaves,
            bark_groups=self.bark_face_groups,
            bark_group_names=self.group_names,
            sides=sides,
            mtl=mtl,
        )

    def to_trimesh(self, include_leaves: bool = True, sides: int = 8) -> Any:
        """A ``trimesh.Trimesh`` of the bark (and the leaf cards, as ``sides``-gon fans).

        trimesh is optional and imported only here. ``metadata`` holds ``face_groups`` (index
        into ``group_names``, leaf cards in their leaf group) and ``n_bark_faces``."""
        include_leaves = flag(include_leaves, "include_leaves")
        try:
            import trimesh
        except ImportError as exc:
            raise ImportError(
                "Mesh.to_trimesh needs the optional package 'trimesh' (pip install trimesh); "
                "batecho itself does not depend on it"
            ) from exc
        verts = [self.bark_vertices]
        faces = [self.bark_faces]
        groups = [self.bark_face_groups]
        if include_leaves and self.leaves is not None:
            k = _check_sides(sides)
            cards = leaf_cards(self.leaves, k)
            base = len(self.bark_vertices) + k * np.arange(len(cards))[:, None, None]
            fan = np.array([[0, i, i + 1] for i in range(1, k - 1)], dtype=np.int64)
            verts.append(cards.reshape(-1, 3))
            faces.append((base + fan[None, :, :]).reshape(-1, 3))
            groups.append(np.repeat(self.leaf_groups, k - 2))
        return trimesh.Trimesh(
            vertices=np.concatenate(verts),
            faces=np.concatenate(faces),
            process=False,
            metadata={
                "group_names": list(self.group_names),
                "face_groups": np.concatenate(groups),
                "n_bark_faces": len(self.bark_faces),
                "source": None if self.source is None else str(self.source),
            },
        )

    def __repr__(self) -> str:
        src = "" if self.source is None else f", source={self.source.name!r}"
        return (
            f"Mesh(n_leaves={self.n_leaves}, bark_vertices={len(self.bark_vertices)}, "
            f"bark_faces={len(self.bark_faces)}, groups={list(self.group_names)}"
            f"{', degenerate=' + str(self.n_degenerate_faces) if self.n_degenerate_faces else ''}"
            f"{src})"
        )


def load_obj(
    path: str | os.PathLike,
    leaf_patterns: Sequence[str] | None = None,
    up: str = "z",
    per: str = "patch",
    scale: float = 1.0,
    transform: Any = None,
) -> Mesh:
    """Load a tree mesh from a Wavefront OBJ file.

    Parameters
    ----------
    path : str or path-like
        The OBJ file: a regular file (not a FIFO or a device) of at most
        :data:`MAX_OBJ_BYTES`. Only it and the MTL files in its own folder are read; an
        ``mtllib`` that is absolute, contains ``..`` or resolves outside that folder is
        refused (the check is made on the file as opened, so a link swapped meanwhile
        cannot lead outside). Object, group and
        material names may not hold control characters (the error names the file and line).
    leaf_patterns : list of str, optional
        Names (object, group or material) that mark leaf faces; case-insensitive; ``*`` and
        ``?`` make a pattern a glob over the whole name, otherwise it is a substring.
        Default :data:`DEFAULT_LEAF_PATTERNS`. Everything else is bark.
    up : {"z", "y"}
        The file's up axis. ``"y"`` (Blender's OBJ export default) maps
        ``(x, y, z) -> (x, -z, y)``; the result is always z-up.
    per : {"patch", "face"}
        One disk per connected patch of leaf faces (faces sharing a vertex) or per polygon.
    scale : float
        Unit scale, e.g. 0.01 for a file in centimetres (applied after ``up``).
    transform : (4, 4) array_like, optional
        Affine transform (last row ``0 0 0 1``) applied after ``up`` and ``scale``; normals
        follow the inverse-transpose, radii the area change.

    Returns
    -------
    Mesh
        ``.leaves`` is None (with an :class:`ObjWarning`) when no face is a leaf face.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ValueError
        The file cannot be read or understood (the message names the file, and the line where
        there is one), or an argument is out of range. TypeError for arguments of the wrong
        type.
    """
    p = _as_path(path, "path")
    if not p.exists():
        raise FileNotFoundError(f"OBJ file not found: {p}")
    if p.is_dir():
        raise IsADirectoryError(f"{p} is a folder, not an OBJ file")
    patterns = _patterns(leaf_patterns)
    up_ = _choice(up, "up", ("z", "y"))
    per_ = _choice(per, "per", ("patch", "face"))
    s = positive_scalar(scale, "scale")
    t = _transform(transform)
    (
        centers,
        normals,
        radii,
        areas,
        leaf_groups,
        bark_vertices,
        bark_faces,
        bark_groups,
        group_names,
        n_degenerate,
        messages,
    ) = _core.load_obj(p, patterns, per_, up_, s, t)
    for msg in messages:
        warnings.warn(msg, ObjWarning, stacklevel=2)
    try:
        leaves = Leaves(centers, normals, radii) if len(centers) else None
    except ValueError as exc:  # (a leaf beyond the bounds of Leaves: the file says where)
        raise ValueError(f"{p}: {exc}") from None
    return Mesh(
        leaves=leaves,
        bark_vertices=bark_vertices,
        bark_faces=bark_faces,
        leaf_areas=areas,
        leaf_groups=leaf_groups,
        bark_face_groups=bark_groups,
        group_names=group_names,
        n_degenerate_faces=n_degenerate,
        source=p,
        warnings=tuple(messages),
    )


def no_leaves_reason(mesh: Mesh, leaf_patterns: Sequence[str] | None = None) -> str:
    """Why a loaded ``mesh`` has no leaves, for an error: no name matches ``leaf_patterns``,
    or leaf faces there were but all degenerate (the loader's warning says which)."""
    if any("leaf faces gave a leaf" in w for w in mesh.warnings):
        return (
            "its leaf faces are all degenerate (~zero area, repeated vertices or cancelling "
            "normals; see its ObjWarning)"
        )
    patterns = list(DEFAULT_LEAF_PATTERNS if leaf_patterns is None else leaf_patterns)
    return (
        f"no leaf faces (no object, group or material name matches leaf_patterns {patterns}; "
        "pass leaf_patterns naming them)"
    )


def leaf_cards(leaves: Leaves, sides: int = 8) -> np.ndarray:
    """(n, sides, 3) vertices of regular polygons with each disk's centre, normal (counter-
    clockwise about it) and area: circumradius ``r * sqrt(2 pi / (sides sin(2 pi / sides)))``."""
    k = _check_sides(sides)
    c, nv, r = leaves.centers, leaves.normals, leaves.radii
    helper = np.zeros_like(nv)
    helper[np.arange(len(nv)), np.argmin(np.abs(nv), axis=1)] = 1.0
    u = crosses(nv, helper)
    u = u / norms(u)[:, None]
    v = crosses(nv, u)
    big_r = r * math.sqrt(2.0 * math.pi / (k * math.sin(2.0 * math.pi / k)))
    theta = 2.0 * np.pi * np.arange(k) / k
    ring = (
        np.cos(theta)[None, :, None] * u[:, None, :] + np.sin(theta)[None, :, None] * v[:, None, :]
    )
    return c[:, None, :] + big_r[:, None, None] * ring


def write_obj(
    path: str | os.PathLike,
    bark_vertices: Any = None,
    bark_faces: Any = None,
    leaves: Leaves | None = None,
    bark_groups: Any = None,
    *,
    bark_group_names: Sequence[str] | None = None,
    leaf_groups: Any = None,
    leaf_group_names: Sequence[str] | None = None,
    sides: int = 8,
    mtl: bool = True,
    comment: str | None = None,
) -> Path:
    """Write bark triangles and leaf disks as a Wavefront OBJ (z-up, metres), with an MTL file
    beside it (``path`` with suffix ``.mtl``) unless ``mtl=False``.

    Parameters
    ----------
    bark_vertices : (v, 3) array_like, optional
    bark_faces : (f, 3) int array_like, optional
        Triangles, 0-based indices into ``bark_vertices``.
    leaves : Leaves, optional
        Each disk is written as a regular ``sides``-gon card (see :func:`leaf_cards`) with its
        own vertices, so ``load_obj(path, per="patch")`` gives the same disks back.
    bark_groups : (f,) int array_like, optional
        Group of each bark face, an index into ``bark_group_names`` (default: all in the first
        name, ``"bark"`` when no names are given).
    bark_group_names, leaf_group_names : list of str, optional
        Names written as ``g`` and ``usemtl`` (one material each). Leaf group names should
        match the leaf patterns used to load the file back (default: one group ``"leaves"``).
    leaf_groups : (n,) int array_like, optional
        Group of each leaf, an index into ``leaf_group_names`` (default: all in the first).
    comment : str, optional
        A comment line written at the top.

    Returns
    -------
    pathlib.Path
        The OBJ path.
    """
    p = _as_path(path, "path")
    mtl = flag(mtl, "mtl")
    if p.suffix.lower() == ".mtl":
        raise ValueError(f"path {p} ends in .mtl; give the .obj path (the MTL goes beside it)")
    bv = _vertices(bark_vertices, "bark_vertices")
    bf = _faces(bark_faces, len(bv), "bark_faces")
    if leaves is not None and not isinstance(leaves, Leaves):
        raise TypeError(f"leaves must be Leaves or None, got {type(leaves).__name__}")
    n = 0 if leaves is None else len(leaves)
    k = _check_sides(sides)
    b_names = (
        ["bark"]
        if bark_group_names is None
        else [_check_name(s, "bark group name") for s in bark_group_names]
    )
    l_names = (
        ["leaves"]
        if leaf_group_names is None
        else [_check_name(s, "leaf group name") for s in leaf_group_names]
    )
    # Without group indices everything goes in the first name given (or "bark"/"leaves").
    bg = _groups(bark_groups, len(bf), b_names, b_names[0] if b_names else "bark", "bark_groups")
    lg = _groups(leaf_groups, n, l_names, l_names[0] if l_names else "leaves", "leaf_groups")
    for g in np.unique(bg):
        name = b_names[g]
        if any(_pattern_matches(pat, name) for pat in DEFAULT_LEAF_PATTERNS):
            warnings.warn(
                f"bark group {name!r} matches the default leaf patterns; load_obj with "
                "the default patterns would read it back as leaves",
                ObjWarning,
                stacklevel=2,
            )
    for g in np.unique(lg):
        if l_names[g] in {b_names[i] for i in np.unique(bg)}:
            raise ValueError(f"leaf group name {l_names[g]!r} is also a bark group name")

    mtl_path = p.with_suffix(".mtl")
    lines: list[str] = []
    if comment is not None:
        lines.extend("# " + c for c in str(comment).splitlines())
    lines.append(
        f"# batecho {_core.__version__}: {len(bf)} bark triangles, {n} leaves as "
        f"{k}-gon cards (z up, metres)"
    )
    if mtl:
        lines.append(f"mtllib {mtl_path.name}")
    lines.extend(f"v {x!r} {y!r} {z!r}" for x, y, z in bv.tolist())
    cards = leaf_cards(leaves, k).reshape(-1, 3) if leaves is not None else np.zeros((0, 3))
    lines.extend(f"v {x!r} {y!r} {z!r}" for x, y, z in cards.tolist())

    used: list[tuple[str, bool]] = []

    def open_group(name: str, leafy: bool) -> None:
        lines.append(f"g {name}")
        lines.append(f"usemtl {name}")
        if (name, leafy) not in used:
            used.append((name, leafy))

    current = None
    for (a, b, c), g in zip((bf + 1).tolist(), bg.tolist(), strict=False):
        if g != current:
            open_group(b_names[g], False)
            current = g
        lines.append(f"f {a} {b} {c}")
    current = None
    base = len(bv) + 1
    for i, g in enumerate(lg.tolist()):
        if g != current:
            open_group(l_names[g], True)
            current = g
        first = base + k * i
        lines.append("f " + " ".join(str(first + j) for j in range(k)))
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    if mtl:
        out = [f"# batecho {_core.__version__} materials for {p.name}"]
        for name, leafy in used:
            rgb = _LEAF_RGB if leafy else _BARK_RGB
            out += ["", f"newmtl {name}", "Kd {:g} {:g} {:g}".format(*rgb), "d 1", "illum 1"]
        mtl_path.write_text("\n".join(out) + "\n", encoding="utf-8")
    return p


# --- validation helpers -------------------------------------------------------------------


def _as_path(path: Any, name: str) -> Path:
    if isinstance(path, (str, os.PathLike)):
        return Path(path)
    raise TypeError(f"{name} must be a str or path-like, got {type(path).__name__}")


def _choice(value: Any, name: str, options: tuple[str, ...]) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be one of {options}, got {value!r}")
    v = value.lower()
    if v not in options:
        raise ValueError(f"{name} must be one of {options}, got {value!r}")
    return v


def _patterns(leaf_patterns: Any) -> list[str]:
    if leaf_patterns is None:
        return list(DEFAULT_LEAF_PATTERNS)
    if isinstance(leaf_patterns, str):
        raise TypeError(
            f"leaf_patterns must be a list of strings, e.g. [{leaf_patterns!r}]; "
            f"got the single string {leaf_patterns!r}"
        )
    try:
        pats = list(leaf_patterns)
    except TypeError:
        raise TypeError(
            f"leaf_patterns must be a list of strings, got {type(leaf_patterns).__name__}"
        ) from None
    for i, pat in enumerate(pats):
        if not isinstance(pat, str):
            raise TypeError(f"leaf_patterns[{i}] must be a str, got {type(pat).__name__}")
        if not pat.strip():
            raise ValueError(f"leaf_patterns[{i}] is empty; it would match every name")
    return pats


def _transform(transform: Any) -> np.ndarray | None:
    if transform is None:
        return None
    t = real_array(transform, "transform")
    if t.shape != (4, 4):
        raise ValueError(f"transform must have shape (4, 4), got {t.shape}")
    if not np.isfinite(t).all():
        raise ValueError("transform must be finite")
    if not np.array_equal(t[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"transform must be affine (last row 0 0 0 1), got last row {t[3]}")
    lin = t[:3, :3]
    det = float(np.linalg.det(lin))
    if not abs(det) > 1e-12 * float(np.prod(np.linalg.norm(lin, axis=1))):
        raise ValueError(
            f"transform is singular (its 3x3 part has determinant {det:g}); it "
            "would flatten the mesh"
        )
    return t


def _check_sides(sides: Any) -> int:
    if isinstance(sides, bool) or not isinstance(sides, (int, np.integer)):
        raise TypeError(f"sides must be an int >= 3, got {sides!r}")
    if sides < 3:
        raise ValueError(f"sides must be >= 3, got {sides}")
    return int(sides)


_BAD_NAME = re.compile(r"[\x00-\x1f\x7f]")


def _check_name(name: Any, what: str) -> str:
    if not isinstance(name, str):
        raise TypeError(f"{what} must be a str, got {type(name).__name__}")
    if not name or name != name.strip() or _BAD_NAME.search(name):
        raise ValueError(
            f"{what} {name!r} must be non-empty, without leading or trailing "
            "blanks or control characters (it is written as an OBJ name)"
        )
    return name


def _vertices(x: Any, name: str) -> np.ndarray:
    if x is None:
        return np.zeros((0, 3))
    arr = real_array(x, name)
    if arr.size == 0:
        return np.zeros((0, 3))
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (v, 3), got {arr.shape}")
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite")
    far = np.abs(arr) > MAX_COORDINATE_M
    if far.any():
        i = int(np.argwhere(far)[0, 0])
        raise ValueError(f"{name} {i} has a coordinate beyond {MAX_COORDINATE_M:g} m: {arr[i]}")
    return arr


def _faces(x: Any, n_vertices: int, name: str) -> np.ndarray:
    if x is None:
        return np.zeros((0, 3), dtype=np.int64)
    arr = np.asarray(x)
    if arr.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{name} must hold integer indices, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (f, 3), got {arr.shape}")
    arr = np.array(arr, dtype=np.int64, order="C")
    if arr.min() < 0 or arr.max() >= n_vertices:
        raise ValueError(
            f"{name} indices must be in [0, {n_vertices}), got {arr.min()}..{arr.max()}"
        )
    return arr


def _groups(x: Any, n: int, names: list[str], default: str, what: str) -> np.ndarray:
    """(n,) int64 indices into ``names``; None puts everything in ``default`` (appended to
    ``names`` if needed)."""
    if x is None:
        if n == 0:
            return np.zeros(0, dtype=np.int64)
        if default not in names:
            names.append(default)
        return np.full(n, names.index(default), dtype=np.int64)
    arr = np.asarray(x)
    if arr.size == 0 and n == 0:
        return np.zeros(0, dtype=np.int64)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"{what} must hold integer indices, got dtype {arr.dtype}")
    if arr.shape != (n,):
        raise ValueError(f"{what} must have shape ({n},), got {arr.shape}")
    arr = np.array(arr, dtype=np.int64)
    if n and (arr.min() < 0 or arr.max() >= len(names)):
        raise ValueError(
            f"{what} must index the {len(names)} group names, got {arr.min()}..{arr.max()}"
        )
    return arr


def _pattern_matches(pattern: str, name: str) -> bool:
    """The Rust core's rule: case-insensitive glob (``*``, ``?``) or substring."""
    p, s = pattern.lower(), name.lower()
    if "*" in p or "?" in p:
        rx = "".join(".*" if ch == "*" else "." if ch == "?" else re.escape(ch) for ch in p)
        return re.fullmatch(rx, s, flags=re.DOTALL) is not None
    return p in s


__all__ = [
    "DEFAULT_LEAF_PATTERNS",
    "MAX_OBJ_BYTES",
    "Mesh",
    "ObjWarning",
    "leaf_cards",
    "load_obj",
    "write_obj",
]
