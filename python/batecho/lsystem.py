"""L-systems (Prusinkiewicz & Lindenmayer, *The Algorithmic Beauty of Plants*, "ABOP") and a
3-D turtle, in pure Python + NumPy; plus :func:`trunk_branching`, the first-level branching of
a tree trunk grown with a parametric L-system.

Strings are sequences of *modules*: a one-character symbol, optionally followed by a
parenthesised, comma-separated list of numbers, e.g. ``F``, ``F(1.5)``, ``A(1,0.2)``.
Whitespace between modules is ignored; ``(``, ``)`` and ``,`` cannot be symbols.

Turtle conventions (ABOP p. 19): the turtle state is a position and the orthonormal frame
``[H L U]`` (heading, left, up; columns), right-handed with ``H x L = U``. It starts at the
origin with ``H = +z``, ``U = +x`` and so ``L = U x H = (0, -1, 0)``; rotations update the frame
as ``[H L U] <- [H L U] . R`` with the book's ``R_U``, ``R_L``, ``R_H``. Angles are in degrees,
lengths in the caller's unit (metres in batecho).
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

__all__ = [
    "DEFAULT_ANGLE_DEG",
    "Branching",
    "LSystem",
    "Marks",
    "Module",
    "Segments",
    "module_string",
    "parse_modules",
    "rotation_h",
    "rotation_l",
    "rotation_u",
    "trunk_branching",
    "turtle",
]

#: Default turtle turning angle (degrees); ABOP's bracketed plants use 20-25.7 degrees.
DEFAULT_ANGLE_DEG = 25.0
#: Default width factor for ``!``: sqrt(1/2), da Vinci's rule for two equal daughter branches.
DEFAULT_WIDTH_DECREMENT = math.sqrt(0.5)
#: Tolerance on the sum of the probabilities of a stochastic rule.
PROBABILITY_TOLERANCE = 1e-9

Successor = str | Callable[..., str | None]
RuleSpec = Successor | Sequence[tuple[float, Successor]]
SeedLike = int | np.random.Generator | None

# One token: a module (symbol + optional parameter list), whitespace, or a stray '(' ')' ','.
_TOKEN = re.compile(r"(?P<sym>[^\s(),])(?:\((?P<par>[^()]*)\))?|(?P<ws>\s+)|(?P<bad>[(),])")


# --------------------------------------------------------------------------------------------
# Parsing
# --------------------------------------------------------------------------------------------


class Module(NamedTuple):
    """One module of an L-system string.

    ``symbol`` is one character; ``params`` the parameters as floats (empty for a bare symbol);
    ``position`` the index of the symbol in the string.
    """

    symbol: str
    params: tuple[float, ...]
    position: int


def _bad_char_message(s: str, i: int) -> str:
    c = s[i]
    if c == ")":
        return f"unmatched ')' at position {i}"
    if c == ",":
        return f"',' at position {i} is outside a parameter list"
    close = s.find(")", i + 1)
    nxt = s.find("(", i + 1)
    if close < 0:
        return f"unbalanced '(' at position {i}: no closing ')'"
    if 0 <= nxt < close:
        return f"nested '(' at position {nxt} inside the parameter list opened at position {i}"
    return f"'(' at position {i} does not directly follow a module symbol"


def _scan(s: str) -> list[tuple[str, str | None, int, int]]:
    """Structural tokenisation: ``(symbol, parameter text or None, start, end)`` per module.

    Whitespace tokens are returned with symbol ``""``. Raises ValueError on stray parentheses
    or commas; parameter texts are not converted (see :func:`_params`).
    """
    out = []
    for m in _TOKEN.finditer(s):
        sym = m.group("sym")
        if sym is not None:
            out.append((sym, m.group("par"), m.start(), m.end()))
        elif m.group("ws") is not None:
            out.append(("", None, m.start(), m.end()))
        else:
            raise ValueError(f"malformed module string: {_bad_char_message(s, m.start())}")
    return out


def _params(text: str | None, sym: str, pos: int) -> tuple[float, ...]:
    """Parameters of the module ``sym`` at ``pos`` as finite floats."""
    if text is None:
        return ()
    if not text.strip():
        raise ValueError(f"module {sym!r} at position {pos} has an empty parameter list")
    vals = []
    offset = pos + 2  # first character after "S("
    for part in text.split(","):
        try:
            v = float(part)
        except ValueError:
            v = None
        if v is None or not math.isfinite(v):
            what = "is not a number" if v is None else "is not finite"
            raise ValueError(
                f"module {sym!r} at position {pos}: parameter {part.strip()!r} "
                f"(position {offset}) {what}"
            ) from None
        vals.append(v)
        offset += len(part) + 1
    return tuple(vals)


def parse_modules(string: str) -> list[Module]:
    """Split an L-system string into :class:`Module` s (whitespace skipped).

    Raises ValueError, naming the position, for unbalanced or nested parentheses, stray commas,
    empty parameter lists and parameters that are not finite numbers.
    """
    if not isinstance(string, str):
        raise TypeError(f"an L-system string must be a str, got {type(string).__name__}")
    return [
        Module(sym, _params(par, sym, start), start) for sym, par, start, _ in _scan(string) if sym
    ]


def module_string(symbol: str, *params: float) -> str:
    """Format one module, e.g. ``module_string("F", 1.5) == "F(1.5)"``; floats are written
    with ``repr`` so they round-trip exactly."""
    _check_symbol(symbol)
    if not params:
        return symbol
    return symbol + "(" + ",".join(repr(float(p)) for p in params) + ")"


def _check_symbol(symbol: Any) -> None:
    if not isinstance(symbol, str) or len(symbol) != 1 or symbol.isspace() or symbol in "(),":
        raise ValueError(
            f"a module symbol must be one character other than whitespace, '(', ')' or ',';"
            f" got {symbol!r}"
        )


# --------------------------------------------------------------------------------------------
# L-systems
# --------------------------------------------------------------------------------------------


class _Rule:
    """The production(s) of one symbol: successors (strings or callables) and, when
    stochastic, their cumulative probabilities."""

    __slots__ = ("cum", "last", "successors")

    def __init__(self, symbol: str, spec: Any):
        if isinstance(spec, str) or callable(spec):
            self.successors = [_check_successor(symbol, spec)]
            self.cum = None
            self.last = 0
            return
        if not isinstance(spec, Sequence) or len(spec) == 0:
            raise TypeError(
                f"the rule for {symbol!r} must be a successor string, a callable, or a non-empty"
                f" list of (probability, successor) pairs; got {spec!r}"
            )
        probs, succs = [], []
        for k, pair in enumerate(spec):
            if not (isinstance(pair, Sequence) and not isinstance(pair, str) and len(pair) == 2):
                raise ValueError(
                    f"alternative {k} of the stochastic rule for {symbol!r} must be a"
                    f" (probability, successor) pair; got {pair!r}"
                )
            p, succ = pair
            if isinstance(p, bool) or not isinstance(p, numbers.Real):
                raise TypeError(
                    f"probability {k} of the rule for {symbol!r} must be a real number; got {p!r}"
                )
            p = float(p)
            if not math.isfinite(p) or p < 0:
                raise ValueError(
                    f"probability {k} of the rule for {symbol!r} is {p}, not in [0, 1]"
                )
            probs.append(p)
            succs.append(_check_successor(symbol, succ))
        total = math.fsum(probs)
        if abs(total - 1.0) > PROBABILITY_TOLERANCE:
            raise ValueError(
                f"the probabilities of the stochastic rule for {symbol!r} sum to {total!r}, not 1"
                f" (tolerance {PROBABILITY_TOLERANCE:g})"
            )
        self.successors = succs
        self.cum = np.cumsum(probs)
        self.last = max(k for k, p in enumerate(probs) if p > 0)

    def pick(self, u: float) -> Successor:
        if self.cum is None:
            return self.successors[0]
        k = int(np.searchsorted(self.cum, u, side="right"))
        return self.successors[min(k, self.last)]


def _check_successor(symbol: str, succ: Any) -> Successor:
    if isinstance(succ, str):
        try:
            parse_modules(succ)
        except ValueError as exc:
            raise ValueError(f"the successor {succ!r} of {symbol!r} is malformed: {exc}") from None
        return succ
    if callable(succ):
        return succ
    raise TypeError(
        f"a successor of {symbol!r} must be a string or a callable; got {type(succ).__name__}"
    )


class LSystem:
    """A (stochastic, parametric) context-free L-system.

    Parameters
    ----------
    axiom : str
        The initial string, e.g. ``"F"`` or ``"B(2)A(4,4)"``.
    rules : mapping
        Symbol (one character) -> production. A production is

        * a successor string (``"F[+F]F[-F]F"``), which replaces the module whatever its
          parameters;
        * a callable taking the module's parameters as floats (no arguments for a bare symbol)
          and returning the successor string, or None for "no production applies, keep the
          module" (conditions and arithmetic in plain Python; ABOP section 1.10), e.g.
          ``lambda s: f"F({s})[+A({s / 1.5})][-A({s / 1.5})]"``;
        * a list of ``(probability, successor)`` pairs, successors as above; probabilities must
          be >= 0 and sum to 1 within 1e-9 (ABOP section 1.7).

        Symbols without a rule are copied unchanged (identity production).
    seed : int, numpy.random.Generator or None
        Seeds ``numpy.random.default_rng`` for the stochastic choices. The generator is kept:
        successive :meth:`derive` calls continue its stream; equal seeds give equal strings.

    Callables may draw their own random numbers (e.g. from the same Generator) for parameter
    jitter. Successor strings returned by callables are validated when produced.
    """

    def __init__(self, axiom: str, rules: Mapping[str, RuleSpec], seed: SeedLike = None):
        if not isinstance(axiom, str):
            raise TypeError(f"axiom must be a str, got {type(axiom).__name__}")
        try:
            parse_modules(axiom)
        except ValueError as exc:
            raise ValueError(f"the axiom {axiom!r} is malformed: {exc}") from None
        if not isinstance(rules, Mapping):
            raise TypeError(f"rules must be a mapping symbol -> production, got {rules!r}")
        self._axiom = axiom
        self._rules: dict[str, _Rule] = {}
        for sym, spec in rules.items():
            _check_symbol(sym)
            self._rules[sym] = _Rule(sym, spec)
        self._spec = dict(rules)
        self._stochastic = any(r.cum is not None for r in self._rules.values())
        simple = all(
            r.cum is None and isinstance(r.successors[0], str) for r in self._rules.values()
        )
        # Deterministic string rules on a string without parameters: str.translate rewrites
        # every symbol in parallel, exactly.
        self._table = {ord(s): r.successors[0] for s, r in self._rules.items()} if simple else None
        self._rng = np.random.default_rng(seed)

    @property
    def axiom(self) -> str:
        return self._axiom

    @property
    def rules(self) -> dict[str, RuleSpec]:
        """A copy of the rules as given."""
        return dict(self._spec)

    @property
    def stochastic(self) -> bool:
        return self._stochastic

    def __repr__(self) -> str:
        return f"LSystem(axiom={self._axiom!r}, rules={self._spec!r})"

    def derive(self, n: int, rng: SeedLike = None) -> str:
        """The string after ``n`` parallel rewriting steps (``n = 0`` gives the axiom).

        ``rng`` (int or Generator), when given, is used instead of the system's generator.
        """
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 0:
            raise ValueError(f"n must be an integer >= 0, got {n!r}")
        gen = self._rng if rng is None else np.random.default_rng(rng)
        s = self._axiom
        for _ in range(int(n)):
            s = self._rewrite(s, gen)
        return s

    def _rewrite(self, s: str, gen: np.random.Generator) -> str:
        if self._table is not None and "(" not in s:
            return s.translate(self._table)
        tokens = _scan(s)
        u = gen.random(len(tokens)) if self._stochastic else None
        rules = self._rules
        out = []
        for i, (sym, par, start, end) in enumerate(tokens):
            rule = rules.get(sym) if sym else None
            if rule is None:
                out.append(s[start:end])
                continue
            succ = rule.pick(u[i]) if u is not None else rule.successors[0]
            if not isinstance(succ, str):
                result = succ(*_params(par, sym, start))
                if result is None:
                    out.append(s[start:end])
                    continue
                if not isinstance(result, str):
                    raise TypeError(
                        f"the rule for {sym!r} returned {type(result).__name__} for the module"
                        f" {s[start:end]!r}; expected a str or None"
                    )
                try:
                    parse_modules(result)
                except ValueError as exc:
                    raise ValueError(
                        f"the rule for {sym!r} applied to {s[start:end]!r} (position {start})"
                        f" returned the malformed successor {result!r}: {exc}"
                    ) from None
                succ = result
            out.append(succ)
        return "".join(out)


# --------------------------------------------------------------------------------------------
# Turtle
# --------------------------------------------------------------------------------------------


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


@dataclass(frozen=True)
class Marks:
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


@dataclass(frozen=True)
class Segments:
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


def _finite(x: Any, name: str) -> float:
    v = float(x)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {x!r}")
    return v


def turtle(
    string: str,
    step: float = 1.0,
    angle_deg: float = DEFAULT_ANGLE_DEG,
    *,
    width: float = 1.0,
    width_decrement: float = DEFAULT_WIDTH_DECREMENT,
    tropism: Sequence[float] | None = None,
    elasticity: float = 0.0,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    heading: Sequence[float] = (0.0, 0.0, 1.0),
    up: Sequence[float] = (1.0, 0.0, 0.0),
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
    (default +x; orthogonalised against the heading). Unbalanced brackets raise ValueError.
    """
    mods = parse_modules(string)
    delta = math.radians(_finite(angle_deg, "angle_deg"))
    step = _finite(step, "step")
    w = _finite(width, "width")
    wdec = _finite(width_decrement, "width_decrement")
    e = _finite(elasticity, "elasticity")
    tvec = None
    if tropism is not None and e != 0.0:
        tvec = np.array(tropism, dtype=np.float64).reshape(-1)
        if tvec.shape != (3,) or not np.isfinite(tvec).all():
            raise ValueError(f"tropism must be a finite 3-vector, got {tropism!r}")
    pos = np.array(origin, dtype=np.float64).reshape(-1)
    if pos.shape != (3,) or not np.isfinite(pos).all():
        raise ValueError(f"origin must be a finite 3-vector, got {origin!r}")
    h = _unit(heading, "heading")
    u = np.array(up, dtype=np.float64).reshape(-1) if np.shape(up) == (3,) else None
    if u is None or not np.isfinite(u).all():
        raise ValueError(f"up must be a finite 3-vector, got {up!r}")
    u = u - (u @ h) * h
    if np.linalg.norm(u) < 1e-12:
        raise ValueError("up must not be parallel to heading")
    u = u / np.linalg.norm(u)
    frame = np.column_stack([h, np.cross(u, h), u])  # [H L U], L = U x H

    # The frame as 9 floats (H, L, U): each rotation mixes only two of the columns, which is much
    # faster in scalar Python than 3x3 NumPy products for strings of ~1e5 modules.
    hx, hy, hz = (float(x) for x in h)
    ux, uy, uz = (float(x) for x in u)
    frame = (hx, hy, hz, uy * hz - uz * hy, uz * hx - ux * hz, ux * hy - uy * hx, ux, uy, uz)
    px, py, pz = (float(x) for x in pos)
    default_turn = {
        sym: (axis, math.cos(sign * delta), math.sin(sign * delta))
        for sym, (axis, sign) in _ROTATIONS.items()
    }
    tt = None if tvec is None else (float(tvec[0]), float(tvec[1]), float(tvec[2]))
    marks_set = set(marks)
    stack: list[tuple[float, float, float, tuple[float, ...], float, int]] = []
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
            frame = (-frame[0], -frame[1], -frame[2], -frame[3], -frame[4], -frame[5], *frame[6:])
        elif sym == "!":
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
        widths=np.array(widths, dtype=np.float64),
        depth=np.array(depths, dtype=np.int64),
        headings=seg[:, 6:9].copy(),
        lefts=seg[:, 9:12].copy(),
        ups=seg[:, 12:15].copy(),
        marks=marks_out,
    )


