"""ABOP's 3-D turtle (Prusinkiewicz & Lindenmayer, *The Algorithmic Beauty of Plants*): the
segments an L-system string draws, and the turtle states at chosen symbols.

Turtle conventions (ABOP p. 19): the turtle state is a position and the orthonormal frame
``[H L U]`` (heading, left, up; columns), right-handed with ``H x L = U``. It starts at the
origin with ``H = +z``, ``U = +x`` and so ``L = U x H = (0, -1, 0)``; rotations update the frame
as ``[H L U] <- [H L U] . R`` with the book's ``R_U``, ``R_L``, ``R_H``. Angles are in degrees,
lengths in the caller's unit (metres in batecho).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._equal import EqualByValue
from .._validate import finite_scalar, point3, positive_scalar
from .lsystem import parse_modules

__all__ = [
    "DEFAULT_ANGLE_DEG",
    "DEFAULT_WIDTH_DECREMENT",
    "Marks",
    "Segments",
    "rotation_h",
    "rotation_l",
    "rotation_u",
    "turtle",
]

#: Default turtle turning angle (degrees); ABOP's bracketed plants use 20-25.7 degrees.
DEFAULT_ANGLE_DEG = 25.0
#: Default width factor for ``!``: sqrt(1/2), da Vinci's rule for two equal daughter branches.
DEFAULT_WIDTH_DECREMENT = math.sqrt(0.5)


def rotation_u(angle_rad: float) -> np.ndarray:
    """ABOP's R_U(a): turn about the up vector; ``[H L U] . R_U(a)`` turns left for a > 0."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_l(angle_rad: float) -> np.ndarray:
    """ABOP's R_L(a): pitch about the left vector; pitches down for a > 0."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def rotation_h(angle_rad: float) -> np.ndarray:
    """ABOP's R_H(a): roll about the heading; rolls left for a > 0."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


# symbol -> (rotation axis, sign of the angle)
_ROTATIONS: dict[str, tuple[str, float]] = {
    "+": ("U", 1.0),
    "-": ("U", -1.0),
    "\u2212": ("U", -1.0),  # ABOP's typeset minus sign
    "&": ("L", 1.0),
    "^": ("L", -1.0),
    "\u2227": ("L", -1.0),  # ABOP's typeset wedge for pitch up
    "\\": ("H", 1.0),
    "/": ("H", -1.0),
}


@dataclass(frozen=True, eq=False)
class Marks(EqualByValue):
    """Turtle states recorded at the modules whose symbols were passed as ``marks``.

    ``symbols`` (m,) str array; ``params`` a list of parameter tuples; ``positions``,
    ``headings``, ``lefts``, ``ups`` (m, 3); ``widths`` (m,); ``depth`` (m,) bracket depth.
    """

    symbols: np.ndarray
    params: list[tuple[float, ...]]
    positions: np.ndarray
    headings: np.ndarray
    lefts: np.ndarray
    ups: np.ndarray
    widths: np.ndarray
    depth: np.ndarray

    def __len__(self) -> int:
        return int(self.positions.shape[0])


@dataclass(frozen=True, eq=False)
class Segments(EqualByValue):
    """The segments drawn by :func:`turtle`, one row per ``F``.

    ``starts``, ``ends`` (k, 3) float64 (length unit of ``step``); ``widths`` (k,) the width
    when drawn; ``depth`` (k,) int bracket nesting depth (0 on the main axis); ``headings``,
    ``lefts``, ``ups`` (k, 3) the turtle frame when the segment was drawn (the heading is the
    segment's direction, before tropism acts); ``marks`` the states recorded at ``marks``
    symbols.
    """

    starts: np.ndarray
    ends: np.ndarray
    widths: np.ndarray
    depth: np.ndarray
    headings: np.ndarray
    lefts: np.ndarray
    ups: np.ndarray
    marks: Marks

    def __len__(self) -> int:
        return int(self.starts.shape[0])

    @property
    def lengths(self) -> np.ndarray:
        """(k,) segment lengths."""
        d = self.ends - self.starts
        return np.sqrt(np.einsum("ij,ij->i", d, d))


