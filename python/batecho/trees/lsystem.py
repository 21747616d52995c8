"""L-systems (Prusinkiewicz & Lindenmayer, *The Algorithmic Beauty of Plants*, "ABOP"): module
strings, their parsing, and (stochastic, parametric) context-free rewriting, in pure Python +
NumPy. The turtle that draws them is :mod:`batecho.trees.turtle`.

Strings are sequences of *modules*: a one-character symbol, optionally followed by a
parenthesised, comma-separated list of numbers, e.g. ``F``, ``F(1.5)``, ``A(1,0.2)``.
Whitespace between modules is ignored; ``(``, ``)`` and ``,`` cannot be symbols.
"""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple, cast

import numpy as np

from .._resources import check_memory, memory_limit, warn_if_slow
from .._validate import integer

__all__ = [
    "PROBABILITY_TOLERANCE",
    "LSystem",
    "Module",
    "RuleSpec",
    "SeedLike",
    "Successor",
    "module_string",
    "parse_modules",
]

#: Tolerance on the sum of the probabilities of a stochastic rule.
PROBABILITY_TOLERANCE = 1e-9

#: Memory per module of a string rewritten module by module (bytes): its parsed token and its
#: piece of the new string (strings with parameters, or rules that are not all deterministic
#: strings); a string rewritten by ``str.translate`` needs only its characters.
BYTES_PER_MODULE = 200.0
#: Time per module rewritten module by module, and per character translated (s).
S_PER_MODULE = 2e-6
S_PER_CHAR = 1e-8
#: Time per rewriting step, whatever the string (s).
S_PER_STEP = 2e-7
#: How a slow derivation is made shorter.
FEWER = "derive fewer steps (n)"

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

    Notes
    -----
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
        self._table = (
            {ord(s): cast(str, r.successors[0]) for s, r in self._rules.items()} if simple else None
        )
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

        The string must fit :func:`batecho.memory_limit`: with string rules its length after
        every step is bounded before the first (from each symbol's longest successor; exact for
        deterministic rules) and a derivation that cannot fit raises MemoryError at once, one
        expected to rewrite for over a minute warns (:class:`batecho._resources.SlowWarning`);
        with callable rules, whose results are known only when called, MemoryError is raised
        during the step that would outgrow the limit.
        """
        steps = integer(n, "n", 0)
        gen = self._rng if rng is None else np.random.default_rng(rng)
        limit = memory_limit()
        # String rules are bounded before the first step; a callable's result only when it
        # is called, so a system with callables is checked as it rewrites.
        watch = None
        if self._string_rules:
            self._guard(steps, limit)
        s = self._axiom
        for k in range(steps):
            if not self._string_rules:
                watch = (steps, k, limit)
            s = self._rewrite(s, gen, watch)
        return s

    @property
    def _string_rules(self) -> bool:
        return all(isinstance(x, str) for r in self._rules.values() for x in r.successors)

    def _guard(self, steps: int, limit: int) -> None:
        """Before deriving with string rules: the string's length after each step, bounded
        from each symbol's longest successor (exact for deterministic rules) without building
        it, must fit the memory limit; a derivation of more than a minute warns first."""
        texts = [self._axiom, *(cast(str, x) for r in self._rules.values() for x in r.successors)]
        width = 1 if all(t.isascii() for t in texts) else 4  # bytes per character, at most
        slow = self._table is None or any("(" in t for t in texts)
        ruled = set(self._rules)

        def parts(text: str) -> tuple[dict[str, int], int, int, int]:
            """Ruled modules by symbol, their characters, the other characters and tokens."""
            counts: dict[str, int] = {}
            r_chars = 0
            other = 0
            for sym, _, start, end in _scan(text):
                if sym in ruled:
                    counts[sym] = counts.get(sym, 0) + 1
                    r_chars += end - start
                else:
                    other += 1
            return counts, r_chars, len(text) - r_chars, other

        # per ruled symbol, the most each of its successors gives of every part
        grow: dict[str, tuple[dict[str, int], int, int, int]] = {}
        for sym, rule in self._rules.items():
            alts = [parts(cast(str, x)) for x in rule.successors]
            most: dict[str, int] = {}
            for counts, _, _, _ in alts:
                for t, c in counts.items():
                    most[t] = max(most.get(t, 0), c)
            grow[sym] = (
                most,
                max(a[1] for a in alts),
                max(a[2] for a in alts),
                max(a[3] for a in alts),
            )
        counts, r_chars, f_chars, f_tokens = parts(self._axiom)
        peak = 0.0
        seconds = 0.0
        # (the bound below walks the steps one by one: so many steps are slow whatever the
        # string, and say so before that walk)
        warned = warn_if_slow(steps * S_PER_STEP, f"LSystem.derive(n={steps})", FEWER, 3)
        k = 0
        while k < steps:
            length = r_chars + f_chars
            tokens = sum(counts.values()) + f_tokens
            new: dict[str, int] = {}
            nr, nf, nt = 0, f_chars, f_tokens
            for sym, c in counts.items():
                most, gr, gf, gt = grow[sym]
                for t, m in most.items():
                    new[t] = new.get(t, 0) + c * m
                nr += c * gr
                nf += c * gf
                nt += c * gt
            step_s = S_PER_STEP + (tokens * S_PER_MODULE if slow else length * S_PER_CHAR)
            if new == counts and nr == r_chars:
                # the same ruled modules from now on: each step adds the same characters
                left = steps - k
                d_chars, d_tokens = nf - f_chars, nt - f_tokens
                last = length + (left - 1) * d_chars
                last_tokens = tokens + (left - 1) * d_tokens
                peak = max(
                    peak, width * (2 * last + d_chars) + slow * last_tokens * BYTES_PER_MODULE
                )
                slope = S_PER_MODULE * d_tokens if slow else S_PER_CHAR * d_chars
                seconds += left * step_s + slope * left * (left - 1) / 2
                k = steps
                break
            counts, r_chars, f_chars, f_tokens = new, nr, nf, nt
            k += 1
            need = width * (length + r_chars + f_chars) + slow * tokens * BYTES_PER_MODULE
            peak = max(peak, need)
            seconds += step_s
            if need > limit:
                break
        check_memory(
            peak,
            f"LSystem.derive(n={steps}) (a string of about {(r_chars + f_chars):.3g} characters "
            f"at step {k})",
            "derive fewer steps (n), or use rules that grow less",
        )
        if not warned:
            warn_if_slow(seconds, f"LSystem.derive(n={steps})", FEWER, 3)

    def _rewrite(
        self, s: str, gen: np.random.Generator, watch: tuple[int, int, int] | None = None
    ) -> str:
        """One parallel rewriting step. With ``watch`` = (steps, step, limit), refuse with
        MemoryError as soon as the step would outgrow ``limit`` bytes."""
        if self._table is not None and "(" not in s:
            return s.translate(self._table)
        room = math.inf
        if watch is not None:
            steps, step, limit = watch
            # tokens: at most one per character, less 3 per '(' and 2 per ',' ("X(a,b)")
            most = len(s) - 3 * s.count("(") - 2 * s.count(",")
            room = limit - len(s) - most * BYTES_PER_MODULE
            if room < 0:
                self._refuse(limit - room, steps, step, "")
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
                room -= BYTES_PER_MODULE
            room -= len(succ)
            if room < 0:
                assert watch is not None
                where = f", at the module {s[start:end]!r} at position {start}"
                self._refuse(watch[2] - room, watch[0], watch[1], where)
            out.append(succ)
        return "".join(out)

    @staticmethod
    def _refuse(nbytes: float, steps: int, step: int, where: str) -> None:
        check_memory(
            nbytes,
            f"LSystem.derive(n={steps}) (step {step + 1} of the rewriting{where})",
            "derive fewer steps (n), or use rules that grow less",
        )
