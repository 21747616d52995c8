"""Scene files that ask for too much, or for the impossible, end ``batecho simulate`` at once
with one line naming the file, the table and the key: never an abort, a hang, a traceback,
or a failure after the work is done. Each runs the command in a child with time and memory
limits."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from _isolated import run_argv

SCENE = (
    '[scene]\nkind = "leaf_box"\ndensity_per_m3 = 2.0\n'
    "box = [[1.0, 4.0], [-1.0, 1.0], [-1.0, 1.0]]\n"
)
SONAR = "[sonar]\nbeamwidth_deg = 20\nn_samples = 4000\n"
FLIGHT = '[flight]\npath = "circle"\nradius = 6.2\naltitude = 0.0\nheading = "center"\n'
OUTPUT = "[output]\nplots = []\n"


def simulate_file(tmp_path: Path, text: str, timeout_s: float = 60.0):
    path = tmp_path / "scene.toml"
    path.write_text(text, encoding="utf-8")
    argv = [sys.executable, "-m", "batecho", "simulate", str(path), "--out", str(tmp_path / "o")]
    return run_argv(argv + ["-q"], timeout_s=timeout_s, memory_bytes=3 * 2**30)


def refused_naming(tmp_path: Path, text: str, *words: str) -> str:
    oc = simulate_file(tmp_path, text)
    assert oc.kind == "exit" and oc.returncode == 2, (oc.kind, oc.stderr[-2000:])
    lines = oc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in oc.stderr, oc.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.mark.parametrize(
    "flight, named",
    [
        ("n_pulses = 10000000\n", "[flight] n_pulses = 10000000"),
        ("pulse_rate_hz = 1e6\n", "[flight] pulse_rate_hz = 1000000.0"),
        ("n_pulses = 1e7\n", "[flight] n_pulses"),
        ('mode = "flown"\ndt = 1e-12\nn_pulses = 3\n', "[flight] dt = 1e-12"),
    ],
)
def test_a_flight_too_large_for_memory_is_refused_naming_the_key(tmp_path, flight, named):
    refused_naming(tmp_path, SCENE + SONAR + FLIGHT + flight + OUTPUT, "scene.toml", named)


def test_a_huge_pulse_count_on_a_line_is_refused_not_an_index_error(tmp_path):
    line = '[flight]\npath = "line"\nstart = [0.0, 0.0, 0.0]\ntarget = [5.0, 0.0, 0.0]\n'
    refused_naming(
        tmp_path, SCENE + SONAR + line + "n_pulses = 9223372036854775807\n" + OUTPUT, "n_pulses"
    )


def test_a_record_too_large_for_memory_is_refused_naming_the_sonar_table(tmp_path):
    sonar = "[sonar]\nn_samples = 1000000000\n"
    msg = refused_naming(tmp_path, SCENE + sonar + FLIGHT + "n_pulses = 3\n" + OUTPUT, "[sonar]")
    assert "n_samples = 1000000000" in msg


def test_a_leaf_box_too_dense_for_memory_is_refused_naming_the_density(tmp_path):
    scene = '[scene]\nkind = "leaf_box"\ndensity_per_m3 = 1e9\n'
    refused_naming(tmp_path, scene + SONAR + FLIGHT + "n_pulses = 3\n" + OUTPUT, "density_per_m3")


def test_a_negative_mean_leaf_radius_is_refused_not_redrawn_forever(tmp_path):
    refused_naming(
        tmp_path,
        SCENE + "radius_mean_m = -0.1\n" + SONAR + FLIGHT + "n_pulses = 3\n" + OUTPUT,
        "[scene] radius_mean_m",
    )


def test_a_negative_zero_angle_spread_is_taken_as_zero_not_blamed_on_another_key(tmp_path):
    oc = simulate_file(
        tmp_path,
        SCENE + "normal_angle_sd_deg = -0.0\n" + SONAR + FLIGHT + "n_pulses = 3\n" + OUTPUT,
    )
    assert oc.returncode == 0, oc.stderr


def test_a_resolution_beyond_print_quality_is_refused_naming_dpi(tmp_path):
    out = '[output]\nplots = ["scene"]\ndpi = 1000000\n'
    refused_naming(tmp_path, SCENE + SONAR + FLIGHT + "n_pulses = 3\n" + out, "[output] dpi")


def test_a_beam_too_narrow_is_refused_before_plotting(tmp_path):
    sonar = "[sonar]\nbeamwidth_deg = 1e-300\nn_samples = 4000\n"
    out = '[output]\nplots = ["scene"]\n'
    refused_naming(tmp_path, SCENE + sonar + FLIGHT + "n_pulses = 3\n" + out, "beamwidth_deg")


@pytest.mark.parametrize("seed", ["-1", "340282366920938463463374607431768211456"])
def test_a_seed_out_of_range_is_refused_naming_seed(tmp_path, seed):
    text = f"seed = {seed}\n" + SCENE + SONAR + FLIGHT + "n_pulses = 3\n" + OUTPUT
    refused_naming(tmp_path, text, "seed: must be an integer in [0, 2^128)")


def test_an_automatic_record_writes_the_npz_with_the_record_it_chose(tmp_path):
    sonar = '[sonar]\nbeamwidth_deg = 20\nn_samples = "auto"\n'
    oc = simulate_file(tmp_path, SCENE + sonar + FLIGHT + "n_pulses = 3\n" + OUTPUT)
    assert oc.returncode == 0, oc.stderr
    with np.load(tmp_path / "o" / "echoes.npz") as z:
        k0, k1 = z["band_bins"]
        assert z["spectrum"].shape[1] == k1 - k0 + 1
        assert z["impulse"].shape[1] == z["times"].shape[0]
