"""The first-level branching of a tree trunk (:func:`trunk_branching`), grown with a
parametric L-system: where the branches leave the trunk, in which directions, and their
suggested lengths."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._equal import EqualByValue
from .._resources import check_memory, warn_if_slow
from .._validate import finite_scalar, integer, point3
from .lsystem import LSystem, SeedLike
from .turtle import turtle

__all__ = ["Branching", "trunk_branching"]

#: Memory per first-level branch of a trunk's branching (bytes): its bud's modules in the
#: L-system string and the turtle's mark.
BYTES_PER_BUD = 4096.0
#: Time per bud per rewriting step (s): each of the ``n / buds_per_node`` steps rewrites the
#: whole string grown so far, so a branching takes about this times ``n^2 / buds_per_node``.
S_PER_BUD_STEP = 8e-6


def branching_seconds(n_branches: int, buds_per_node: int) -> float:
    """About how long (s) :func:`trunk_branching` takes for ``n_branches``."""
    return S_PER_BUD_STEP * n_branches * -(-n_branches // buds_per_node)


@dataclass(frozen=True, eq=False)
class Branching(EqualByValue):
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

    Parameters (metres, degrees; real numbers, not bools or strings: TypeError)
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

    The time grows as ``n_branches^2 / buds_per_node`` (each step rewrites the whole string):
    a branching of minutes warns first (:class:`batecho._resources.SlowWarning`), and one too
    large for :func:`batecho.memory_limit` raises MemoryError.
    """
    gen = np.random.default_rng(rng)
    height = finite_scalar(trunk_height, "trunk_height", strict=True)
    h0 = finite_scalar(first_branch_height, "first_branch_height", strict=True)
    theta0 = finite_scalar(branching_angle_deg, "branching_angle_deg", strict=True)
    div = finite_scalar(divergence_deg, "divergence_deg", strict=True)
    r = finite_scalar(contraction, "contraction", strict=True)
    lmax = finite_scalar(branch_length, "branch_length", strict=True)
    ajit = finite_scalar(angle_jitter_deg, "angle_jitter_deg", strict=True)
    djit = finite_scalar(divergence_jitter_deg, "divergence_jitter_deg", strict=True)
    ijit = finite_scalar(internode_jitter, "internode_jitter", strict=True)
    ljit = finite_scalar(length_jitter, "length_jitter", strict=True)
    if height <= 0:
        raise ValueError(f"trunk_height must be > 0 m, got {trunk_height!r}")
    if not 0 <= h0 < height:
        raise ValueError(f"first_branch_height must be in [0, trunk_height={height}) m, got {h0!r}")
    n = integer(n_branches, "n_branches", 0)
    m = integer(buds_per_node, "buds_per_node", 1)
    check_memory(
        n * BYTES_PER_BUD,
        f"a trunk branching of n_branches = {n}",
        "use fewer n_branches",
    )
    warn_if_slow(
        branching_seconds(n, m),
        f"a trunk branching of n_branches = {n}",
        "use fewer n_branches (the time grows as n_branches^2 / buds_per_node)",
    )
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
    base_v = point3(base, "base")
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
        if abs(1.0 - r) < 1e-12:
            frac = 1.0 / k
        else:
            try:
                frac = (1.0 - r) / (1.0 - r**k)
            except OverflowError:  # r > 1 and r**k beyond float64: (r - 1) / r**k is ~0
                frac = 0.0
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
