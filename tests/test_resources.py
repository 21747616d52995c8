"""The resource guard: requests too large for memory and absurd parameters that size work
get a clear exception at once, naming the parameter and the size, in a child process with an
address-space limit (a regression would abort or hang the child, not the test run)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from _isolated import call_in_child

import batecho
from batecho._resources import DEFAULT_MEMORY_LIMIT_BYTES, check_memory

SETUP = """
import numpy as np
import batecho
from batecho import Leaves, Poses, Sonar, simulate
LEAF = Leaves([[2.0, 0, 0]], [[1.0, 0, 0]], [0.02])
POSE = Poses([0.0, 0, 0], [1.0, 0, 0])
"""

#: A refused call must answer within this (s): the guards check before any work.
PROMPT_S = 1.0


def refused(body: str, error: str, *words: str) -> str:
    """The call in a child raises ``error`` promptly, with every one of ``words``."""
    r = call_in_child(body, SETUP)
    assert r["raised"] == error, r
    for w in words:
        assert w in r["message"], (w, r["message"])
    assert r["elapsed_s"] < PROMPT_S, r
    return r["message"]


def test_an_oversized_record_is_a_memory_error_naming_n_samples_and_the_size():
    refused(
        "Sonar(n_samples=1_000_000_000)",
        "MemoryError",
        "n_samples = 1000000000",
        "GiB",
        "set_memory_limit",
    )


def test_an_oversized_record_at_simulate_is_refused_before_any_work():
    refused("simulate(LEAF, Sonar(n_samples=100_000_000), POSE)", "MemoryError", "n_samples")


def test_many_poses_at_once_are_refused_with_how_to_split_them():
    refused(
        "simulate(LEAF, Sonar(), Poses(np.zeros((200_000, 3)), [1.0, 0, 0]))",
        "MemoryError",
        "200000 poses",
        "poses[i:j]",
    )


def test_an_absurd_sound_speed_with_an_automatic_record_is_refused_at_once():
    refused(
        "s = Sonar(sound_speed=0.001, n_samples='auto', threshold_db=-100)\n"
        "simulate(Leaves([[1e7, 0, 0]], [[1.0, 0, 0]], [0.02]), s, POSE)",
        "ValueError",
        "sound_speed = 0.001",
        "max_range_m",
    )


@pytest.mark.parametrize(
    "kwargs, named",
    [
        ("threshold_db=-200", "threshold_db"),
        ("lobe='cone', cone_half_angle_deg=30, max_range_m=1e300", "max_range_m"),
        ("record_tail_s=1e6", "record_tail_s = 1e+06"),
    ],
)
def test_an_automatic_record_too_long_to_make_is_refused_naming_its_cause(kwargs, named):
    refused(f"Sonar(n_samples='auto', {kwargs})", "ValueError", named, "2^31")


def test_a_huge_band_at_a_tiny_sound_speed_simulates_or_refuses_without_aborting():
    r = call_in_child(
        "simulate(LEAF, Sonar(fs=160e3, band_hz=(1e3, 80e3), lobe='cone',\n"
        "    cone_half_angle_deg=179.9, sound_speed=1e-3), POSE)",
        SETUP,
    )
    assert r["raised"] in (None, "ValueError", "MemoryError"), r


def test_a_plan_for_a_huge_band_at_a_tiny_sound_speed_is_refused_not_aborted():
    refused(
        "s = Sonar(fs=160e3, band_hz=(1e3, 80e3), lobe='cone', cone_half_angle_deg=179.9,\n"
        "          sound_speed=1e-3, n_samples='auto', max_range_m=10)",
        "ValueError",
        "n_samples='auto'",
    )


@pytest.mark.parametrize("n", ["-5", "2**64"])
def test_an_out_of_range_record_length_names_n_samples(n):
    refused(f"Sonar(n_samples={n})", "ValueError", "n_samples")


def test_the_core_names_an_unsigned_parameter_given_a_negative_integer():
    msg = refused(
        "batecho._core.Sonar((1.0, .1, .1, 0.0, 0.0, 0.0), None, 'detectable', 20.0, .1, 2.0,\n"
        "    2e-5, None, None, 4e5, -5, 6e4, 8e4, 340.0, 'paper', True, .2, 'hann', None, .01,\n"
        "    'raise', .5)",
        "ValueError",
        "n_samples",
    )
    assert "-5" in msg


def test_the_memory_limit_can_be_raised_and_restored():
    before = batecho.memory_limit()
    try:
        assert batecho.set_memory_limit(64 * 2**30) == before
        assert batecho.memory_limit() == 64 * 2**30
    finally:
        batecho.set_memory_limit(None)
    assert batecho.memory_limit() == DEFAULT_MEMORY_LIMIT_BYTES


def test_a_lowered_limit_refuses_what_the_default_allows():
    batecho.Sonar(n_samples=2_000_000)
    batecho.set_memory_limit(2**20)
    try:
        with pytest.raises(MemoryError, match="n_samples = 2000000"):
            batecho.Sonar(n_samples=2_000_000)
    finally:
        batecho.set_memory_limit(None)


@pytest.mark.parametrize("bad", [0, 1000, -1, 2.5, "4GB", True])
def test_a_memory_limit_below_one_mebibyte_or_not_an_integer_is_refused(bad):
    with pytest.raises((ValueError, TypeError), match="nbytes"):
        batecho.set_memory_limit(bad)
    assert batecho.memory_limit() == DEFAULT_MEMORY_LIMIT_BYTES


def test_the_python_check_says_what_and_how_to_split_it():
    with pytest.raises(MemoryError, match=r"the thing needs about 931\.3 GiB.*in pieces"):
        check_memory(1e12, "the thing", "do it in pieces")
    check_memory(1e3, "a small thing", "")


@pytest.mark.parametrize(
    ("nbytes", "size"), [(1e300, "9.09e+287 TiB"), (2.0**40 * 123456789, "1.23e+08 TiB")]
)
def test_an_astronomical_request_is_sized_in_a_few_digits(nbytes, size):
    with pytest.raises(MemoryError, match=rf"needs about {size.replace('+', '[+]')}, over"):
        check_memory(nbytes, "the thing", "do it in pieces")


def test_a_pose_whose_branches_cut_into_too_many_pieces_is_refused_naming_the_piece_scale():
    # 3000 trunks 8 m tall at 2-3 m, cut finely: billions of bytes of pieces for one pose
    refused(
        "rng = np.random.default_rng(0)\n"
        "base = np.column_stack([rng.uniform(2, 3, 3000), rng.uniform(-3, 3, 3000),\n"
        "                        np.full(3000, -4.0)])\n"
        "wood = batecho.Branches(base, base + [0, 0, 8.0], np.full(3000, 0.05))\n"
        "simulate(batecho.Scene(None, branches=wood),\n"
        "         Sonar(branch_piece_scale=0.01, lobe='cone', cone_half_angle_deg=89,\n"
        "               max_range_m=10), POSE, method='fast')",
        "MemoryError",
        "branch_piece_scale",
        "pieces",
    )


def test_an_absurd_branch_piece_scale_is_refused_in_a_message_of_few_digits():
    message = refused(
        "wood = batecho.Branches([[3.0, 0, -1]], [[3.0, 0, 1]], [0.05])\n"
        "simulate(batecho.Scene(None, branches=wood), Sonar(branch_piece_scale=1e-300), POSE)",
        "MemoryError",
        "branch_piece_scale = 1.000e-300",
    )
    assert not re.search(r"\d{20}", message), message


def test_branches_sharing_one_end_point_by_the_thousand_are_refused_before_they_are_joined():
    # 100,000 segments from one point: each joined to every other, 10^10 joints
    refused(
        "rng = np.random.default_rng(0)\n"
        "star = batecho.Branches(np.zeros((100_000, 3)), rng.normal(size=(100_000, 3)),\n"
        "                        np.full(100_000, 0.01))\n"
        "batecho.Scene(None, branches=star)",
        "MemoryError",
        "100000 share one",
        "set_memory_limit",
    )


@pytest.mark.parametrize(
    "body, name",
    [
        ("Leaves(np.broadcast_to([2.0, 0, 0], (10**9, 3)), [[1.0, 0, 0]], [0.02])", "centers"),
        ("Poses(np.broadcast_to([0.0, 0, 0], (10**9, 3)), [1.0, 0, 0])", "positions"),
        ("batecho.Call(np.broadcast_to(1.0, (10**10,)), 4e5)", "samples"),
        ("batecho.Scene(LEAF).clearance(np.broadcast_to([0.0, 0, 0], (10**9, 3)))", "points"),
    ],
)
def test_an_input_array_too_large_to_copy_is_a_memory_error_naming_it(body, name):
    # a broadcast view costs nothing; its float64 copy would be tens of GiB
    refused(body, "MemoryError", name, "set_memory_limit")


@pytest.mark.parametrize("make", [batecho.Poses, batecho.look_at])
def test_poses_whose_frames_need_more_than_the_limit_are_refused_before_they_are_built(make):
    # each (p, 3) copy (24 MB) is under the limit, but the frames and their temporaries are
    # about ten such arrays (over 200 MB)
    positions = np.broadcast_to([0.0, 0.0, 0.0], (10**6, 3))
    batecho.set_memory_limit(32 * 2**20)
    try:
        with pytest.raises(MemoryError, match="1000000 poses.*in pieces"):
            make(positions, [1.0, 0.0, 0.0])
    finally:
        batecho.set_memory_limit(None)
