"""A scene file's values out of range are refused when the file is read, before anything is
built or simulated, by a message naming the table, the key the file wrote, and its value."""

from __future__ import annotations

import pytest

from batecho.cli import main
from batecho.scenefile import SceneFile, ScenefileError

SCENE = '[scene]\nkind = "leaf_box"\ndensity_per_m3 = 2.0\n'
SONAR = "[sonar]\nbeamwidth_deg = 20\n"
FLIGHT = '[flight]\npath = "circle"\nradius = 6.2\naltitude = 0.0\nheading = "center"\n'
OUTPUT = "[output]\nplots = []\n"


def refused(text: str) -> str:
    with pytest.raises(ScenefileError) as info:
        SceneFile.from_string(text, "scene.toml")
    return str(info.value)


def test_a_flown_time_step_of_zero_is_refused_naming_dt(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE + SONAR + FLIGHT + 'mode = "flown"\ndt = 0\nn_pulses = 2\n' + OUTPUT)
    assert main(["simulate", str(path), "--out", str(tmp_path / "o"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "[flight] dt: must be > 0, got 0.0" in err and "Traceback" not in err


@pytest.mark.parametrize("rate", ["0", "-10"])
def test_a_pulse_rate_not_above_zero_is_refused_naming_pulse_rate_hz(rate):
    msg = refused(SCENE + SONAR + FLIGHT + f"pulse_rate_hz = {rate}\n" + OUTPUT)
    assert f"[flight] pulse_rate_hz: must be > 0, got {float(rate)}" in msg


def test_a_negative_duration_is_refused_naming_duration():
    msg = refused(SCENE + SONAR + FLIGHT + "pulse_rate_hz = 10\nduration = -1\n" + OUTPUT)
    assert "[flight] duration: must be > 0, got -1.0" in msg


def test_a_duration_that_kinematic_pulses_by_count_would_ignore_is_refused_by_name():
    msg = refused(SCENE + SONAR + FLIGHT + "n_pulses = 2\nduration = 3\n" + OUTPUT)
    assert "[flight] duration: not used by kinematic pulses placed by n_pulses" in msg


def test_a_negative_call_noise_is_refused_naming_call_noise_rms():
    call = '[call]\nkind = "linear_fm"\nf_start_hz = 80e3\nf_end_hz = 60e3\nduration_s = 2e-3\n'
    msg = refused(SCENE + SONAR + FLIGHT + OUTPUT + call + "noise_rms = -1\n")
    assert "[call] noise_rms: must be >= 0, got -1.0" in msg


def test_a_horseshoe_frequency_outside_its_fit_is_refused_naming_it_and_its_value():
    msg = refused(SCENE + "[sonar]\nhorseshoe_bat_khz = -70\n" + FLIGHT + OUTPUT)
    assert "[sonar] horseshoe_bat_khz: the horseshoe-bat fit at -70 kHz" in msg


def test_a_horseshoe_frequency_inside_its_fit_is_accepted():
    sf = SceneFile.from_string(SCENE + "[sonar]\nhorseshoe_bat_khz = 70\n" + FLIGHT + OUTPUT)
    assert 0.0 < sf.build_sonar().beamwidth_deg < 180.0


@pytest.mark.parametrize("tol", ["0.0", "1.0", "2.0"])
def test_a_tolerance_outside_zero_to_one_is_refused_naming_tol(tol):
    msg = refused(f"tol = {tol}\n" + SCENE + SONAR + FLIGHT + OUTPUT)
    assert f"tol: must be in (0, 1), got {tol}" in msg


@pytest.mark.parametrize("te", ["0", "-10"])
def test_a_wav_time_expansion_not_above_zero_is_refused_naming_it(te):
    msg = refused(SCENE + SONAR + FLIGHT + OUTPUT + f"wav = true\nwav_time_expansion = {te}\n")
    assert f"[output] wav_time_expansion: must be > 0, got {float(te)}" in msg


def test_a_wav_rate_below_one_hertz_is_refused_before_anything_is_written(tmp_path, capsys):
    path = tmp_path / "scene.toml"
    wav = "wav = true\nwav_time_expansion = 1e9\n"
    path.write_text(SCENE + SONAR + FLIGHT + "n_pulses = 2\n" + OUTPUT + wav)
    assert main(["simulate", str(path), "--out", str(tmp_path / "o"), "-q"]) == 2
    assert "[output] wav_time_expansion: fs / 1e+09" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_a_bad_call_is_refused_before_anything_is_written(tmp_path, capsys):
    call = '[call]\nkind = "linear_fm"\nf_start_hz = 3e5\nf_end_hz = 60e3\nduration_s = 2e-3\n'
    path = tmp_path / "scene.toml"
    path.write_text(SCENE + SONAR + FLIGHT + "n_pulses = 2\n" + OUTPUT + call)
    assert main(["simulate", str(path), "--out", str(tmp_path / "o"), "-q"]) == 2
    assert "[call] f_start_hz" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_number_that_is_not_finite_is_refused_as_not_finite(value):
    msg = refused(SCENE + f"[sonar]\nbeamwidth_deg = {value}\n" + FLIGHT + OUTPUT)
    assert f"[sonar] beamwidth_deg: must be finite, got {float(value)}" in msg


def test_a_radius_that_is_not_finite_is_refused_as_not_finite():
    flight = FLIGHT.replace("radius = 6.2", "radius = nan")
    msg = refused(SCENE + SONAR + flight + OUTPUT)
    assert '[flight] radius: must be finite (or "clear"), got nan' in msg