def _unit(v: Any, name: str) -> np.ndarray:
    a = np.array(v, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite 3-vector, got {v!r}")
    n = float(np.linalg.norm(a))
    if n == 0:
        raise ValueError(f"{name} must be non-zero")
    return a / n


def turtle(
    string: str,
    step: float = 1.0,
    angle_deg: float = DEFAULT_ANGLE_DEG,
    *,
    width: float = 1.0,
    width_decrement: float = DEFAULT_WIDTH_DECREMENT,
    tropism: Sequence[float] | np.ndarray | None = None,
    elasticity: float = 0.0,
    origin: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    heading: Sequence[float] | np.ndarray = (0.0, 0.0, 1.0),
    up: Sequence[float] | np.ndarray = (1.0, 0.0, 0.0),
    marks: str = "",
) -> Segments:
    """Interpret an L-system string with ABOP's 3-D turtle.

    Commands (parameter, when given, replaces the default):

    ``F``/``F(l)`` draw a segment of length ``step``/``l`` and move; ``f``/``f(l)`` move without
    drawing; ``+``/``-`` turn left/right by ``angle_deg`` (R_U(+-a)); ``&``/``^`` pitch down/up
    (R_L(+-a)); ``\\``/``/`` roll left/right (R_H(+-a)); ``|`` turn around (R_U(180)); ``$``
    roll so that L is horizontal (L = V x H / |V x H|, V = +z); ``[``/``]`` push/pop the whole
    state (position, frame, width); ``!`` multiplies the width by ``width_decrement``, ``!(w)``
    sets it to ``w``. Angles in parameters are degrees. Modules with several parameters use the
    first. ABOP's typeset minus (U+2212) and wedge (U+2227) are read as ``-`` and ``^``.
    Other symbols are ignored, except that the states at symbols in ``marks`` are recorded.

    Tropism (ABOP p. 58): when ``tropism`` T is given and ``elasticity`` e != 0, after each ``F``
    the frame is rotated about ``H x T`` by ``e |H x T|`` radians, bending H towards T (T is not
    normalised: its length scales the effect). Gravity is ``T = (0, 0, -1)``.

    The turtle starts at ``origin`` with heading ``heading`` (default +z) and up ``up``
    (default +x; orthogonalised against the heading).

    Refused with ValueError, by name: a ``step``, ``width`` or ``width_decrement`` that is not
    finite and > 0, an ``F(l)`` with ``l < 0`` or a ``!(w)`` with ``w <= 0`` (by position),
    unbalanced brackets, and a string whose segments or marks leave float64 (an infinite
    position from lengths near 1e308) or whose widths underflow to 0.
    """
    mods = parse_modules(string)
    delta = math.radians(finite_scalar(angle_deg, "angle_deg"))
    step = positive_scalar(step, "step")
    w = positive_scalar(width, "width")
    wdec = positive_scalar(width_decrement, "width_decrement")
    e = finite_scalar(elasticity, "elasticity")
    tvec = None
    if tropism is not None and e != 0.0:
        tvec = point3(tropism, "tropism")
        if not math.isfinite(e * float(np.linalg.norm(tvec))):
            raise ValueError(
                f"elasticity * |tropism| must be finite, got {e!r} * {np.linalg.norm(tvec)!r}"
            )
    pos = point3(origin, "origin")
    h = _unit(heading, "heading")
    u = np.array(up, dtype=np.float64).reshape(-1) if np.shape(up) == (3,) else None
    if u is None or not np.isfinite(u).all():
        raise ValueError(f"up must be a finite 3-vector, got {up!r}")
    u = u - (u @ h) * h
    if np.linalg.norm(u) < 1e-12:
        raise ValueError("up must not be parallel to heading")
    u = u / np.linalg.norm(u)

    # The frame [H L U] (L = U x H) as 9 floats: each rotation mixes only two of the columns,
    # which is much faster in scalar Python than 3x3 NumPy products for strings of ~1e5 modules.
    hx, hy, hz = (float(x) for x in h)
    ux, uy, uz = (float(x) for x in u)
    frame: Frame = (hx, hy, hz, uy * hz - uz * hy, uz * hx - ux * hz, ux * hy - uy * hx, ux, uy, uz)
    px, py, pz = (float(x) for x in pos)
    default_turn = {
        sym: (axis, math.cos(sign * delta), math.sin(sign * delta))
        for sym, (axis, sign) in _ROTATIONS.items()
    }
    tt = None if tvec is None else (float(tvec[0]), float(tvec[1]), float(tvec[2]))
    marks_set = set(marks)
    stack: list[tuple[float, float, float, Frame, float, int]] = []
    rows: list[tuple[float, ...]] = []  # start, end, frame
    widths: list[float] = []
    depths: list[int] = []
    mk_sym: list[str] = []
    mk_par: list[tuple[float, ...]] = []
    mk_rows: list[tuple[float, ...]] = []  # position, frame
    mk_w: list[float] = []
    mk_d: list[int] = []

    for sym, params, where in mods:
        if sym == "F" or sym == "f":
            length = params[0] if params else step
            if length < 0 and sym == "F":
                raise ValueError(
                    f"the segment F({length!r}) at position {where} must have a length >= 0"
                )
            nx = px + length * frame[0]
            ny = py + length * frame[1]
            nz = pz + length * frame[2]
            if sym == "F":
                rows.append((px, py, pz, nx, ny, nz, *frame))
                widths.append(w)
                depths.append(len(stack))
                if tt is not None:
                    frame = _tropism_turn(frame, tt, e)
            px, py, pz = nx, ny, nz
        elif sym in _ROTATIONS:
            if params:
                axis, sign = _ROTATIONS[sym]
                a = sign * math.radians(params[0])
                frame = _turn(frame, axis, math.cos(a), math.sin(a))
            else:
                frame = _turn(frame, *default_turn[sym])
        elif sym == "[":
            stack.append((px, py, pz, frame, w, where))
        elif sym == "]":
            if not stack:
                raise ValueError(
                    f"unbalanced brackets: ']' at position {where} has no matching '['"
                )
            px, py, pz, frame, w, _ = stack.pop()
        elif sym == "|":
            frame = (
                -frame[0],
                -frame[1],
                -frame[2],
                -frame[3],
                -frame[4],
                -frame[5],
                frame[6],
                frame[7],
                frame[8],
            )
        elif sym == "!":
            if params and params[0] <= 0:
                raise ValueError(f"the width !({params[0]!r}) at position {where} must be > 0")
            w = params[0] if params else w * wdec
        elif sym == "$":
            frame = _roll_horizontal(frame)
        if sym in marks_set:
            mk_sym.append(sym)
            mk_par.append(params)
            mk_rows.append((px, py, pz, *frame))
            mk_w.append(w)
            mk_d.append(len(stack))
    if stack:
        raise ValueError(f"unbalanced brackets: '[' at position {stack[-1][5]} is never closed")

    seg = np.array(rows, dtype=np.float64).reshape(len(rows), 15)
    mk = np.array(mk_rows, dtype=np.float64).reshape(len(mk_rows), 12)
    seg_widths = np.array(widths, dtype=np.float64)
    _check_finite(seg, mk, seg_widths, mods, marks_set)
    marks_out = Marks(
        symbols=np.array(mk_sym, dtype="<U1"),
        params=mk_par,
        positions=mk[:, 0:3].copy(),
        headings=mk[:, 3:6].copy(),
        lefts=mk[:, 6:9].copy(),
        ups=mk[:, 9:12].copy(),
        widths=np.array(mk_w, dtype=np.float64),
        depth=np.array(mk_d, dtype=np.int64),
    )
    return Segments(
        starts=seg[:, 0:3].copy(),
        ends=seg[:, 3:6].copy(),
        widths=seg_widths,
        depth=np.array(depths, dtype=np.int64),
        headings=seg[:, 6:9].copy(),
        lefts=seg[:, 9:12].copy(),
        ups=seg[:, 12:15].copy(),
        marks=marks_out,
    )


Frame = tuple[float, float, float, float, float, float, float, float, float]


def _nth_position(mods: list[Any], symbols: Any, k: int) -> tuple[str, int]:
    """The symbol and string position of the ``k``-th module whose symbol is in ``symbols``."""
    n = -1
    for sym, _, where in mods:
        if sym in symbols:
            n += 1
            if n == k:
                return sym, where
    raise AssertionError("fewer modules than rows")  # pragma: no cover


def _check_finite(
    seg: np.ndarray, mk: np.ndarray, widths: np.ndarray, mods: list[Any], marks: set[str]
) -> None:
    """Refuse segments or marks that left float64 (lengths near 1e308 add up to inf) and
    widths that underflowed to 0, naming the module that drew them."""
    for rows, symbols, what in ((seg, "F", "segment"), (mk, marks, "mark")):
        bad = ~np.isfinite(rows).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            sym, where = _nth_position(mods, symbols, k)
            raise ValueError(
                f"the turtle's position is not finite at the {what} {sym!r} at position {where} "
                f"({what} {k}): the lengths before it add up beyond float64"
            )
    if len(widths) and not (widths > 0).all():
        k = int(np.argmax(~(widths > 0)))
        _, where = _nth_position(mods, "F", k)
        raise ValueError(
            f"the width of the segment 'F' at position {where} (segment {k}) underflows to 0; "
            "use fewer '!' or a larger width_decrement"
        )


def _turn(f: Frame, axis: str, c: float, s: float) -> Frame:
    """``[H L U] . R_axis(a)`` with ``c = cos a``, ``s = sin a`` (ABOP p. 19)."""
    hx, hy, hz, lx, ly, lz, ux, uy, uz = f
    if axis == "U":  # H' = c H - s L, L' = s H + c L
        return (
            c * hx - s * lx,
            c * hy - s * ly,
            c * hz - s * lz,
            s * hx + c * lx,
            s * hy + c * ly,
            s * hz + c * lz,
            ux,
            uy,
            uz,
        )
    if axis == "L":  # H' = c H + s U, U' = -s H + c U
        return (
            c * hx + s * ux,
            c * hy + s * uy,
            c * hz + s * uz,
            lx,
            ly,
            lz,
            c * ux - s * hx,
            c * uy - s * hy,
            c * uz - s * hz,
        )
    # "H": L' = c L + s U, U' = -s L + c U
    return (
        hx,
        hy,
        hz,
        c * lx + s * ux,
        c * ly + s * uy,
        c * lz + s * uz,
        c * ux - s * lx,
        c * uy - s * ly,
        c * uz - s * lz,
    )


def _tropism_turn(f: Frame, t: tuple[float, float, float], e: float) -> Frame:
    """Rotate the frame about H x T by e |H x T| radians (Rodrigues)."""
    hx, hy, hz = f[0], f[1], f[2]
    tx, ty, tz = t
    kx, ky, kz = hy * tz - hz * ty, hz * tx - hx * tz, hx * ty - hy * tx
    n = math.sqrt(kx * kx + ky * ky + kz * kz)
    if n < 1e-15:
        return f
    kx, ky, kz = kx / n, ky / n, kz / n
    c, s = math.cos(e * n), math.sin(e * n)
    out: list[float] = []
    for i in (0, 3, 6):
        vx, vy, vz = f[i], f[i + 1], f[i + 2]
        d = (1.0 - c) * (kx * vx + ky * vy + kz * vz)
        out += (
            c * vx + s * (ky * vz - kz * vy) + d * kx,
            c * vy + s * (kz * vx - kx * vz) + d * ky,
            c * vz + s * (kx * vy - ky * vx) + d * kz,
        )
    return tuple(out)  # type: ignore[return-value]


def _roll_horizontal(f: Frame) -> Frame:
    """ABOP's ``$``: L = V x H / |V x H| with V = +z, U = H x L; unchanged when H is vertical."""
    hx, hy, hz = f[0], f[1], f[2]
    lx, ly = -hy, hx  # V x H, z component 0
    n = math.sqrt(lx * lx + ly * ly)
    if n < 1e-12:
        return f
    lx, ly = lx / n, ly / n
    return (hx, hy, hz, lx, ly, 0.0, -hz * ly, hz * lx, hx * ly - hy * lx)
