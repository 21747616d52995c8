"""Tests for batecho.trees.lsystem, .turtle and .branching: L-system rewriting (deterministic,
stochastic, parametric), the ABOP 3-D turtle and the trunk branching."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import batecho
from batecho._resources import SlowWarning
from batecho.trees.branching import Branching, trunk_branching
from batecho.trees.lsystem import LSystem, Module, module_string, parse_modules
from batecho.trees.turtle import (
    DEFAULT_ANGLE_DEG,
    Segments,
    rotation_h,
    rotation_l,
    rotation_u,
    turtle,
)

# ---------------------------------------------------------------------------------------------
# Deterministic rewriting: textbook examples (ABOP chapter 1)
# ---------------------------------------------------------------------------------------------


def test_algae_strings_match_abop():
    algae = LSystem("a", {"a": "ab", "b": "a"})
    expected = ["a", "ab", "aba", "abaab", "abaababa", "abaababaabaab"]
    assert [algae.derive(n) for n in range(6)] == expected


def test_algae_lengths_are_fibonacci_numbers():
    algae = LSystem("a", {"a": "ab", "b": "a"})
    fib = [1, 2]
    while len(fib) < 16:
        fib.append(fib[-1] + fib[-2])
    assert [len(algae.derive(n)) for n in range(16)] == fib


def test_koch_curve_f_count_is_five_to_the_n():
    koch = LSystem("F", {"F": "F+F-F-F+F"})
    assert [koch.derive(n).count("F") for n in range(6)] == [5**n for n in range(6)]


def test_koch_curve_turtle_displacement_is_three_to_the_n():
    seg = turtle(LSystem("F", {"F": "F+F-F-F+F"}).derive(4), angle_deg=90.0)
    np.testing.assert_allclose(seg.ends[-1], [0.0, 0.0, 81.0], atol=1e-9)


def test_bracketed_plant_fig_1_24a_length_and_f_count():
    # F -> F[+F]F[-F]F: 5^n F's and 6 more bracket/turn symbols per rewritten F.
    plant = LSystem("F", {"F": "F[+F]F[-F]F"})
    s = plant.derive(5)
    assert (s.count("F"), len(s)) == (5**5, 5**5 + 6 * (5**5 - 1) // 4)


def test_bracketed_plant_fig_1_24d_symbol_counts():
    # X -> F[+X]F[-X]+X, F -> FF: X_n = 3^n, F_n = 2 (3^n - 2^n).
    plant = LSystem("X", {"X": "F[+X]F[-X]+X", "F": "FF"})
    counts = [(plant.derive(n).count("X"), plant.derive(n).count("F")) for n in range(8)]
    assert counts == [(3**n, 2 * (3**n - 2**n)) for n in range(8)]


def test_bracketed_plant_segment_depths_follow_brackets():
    seg = turtle("F[+F[-F]]F")
    assert seg.depth.tolist() == [0, 1, 2, 0]


# ---------------------------------------------------------------------------------------------
# Turtle: single-symbol programs against ABOP's rotation matrices (angle 90 degrees)
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("program", "end"),
    [
        ("F", (0, 0, 1)),
        ("+F", (0, 1, 0)),  # H' = H cos d - L sin d, L = (0, -1, 0)
        ("-F", (0, -1, 0)),
        ("&F", (1, 0, 0)),  # H' = H cos d + U sin d, U = +x
        ("^F", (-1, 0, 0)),
        ("\\&F", (0, 1, 0)),  # roll left: U' = -L = +y, then pitch down
        ("/&F", (0, -1, 0)),  # roll right: U' = L = -y
        ("|F", (0, 0, -1)),
        ("fF", (0, 0, 2)),
        ("f F", (0, 0, 2)),
        ("+(180)F", (0, 0, -1)),
        ("&(90)F(2.5)", (2.5, 0, 0)),
        ("F+F", (0, 1, 1)),
        ("\u2212F", (0, -1, 0)),  # ABOP's typeset minus
        ("\u2227F", (-1, 0, 0)),  # ABOP's typeset wedge (pitch up)
    ],
)
def test_single_symbol_program_ends_where_abop_matrices_say(program, end):
    seg = turtle(program, angle_deg=90.0)
    np.testing.assert_allclose(seg.ends[-1], end, atol=1e-12)


def test_initial_frame_is_h_z_l_minus_y_u_x():
    seg = turtle("F")
    np.testing.assert_array_equal(
        np.stack([seg.headings[0], seg.lefts[0], seg.ups[0]]),
        [[0, 0, 1], [0, -1, 0], [1, 0, 0]],
    )


@pytest.mark.parametrize(
    ("sym", "matrix"), [("+", rotation_u), ("&", rotation_l), ("\\", rotation_h)]
)
def test_turtle_frame_update_is_frame_times_abop_matrix(sym, matrix):
    seg = turtle(f"&(20)\\(30)+(40){sym}(17)F")
    start = turtle("&(20)\\(30)+(40)F")
    before = np.column_stack([start.headings[0], start.lefts[0], start.ups[0]])
    after = np.column_stack([seg.headings[0], seg.lefts[0], seg.ups[0]])
    np.testing.assert_allclose(after, before @ matrix(math.radians(17.0)), atol=1e-12)


def test_default_angle_is_25_degrees():
    seg = turtle("+F")
    assert DEFAULT_ANGLE_DEG == 25.0
    np.testing.assert_allclose(
        seg.ends[0], [0.0, math.sin(math.radians(25)), math.cos(math.radians(25))], atol=1e-12
    )


def test_brackets_restore_position_frame_and_width():
    seg = turtle("[!+F&F]F", angle_deg=90.0)
    np.testing.assert_allclose(seg.starts[2], [0, 0, 0])
    np.testing.assert_allclose(seg.ends[2], [0, 0, 1])
    assert seg.widths[2] == 1.0


def test_width_decrement_multiplies_and_parameter_sets():
    seg = turtle("F!F!(0.3)F!F", width=2.0, width_decrement=0.5)
    np.testing.assert_allclose(seg.widths, [2.0, 1.0, 0.3, 0.15])


def test_unknown_symbols_are_ignored():
    a = turtle("AXF(2)B+(10)QF", angle_deg=30.0)
    b = turtle("F(2)+(10)F", angle_deg=30.0)
    np.testing.assert_array_equal(a.ends, b.ends)


def test_marks_record_turtle_state_at_marked_symbols():
    seg = turtle("F[&B(3)]F", angle_deg=90.0, marks="B")
    assert len(seg.marks) == 1 and seg.marks.params == [(3.0,)] and seg.marks.depth[0] == 1
    np.testing.assert_allclose(seg.marks.positions[0], [0, 0, 1])
    np.testing.assert_allclose(seg.marks.headings[0], [1, 0, 0], atol=1e-12)


def test_segments_len_and_lengths():
    seg = turtle("F(2)fF(0.5)[F]")
    assert isinstance(seg, Segments)
    assert len(seg) == 3
    np.testing.assert_allclose(seg.lengths, [2.0, 0.5, 1.0])


def test_empty_program_gives_empty_arrays_of_the_right_shape():
    seg = turtle("")
    assert (seg.starts.shape, seg.ends.shape, seg.widths.shape, seg.headings.shape) == (
        (0, 3),
        (0, 3),
        (0,),
        (0, 3),
    )


def test_dollar_rolls_left_vector_horizontal_keeping_heading():
    tilted = turtle("&(30)\\(40)F")
    seg = turtle("&(30)\\(40)$F")
    np.testing.assert_allclose(seg.headings, tilted.headings, atol=1e-12)
    assert abs(seg.lefts[0, 2]) < 1e-12 and seg.ups[0, 2] > 0


def test_initial_heading_and_up_options_set_the_frame():
    seg = turtle("+F", angle_deg=90.0, origin=(1, 2, 3), heading=(2, 0, 0), up=(0.3, 0, 1))
    # H = +x, U = +z, L = U x H = +y; "+" turns H to -L.
    np.testing.assert_allclose(seg.ends[0], [1, 1, 3], atol=1e-12)


_COMMANDS = list("Ff+-&^\\/|$!") + ["+(33.3)", "&(-71)", "/(200)", "[+F&F]", "[^[\\F]!F]"]


@settings(max_examples=60, deadline=None)
@given(
    program=st.lists(st.sampled_from(_COMMANDS), min_size=50, max_size=400),
    angle=st.floats(-360.0, 360.0),
    tropism=st.tuples(*[st.floats(-1.0, 1.0)] * 3),
    elasticity=st.floats(0.0, 0.5),
)
def test_frame_stays_orthonormal_and_right_handed(program, angle, tropism, elasticity):
    seg = turtle("".join(program) + "F", angle_deg=angle, tropism=tropism, elasticity=elasticity)
    frames = np.stack([seg.headings, seg.lefts, seg.ups], axis=2)  # columns H L U
    gram = np.einsum("kij,kil->kjl", frames, frames)
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(3), gram.shape), atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(frames), 1.0, atol=1e-9)
    np.testing.assert_allclose(np.cross(seg.headings, seg.lefts), seg.ups, atol=1e-9)


# ---------------------------------------------------------------------------------------------
# Tropism
# ---------------------------------------------------------------------------------------------


def test_tropism_bends_a_vertical_stem_toward_t():
    seg = turtle("F" * 20, tropism=(1.0, 0.0, 0.0), elasticity=0.2)
    toward = seg.headings @ np.array([1.0, 0.0, 0.0])
    assert toward[0] == 0.0 and np.all(np.diff(toward) > 0) and seg.ends[-1, 0] > 1.0


def test_gravity_bends_a_tilted_branch_down():
    seg = turtle("&(45)" + "F" * 10, tropism=(0.0, 0.0, -1.0), elasticity=0.1)
    assert np.all(np.diff(seg.headings[:, 2]) < 0)


def test_gravity_leaves_a_vertical_stem_straight():
    seg = turtle("F" * 10, tropism=(0.0, 0.0, -1.0), elasticity=0.3)
    np.testing.assert_allclose(seg.ends[-1], [0, 0, 10])


def test_tropism_rotation_angle_is_elasticity_times_cross_norm():
    seg = turtle("FF", tropism=(2.0, 0.0, 0.0), elasticity=0.1)
    # |H x T| = 2, so H turns by 0.2 rad about +y towards +x.
    np.testing.assert_allclose(seg.headings[1], [math.sin(0.2), 0.0, math.cos(0.2)], atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Stochastic L-systems
# ---------------------------------------------------------------------------------------------

_STOCHASTIC_RULES = {"F": [(0.5, "F[+F]F"), (0.5, "F")]}


def test_stochastic_mean_growth_matches_expectation():
    # Galton-Watson process: offspring 3 or 1, mean 2, variance 1. After n steps:
    # E = 2^n, Var = 2^(n-1) (2^n - 1).
    n, runs = 6, 400
    counts = np.array(
        [LSystem("F", _STOCHASTIC_RULES, seed=s).derive(n).count("F") for s in range(runs)]
    )
    sem = math.sqrt(2 ** (n - 1) * (2**n - 1) / runs)
    assert abs(counts.mean() - 2**n) < 4 * sem


def test_same_seed_gives_same_string():
    a = LSystem("F", _STOCHASTIC_RULES, seed=42).derive(7)
    b = LSystem("F", _STOCHASTIC_RULES, seed=42).derive(7)
    c = LSystem("F", _STOCHASTIC_RULES, seed=np.random.default_rng(42)).derive(7)
    assert a == b == c


def test_different_seeds_give_different_strings():
    strings = {LSystem("F", _STOCHASTIC_RULES, seed=s).derive(7) for s in range(10)}
    assert len(strings) > 5


def test_zero_probability_alternative_is_never_chosen():
    system = LSystem("FFFFFFFF", {"F": [(0.0, "X"), (1.0, "G"), (0.0, "Y")]}, seed=0)
    assert system.derive(1) == "G" * 8


# ---------------------------------------------------------------------------------------------
# Parametric L-systems (ABOP section 1.10)
# ---------------------------------------------------------------------------------------------


def _abop_parametric() -> LSystem:
    # omega: B(2)A(4,4); p1: A(x,y): y <= 3 -> A(x*2,x+y); p2: A(x,y): y > 3 -> B(x)A(x/y,0);
    # p3: B(x): x < 1 -> C; p4: B(x): x >= 1 -> B(x-1)
    return LSystem(
        "B(2)A(4,4)",
        {
            "A": lambda x, y: f"A({x * 2},{x + y})" if y <= 3 else f"B({x})A({x / y},0)",
            "B": lambda x: "C" if x < 1 else f"B({x - 1})",
        },
    )


def test_abop_parametric_derivation_matches_the_book():
    book = [
        [("B", (2,)), ("A", (4, 4))],
        [("B", (1,)), ("B", (4,)), ("A", (1, 0))],
        [("B", (0,)), ("B", (3,)), ("A", (2, 1))],
        [("C", ()), ("B", (2,)), ("A", (4, 3))],
        [("C", ()), ("B", (1,)), ("A", (8, 7))],
        [("C", ()), ("B", (0,)), ("B", (8,)), ("A", (8 / 7, 0))],
    ]
    system = _abop_parametric()
    got = [[(m.symbol, m.params) for m in parse_modules(system.derive(n))] for n in range(6)]
    assert got == book


def test_parametric_branching_halves_lengths_per_order():
    # A(s) -> F(s)[+A(s/R)][-A(s/R)] with R = 2: 2^k segments of length s / 2^k.
    system = LSystem("A(1)", {"A": lambda s: f"F({s})[+A({s / 2})][-A({s / 2})]"})
    seg = turtle(system.derive(5))
    expected = np.repeat([1 / 2**k for k in range(5)], [2**k for k in range(5)])
    np.testing.assert_allclose(np.sort(seg.lengths)[::-1], expected)


def test_callable_returning_none_keeps_the_module():
    system = LSystem("A(3)", {"A": lambda x: f"FA({x - 1})" if x > 1 else None})
    assert system.derive(5) == "FFA(1.0)"


def test_non_parametric_rules_work_beside_parametric_modules():
    system = LSystem("X F(2.5)", {"X": "F[+X]", "F": lambda *p: None})
    assert system.derive(2) == "F[+F[+X]] F(2.5)"


def test_bare_symbol_calls_callable_without_arguments():
    assert LSystem("A", {"A": lambda *p: f"B({len(p)})"}).derive(1) == "B(0)"


def test_stochastic_rule_with_callables_is_reproducible():
    rules = {"A": [(0.3, lambda s: f"F({s})A({s * 0.9})"), (0.7, lambda s: None)]}
    a = LSystem("A(1)", rules, seed=3).derive(20)
    assert a == LSystem("A(1)", rules, seed=3).derive(20) and a.startswith("F(1.0)")


def test_module_string_round_trips_floats():
    s = module_string("A", 0.1, 1 / 3, 2)
    assert parse_modules(s) == [Module("A", (0.1, 1 / 3, 2.0), 0)]


def test_parse_modules_reports_symbols_parameters_and_positions():
    assert parse_modules("F(1.5) +(-30)A(1, 2e-3)") == [
        Module("F", (1.5,), 0),
        Module("+", (-30.0,), 7),
        Module("A", (1.0, 0.002), 13),
    ]


# ---------------------------------------------------------------------------------------------
# Size: derivations that cannot fit are refused
# ---------------------------------------------------------------------------------------------


@pytest.fixture
def one_mib_limit():
    batecho.set_memory_limit(2**20)
    yield
    batecho.set_memory_limit(None)


def _no_rewriting(system, monkeypatch):
    def rewrite(*args):
        raise AssertionError("a step was rewritten")

    monkeypatch.setattr(system, "_rewrite", rewrite)


def test_a_derivation_too_long_for_memory_is_refused_before_it_starts(monkeypatch):
    system = LSystem("F", {"F": "F" * 10})
    _no_rewriting(system, monkeypatch)
    with pytest.raises(MemoryError, match=r"LSystem.derive\(n=12\) .* characters .* memory limit"):
        system.derive(12)


def test_a_branching_derivation_of_forty_steps_is_refused_at_once(monkeypatch):
    system = LSystem("F", {"F": "F[+F]F[-F]F"})
    _no_rewriting(system, monkeypatch)
    with pytest.raises(MemoryError, match=r"derive\(n=40\)"):
        system.derive(40)


def test_the_bound_on_a_deterministic_derivation_is_its_exact_length(one_mib_limit):
    # algae strings have Fibonacci lengths; a step holds the string and the one before it:
    # 317811 + 514229 bytes fit 1 MiB, 514229 + 832040 do not
    algae = LSystem("a", {"a": "ab", "b": "a"})
    assert len(algae.derive(27)) == 514229
    with pytest.raises(MemoryError, match=r"8.32e\+05 characters at step 28"):
        algae.derive(28)


def test_a_stochastic_derivation_is_bounded_by_each_symbols_longest_successor(monkeypatch):
    system = LSystem("F", {"F": [(0.9, "F"), (0.1, "F" * 10)]}, seed=1)
    _no_rewriting(system, monkeypatch)
    with pytest.raises(MemoryError, match=r"derive\(n=12\)"):
        system.derive(12)


def test_a_callable_rule_that_outgrows_memory_is_refused_as_it_rewrites(one_mib_limit):
    system = LSystem("A", {"A": lambda: "A" * 10})
    with pytest.raises(MemoryError, match=r"derive\(n=10\) \(step \d"):
        system.derive(10)


def test_a_derivation_of_minutes_warns_before_it_starts(monkeypatch):
    system = LSystem("F", {"F": "F"})
    _no_rewriting(system, monkeypatch)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SlowWarning)
        with pytest.raises(SlowWarning, match=r"derive\(n=1000000000\) .* min"):
            system.derive(10**9)


def test_a_derivation_of_very_many_steps_warns_before_it_bounds_the_string():
    system = LSystem("A", {"A": "B", "B": "A"})  # never settles: the bound walks every step
    with warnings.catch_warnings():
        warnings.simplefilter("error", SlowWarning)
        with pytest.raises(SlowWarning, match=r"derive\(n=1000000000000\) .* min"):
            system.derive(10**12)


# ---------------------------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------------------------


def test_unmatched_close_bracket_raises_with_position():
    with pytest.raises(ValueError, match=r"'\]' at position 3"):
        turtle("F+F]F")


def test_unclosed_open_bracket_raises_with_position():
    with pytest.raises(ValueError, match=r"'\[' at position 1 is never closed"):
        turtle("F[+F")


def test_a_position_that_overflows_float64_is_refused_naming_the_segment():
    with pytest.raises(ValueError, match=r"not finite at the segment 'F' at position 8"):
        turtle("F(1e308)F(1e308)")


def test_a_mark_whose_position_overflows_float64_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"not finite at the mark 'B' at position 16"):
        turtle("f(1e308)f(1e308)B", marks="B")


@pytest.mark.parametrize("name", ["step", "width", "width_decrement"])
@pytest.mark.parametrize("value", [0.0, -1.0])
def test_a_step_width_or_width_decrement_not_above_zero_is_refused_by_name(name, value):
    with pytest.raises(ValueError, match=f"{name} must be finite and > 0"):
        turtle("F!F", **{name: value})


@pytest.mark.parametrize("width", ["0", "-1"])
def test_a_width_module_not_above_zero_is_refused_naming_its_position(width):
    with pytest.raises(ValueError, match=rf"the width !\({width}.0\) at position 1 must be > 0"):
        turtle(f"F!({width})F")


def test_a_segment_of_negative_length_is_refused_naming_its_position():
    with pytest.raises(ValueError, match=r"F\(-1.0\) at position 1 must have a length >= 0"):
        turtle("FF(-1)")


def test_a_segment_of_length_zero_is_drawn_as_a_point():
    # (a parametric rule may compute a length that rounds to 0, as the top of a trunk does)
    seg = turtle("FF(0)")
    np.testing.assert_array_equal(seg.starts[1], seg.ends[1])


def test_widths_that_underflow_to_zero_are_refused_naming_the_segment():
    with pytest.raises(ValueError, match=r"'F' at position 1001 \(segment 1\) underflows to 0"):
        turtle("F" + "!" * 1000 + "F", width_decrement=0.25)


def test_probabilities_not_summing_to_one_raise():
    with pytest.raises(ValueError, match="sum to 0.9"):
        LSystem("F", {"F": [(0.5, "F"), (0.4, "FF")]})


def test_negative_probability_raises():
    with pytest.raises(ValueError, match="not in"):
        LSystem("F", {"F": [(1.5, "F"), (-0.5, "FF")]})


@pytest.mark.parametrize(
    ("string", "message"),
    [
        ("F(1,2", r"unbalanced '\(' at position 1"),
        ("F(1(2))", r"nested '\(' at position 3"),
        ("F(1))", r"unmatched '\)' at position 4"),
        ("F,G", r"',' at position 1"),
        ("(1)F", r"'\(' at position 0 does not directly follow"),
        ("FF(abc)", r"parameter 'abc' \(position 3\) is not a number"),
        ("F(1,)", r"parameter '' \(position 4\) is not a number"),
        ("F()", r"empty parameter list"),
        ("F(nan)", r"is not finite"),
    ],
)
def test_malformed_module_raises_naming_position(string, message):
    with pytest.raises(ValueError, match=message):
        parse_modules(string)


def test_malformed_axiom_raises():
    with pytest.raises(ValueError, match="axiom"):
        LSystem("A(1", {})


def test_malformed_successor_string_raises():
    with pytest.raises(ValueError, match="successor"):
        LSystem("A", {"A": "F(x)"})


def test_callable_returning_malformed_successor_raises():
    with pytest.raises(ValueError, match=r"rule for 'A' applied to 'A\(1\)'"):
        LSystem("A(1)", {"A": lambda x: "F(1"}).derive(1)


def test_multi_character_rule_key_raises():
    with pytest.raises(ValueError, match="one character"):
        LSystem("F", {"FF": "F"})


def test_negative_derivation_count_raises():
    with pytest.raises(ValueError, match="n must be"):
        LSystem("F", {}).derive(-1)


# ---------------------------------------------------------------------------------------------
# Trunk branching
# ---------------------------------------------------------------------------------------------


def test_trunk_branching_is_reproducible_for_a_seed():
    a = trunk_branching(np.random.default_rng(7))
    b = trunk_branching(np.random.default_rng(7))
    assert a.lsystem_string == b.lsystem_string
    for name in ("origins", "directions", "lengths", "heights"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_trunk_branching_differs_between_seeds():
    a = trunk_branching(np.random.default_rng(1))
    b = trunk_branching(np.random.default_rng(2))
    assert not np.allclose(a.directions, b.directions)


def test_trunk_branching_defaults_are_a_plausible_deciduous_tree():
    b = trunk_branching(np.random.default_rng(0))
    height = b.trunk_top[2] - b.trunk_base[2]
    assert isinstance(b, Branching)
    assert 6.0 <= height <= 10.0 and 6 <= len(b) <= 12 and 1.5 <= b.heights.min() <= 3.0


@pytest.mark.parametrize("seed", range(5))
def test_trunk_branching_origins_lie_on_the_trunk_segment(seed):
    b = trunk_branching(np.random.default_rng(seed), base=(1.0, -2.0, 0.5))
    axis = b.trunk_top - b.trunk_base
    t = (b.origins - b.trunk_base) @ axis / (axis @ axis)
    off_axis = b.origins - b.trunk_base - t[:, None] * axis
    assert np.all((t >= 0) & (t <= 1)) and np.abs(off_axis).max() < 1e-9


def test_trunk_branching_with_a_contraction_whose_powers_overflow_fills_the_trunk():
    # contraction**k for the lowest node's k nodes above it is beyond float64 (10**320)
    b = trunk_branching(np.random.default_rng(0), n_branches=320, contraction=10.0)
    assert len(b) == 320
    assert np.all(np.diff(b.heights) >= 0) and 2.0 <= b.heights.min() <= b.heights.max() < 7.0


def test_trunk_branching_directions_are_unit_vectors():
    b = trunk_branching(np.random.default_rng(3), n_branches=12)
    np.testing.assert_allclose(np.linalg.norm(b.directions, axis=1), 1.0, atol=1e-12)


def test_trunk_branching_directions_make_the_branching_angle_exactly_without_jitter():
    b = trunk_branching(np.random.default_rng(4), branching_angle_deg=62.0, angle_jitter_deg=0.0)
    angles = np.degrees(np.arccos(np.clip(b.directions[:, 2], -1, 1)))
    np.testing.assert_allclose(angles, 62.0, atol=1e-9)


def test_trunk_branching_angles_stay_within_the_jitter():
    b = trunk_branching(np.random.default_rng(5), n_branches=30, angle_jitter_deg=5.0)
    angles = np.degrees(np.arccos(np.clip(b.directions[:, 2], -1, 1)))
    assert np.all(np.abs(angles - 50.0) <= 5.0 + 1e-9)


def test_trunk_branching_successive_azimuths_differ_by_the_divergence():
    b = trunk_branching(np.random.default_rng(6), divergence_jitter_deg=0.0)
    az = np.degrees(np.arctan2(b.directions[:, 1], b.directions[:, 0]))
    step = np.diff(az) % 360.0
    assert np.allclose(step, 137.5) or np.allclose(step, 360.0 - 137.5)


def test_trunk_branching_heights_lie_within_the_trunk_and_increase():
    b = trunk_branching(
        np.random.default_rng(8), trunk_height=9.0, first_branch_height=2.5, n_branches=11
    )
    assert b.heights[0] == pytest.approx(2.5) and np.all(np.diff(b.heights) > 0)
    assert b.heights[-1] < 9.0 and len(b) == 11


def test_trunk_branching_whorls_share_a_node_height():
    b = trunk_branching(np.random.default_rng(9), n_branches=9, buds_per_node=3)
    np.testing.assert_allclose(
        b.heights.reshape(3, 3) - b.heights.reshape(3, 3)[:, :1], 0.0, atol=1e-12
    )


def test_trunk_branching_lengths_are_positive_and_at_most_the_maximum():
    b = trunk_branching(np.random.default_rng(10), branch_length=2.0, length_jitter=0.1)
    assert np.all(b.lengths > 0) and np.all(b.lengths <= 2.0 * 1.1)


def test_trunk_branching_without_branches_is_empty():
    b = trunk_branching(np.random.default_rng(11), n_branches=0)
    assert len(b) == 0 and b.origins.shape == (0, 3) and b.directions.shape == (0, 3)


def test_trunk_branching_rejects_first_branch_above_top():
    with pytest.raises(ValueError, match="first_branch_height"):
        trunk_branching(np.random.default_rng(0), trunk_height=5.0, first_branch_height=6.0)