Frame = tuple[float, float, float, float, float, float, float, float, float]


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


# --------------------------------------------------------------------------------------------
# First-level branching of a trunk
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Branching:
    """Where the first-level branches leave a (straight) trunk, and in which directions.

    ``trunk_base``, ``trunk_top`` (3,) m; ``origins`` (b, 3) m, points on the trunk axis;
    ``directions`` (b, 3) unit vectors; ``lengths`` (b,) suggested branch lengths, m;
    ``heights`` (b,) heights of the origins along the trunk above its base, m, non-decreasing;
    ``lsystem_string`` the derived L-system string (trunk ``F(l)``, branch buds ``B(length)``).
    """

    trunk_base: np.ndarray
    trunk_top: np.ndarray
    origins: np.ndarray
    directions: np.ndarray
    lengths: np.ndarray
    heights: np.ndarray
    lsystem_string: str

    def __len__(self) -> int:
        return int(self.origins.shape[0])


def trunk_branching(
    rng: SeedLike = None,
    *,
    trunk_height: float = 7.0,
    n_branches: int = 9,
    first_branch_height: float = 2.0,
    branching_angle_deg: float = 50.0,
    divergence_deg: float = 137.5,
    buds_per_node: int = 1,
    contraction: float = 0.85,
    branch_length: float = 3.0,
    base: Sequence[float] = (0.0, 0.0, 0.0),
    angle_jitter_deg: float = 5.0,
    divergence_jitter_deg: float = 10.0,
    internode_jitter: float = 0.15,
    length_jitter: float = 0.1,
) -> Branching:
    """First-level branching of a vertical trunk, grown with a parametric L-system.

    The axiom ``/(phi0) F(h0) A(b, h0)`` (random initial azimuth ``phi0``) grows one node per
    step by ``A(b, h) -> [/(0)&(theta)B(len)]...[/(360 (m-1)/m)&(theta)B(len)] F(l) /(d)
    A(b - m, h + l)``: a node of ``m = buds_per_node`` lateral buds ``B`` at height ``h``, an
    internode ``l`` and a roll by the divergence angle ``d``; the last node ends the trunk with
    ``F(trunk_height - h)``. Internodes contract geometrically upwards (each ~``contraction``
    times the one below; the node heights and the top fill ``[first_branch_height,
    trunk_height]`` exactly), and the random jitters below are drawn from ``rng``.

    Parameters (metres, degrees)
    ----------
    rng : numpy.random.Generator, int or None
        Source of randomness; the same seed gives the same branching.
    trunk_height : float
        Height of the trunk top above ``base``, m (> 0).
    n_branches : int
        Number of first-level branches (>= 0).
    first_branch_height : float
        Height of the lowest node, m, in ``[0, trunk_height)``.
    branching_angle_deg : float
        Angle between each branch and the trunk (upward) axis, degrees, in (0, 180).
    divergence_deg : float
        Roll between successive nodes, degrees (137.5: the golden-angle spiral of alternate
        phyllotaxis; use 90 with ``buds_per_node=2`` for decussate trees such as maples).
    buds_per_node : int
        Branches per node (1 spiral, 2 opposite, >= 3 whorled), spread evenly in azimuth.
    contraction : float
        Ratio of successive internode lengths (> 0; < 1 crowds branches towards the top).
    branch_length : float
        Longest suggested branch length, m; lengths follow an ovoid-crown profile over the
        relative node height t in [0, 1]: ``0.5 + 0.5 sin(pi (0.25 + 0.75 t))`` (longest at
        t = 1/3, half at the top).
    base : 3-vector
        Trunk base, m; the trunk runs straight up (+z) to ``base + (0, 0, trunk_height)``.
    angle_jitter_deg, divergence_jitter_deg : float
        Half-widths of uniform jitters on the branching and divergence angles, degrees.
    internode_jitter, length_jitter : float
        Relative half-widths of uniform jitters on internode lengths (< 0.5) and branch lengths
        (< 1).
    """
    gen = np.random.default_rng(rng)
    height = _finite(trunk_height, "trunk_height")
    h0 = _finite(first_branch_height, "first_branch_height")
    theta0 = _finite(branching_angle_deg, "branching_angle_deg")
    div = _finite(divergence_deg, "divergence_deg")
    r = _finite(contraction, "contraction")
    lmax = _finite(branch_length, "branch_length")
    ajit = _finite(angle_jitter_deg, "angle_jitter_deg")
    djit = _finite(divergence_jitter_deg, "divergence_jitter_deg")
    ijit = _finite(internode_jitter, "internode_jitter")
    ljit = _finite(length_jitter, "length_jitter")
    if height <= 0:
        raise ValueError(f"trunk_height must be > 0 m, got {trunk_height!r}")
    if not 0 <= h0 < height:
        raise ValueError(f"first_branch_height must be in [0, trunk_height={height}) m, got {h0!r}")
    if (
        isinstance(n_branches, bool)
        or not isinstance(n_branches, numbers.Integral)
        or (n_branches < 0)
    ):
        raise ValueError(f"n_branches must be an integer >= 0, got {n_branches!r}")
    if (
        isinstance(buds_per_node, bool)
        or not isinstance(buds_per_node, numbers.Integral)
        or (buds_per_node < 1)
    ):
        raise ValueError(f"buds_per_node must be an integer >= 1, got {buds_per_node!r}")
    if not 0 < theta0 < 180:
        raise ValueError(f"branching_angle_deg must be in (0, 180), got {branching_angle_deg!r}")
    if r <= 0:
        raise ValueError(f"contraction must be > 0, got {contraction!r}")
    if lmax <= 0:
        raise ValueError(f"branch_length must be > 0 m, got {branch_length!r}")
    if min(ajit, djit, ijit, ljit) < 0 or ijit >= 0.5 or ljit >= 1:
        raise ValueError(
            "jitters must be >= 0, internode_jitter < 0.5 and length_jitter < 1; got "
            f"{ajit}, {djit}, {ijit}, {ljit}"
        )
    n = int(n_branches)
    m = int(buds_per_node)
    base_v = np.array(base, dtype=np.float64).reshape(-1)
    if base_v.shape != (3,) or not np.isfinite(base_v).all():
        raise ValueError(f"base must be a finite 3-vector, got {base!r}")
    span = height - h0

    def f(x: float) -> str:
        return repr(float(x))

    def grow(b_param: float, h: float) -> str:
        b = round(b_param)
        here = min(m, b)
        t = (h - h0) / span
        buds = []
        for j in range(here):
            theta = min(max(theta0 + ajit * gen.uniform(-1.0, 1.0), 0.0), 180.0)
            profile = 0.5 + 0.5 * math.sin(math.pi * (0.25 + 0.75 * t))
            length = lmax * profile * (1.0 + ljit * gen.uniform(-1.0, 1.0))
            buds.append(f"[/({f(360.0 * j / m)})&({f(theta)})B({f(length)})]")
        left = b - here
        if left <= 0:
            return "".join(buds) + f"F({f(height - h)})"
        k = -(-left // m) + 1  # internodes still to grow, the top one included
        frac = 1.0 / k if abs(1.0 - r) < 1e-12 else (1.0 - r) / (1.0 - r**k)
        frac = min(frac * (1.0 + ijit * gen.uniform(-1.0, 1.0)), 0.95)
        internode = (height - h) * frac
        turn = div + djit * gen.uniform(-1.0, 1.0)
        return "".join(buds) + f"F({f(internode)})/({f(turn)})A({left},{f(h + internode)})"

    phi0 = gen.uniform(0.0, 360.0)
    if n == 0:
        axiom = f"F({f(height)})"
    else:
        axiom = f"/({f(phi0)})F({f(h0)})A({n},{f(h0)})"
    system = LSystem(axiom, {"A": grow}, seed=gen)
    string = system.derive(-(-n // m))
    seg = turtle(string, origin=base_v, marks="B")
    mk = seg.marks
    origins = mk.positions
    dirs = mk.headings / np.linalg.norm(mk.headings, axis=1)[:, None]
    heights = origins[:, 2] - base_v[2]
    return Branching(
        trunk_base=base_v,
        trunk_top=base_v + np.array([0.0, 0.0, height]),
        origins=origins,
        directions=dirs,
        lengths=np.array([p[0] for p in mk.params], dtype=np.float64),
        heights=heights,
        lsystem_string=string,
    )
