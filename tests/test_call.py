"""The emitted call, what a receiver records and the exports (docs/model.md §5b): the FFT
convolution equals numpy.convolve, the noise is seeded with the asked rms, the matched filter
peaks at the echo's delay, and the WAV, MAT and xarray files read back what was written."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import batecho
from batecho import Call, Leaves, Poses, Sonar


@pytest.fixture(scope="module")
def two_ears():
    from batecho.echoes.canonical import canonical_leaf_box

    leaves = canonical_leaf_box(np.random.default_rng(4), density_per_m3=3.0)
    poses = Poses([[0.0, 0.0, 0.0], [0.3, 0.1, 0.0]], [[1.0, 0.0, 0.0], [1.0, 0.1, 0.0]])
    return batecho.simulate(leaves, Sonar.binaural(0.02, 30.0), poses)


@pytest.fixture(scope="module")
def one_ear():
    leaves = Leaves([[2.0, 0.1, 0.0], [3.5, -0.2, 0.1]], [[1, 0, 0], [1, 0.2, 0]], [0.02, 0.03])
    return batecho.simulate(leaves, Sonar(), Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]))


CALLS = {
    "linear_fm": lambda: Call.linear_fm(80e3, 60e3, 2e-3),
    "hyperbolic_fm": lambda: Call.hyperbolic_fm(90e3, 45e3, 3e-3, window="blackman"),
    "cf_fm": lambda: Call.cf_fm(75e3, 20e-3, 62e3, 4e-3),
    "custom": lambda: Call(np.random.default_rng(1).normal(size=301), 400e3),
}


@pytest.mark.filterwarnings("ignore::batecho.CallBandWarning")  # (calls beyond the band too)
@pytest.mark.parametrize("kind", CALLS)
def test_received_equals_numpy_convolve_without_noise(two_ears, kind):
    call = CALLS[kind]()
    got = two_ears.received(call)
    n = two_ears.impulse.shape[-1]
    want = np.array([[np.convolve(h, call.samples)[:n] for h in pose] for pose in two_ears.impulse])
    assert got.shape == two_ears.impulse.shape
    assert np.max(np.abs(got - want)) <= 1e-10 * np.max(np.abs(want))


def test_the_noise_is_seeded_and_has_the_asked_rms(one_ear):
    call = CALLS["linear_fm"]()
    clean = one_ear.received(call)
    a = one_ear.received(call, noise_rms=0.01, rng=5)
    b = one_ear.received(call, noise_rms=0.01, rng=5)
    c = one_ear.received(call, noise_rms=0.01, rng=6)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    noise = a - clean
    # 24 000 samples: the sample rms is within 3 % of sigma (about 7 standard errors)
    assert abs(np.sqrt(np.mean(noise**2)) - 0.01) < 3e-4
    assert abs(np.mean(noise)) < 3e-4
    gen = np.random.default_rng(9)
    assert np.array_equal(
        one_ear.received(call, 0.01, gen), one_ear.received(call, 0.01, np.random.default_rng(9))
    )


def test_the_matched_filter_peaks_at_a_single_leafs_delay():
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    leaf = Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    e = batecho.simulate(leaf, Sonar(), pose)
    z = e.compressed(Call.linear_fm(85e3, 55e3, 2e-3))
    from scipy.signal import hilbert

    t = e.times[int(np.argmax(np.abs(hilbert(z[0]))))]
    assert abs(t - 2 * 3.0 / e.sonar.sound_speed) <= 2.0 / e.sonar.fs


def test_the_compressed_output_is_the_impulse_response_filtered_by_the_calls_autocorrelation():
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    leaf = Leaves([[3.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    e = batecho.simulate(leaf, Sonar(), pose)
    call = Call.linear_fm(80e3, 60e3, 2e-3)
    y, c = e.impulse[0], call.samples
    rho = np.correlate(c, c, "full") / call.energy  # lags -(m - 1) .. m - 1, rho[0] = 1
    want = np.convolve(y, rho)[c.size - 1 : c.size - 1 + y.size]
    fits = y.size - c.size + 1  # where the call still fits in the record
    z = e.compressed(call)[0]
    assert np.max(np.abs(z[:fits] - want[:fits])) <= 1e-12 * np.max(np.abs(want))


def test_a_single_sample_comes_out_of_the_matched_filter_at_its_amplitude():
    from batecho.echoes.received import compressed

    call = Call.linear_fm(80e3, 60e3, 2e-3)
    y = np.zeros(4000)
    y[1000] = 0.37
    z = compressed(y, call.fs, call)
    assert np.argmax(z) == 1000 and abs(z[1000] - 0.37) <= 1e-12


def test_a_call_at_another_rate_is_refused(one_ear):
    with pytest.raises(ValueError, match="sampled at 250000 Hz"):
        one_ear.received(Call.linear_fm(80e3, 60e3, 2e-3, fs=250e3))
    with pytest.raises(TypeError, match="batecho.Call"):
        one_ear.received(np.ones(10))
    with pytest.raises(ValueError, match="noise_rms"):
        one_ear.received(CALLS["linear_fm"](), noise_rms=-1.0)


@given(
    st.floats(20e3, 150e3),
    st.floats(20e3, 150e3),
    st.floats(2e-4, 1e-2),
    st.sampled_from(["hann", "hamming", "blackman", "tukey", "rect"]),
)
@settings(max_examples=30)
def test_sweeps_have_their_duration_and_stay_within_the_window(f0, f1, duration, window):
    for make in (Call.linear_fm, Call.hyperbolic_fm):
        c = make(f0, f1, duration, window=window)
        assert len(c) == round(duration * 400e3)
        assert np.all(np.abs(c.samples) <= 1.0) and not c.samples.flags.writeable


def test_a_linear_sweep_runs_between_its_frequencies():
    c = Call.linear_fm(80e3, 40e3, 5e-3, window="rect")
    from scipy.signal import hilbert

    phase = np.unwrap(np.angle(hilbert(c.samples)))
    f = np.diff(phase) / (2 * np.pi) * c.fs
    mid = f[len(f) // 10 : -len(f) // 10]
    assert 40e3 < mid.min() < 50e3 and 70e3 < mid.max() < 80e3
    assert np.all(np.diff(mid[::50]) < 0)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Call.linear_fm(80e3, 250e3, 1e-3), "Nyquist"),
        (lambda: Call.linear_fm(80e3, 60e3, 1e-9), "samples"),
        (lambda: Call.cf_fm(80e3, 1e-3, 60e3, 2e-3), "fm_duration_s"),
        (lambda: Call.linear_fm(80e3, 60e3, 1e-3, window="kaiser"), "window"),
        (lambda: Call([1.0, np.nan], 400e3), "finite"),
        (lambda: Call(np.ones((2, 2)), 400e3), "1-D"),
        (lambda: Call([1.0, 2.0], -1.0), "fs"),
    ],
)
def test_bad_calls_are_refused_by_name(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("make", [Call.linear_fm, Call.hyperbolic_fm])
def test_a_sweep_that_its_window_silences_is_refused_naming_its_duration(make):
    # two samples under a Hann window are both zero: "scale the samples" named none of this
    with pytest.raises(ValueError, match=r"duration_s = 5e-06 s .* hann"):
        make(80e3, 60e3, 5e-6)


def test_noise_beyond_float64_is_refused_naming_noise_rms(one_ear):
    with pytest.raises(ValueError, match="noise_rms"):
        one_ear.received(CALLS["linear_fm"](), noise_rms=1e308, rng=0)


@pytest.mark.parametrize("samples", [np.zeros(50), np.full(50, 1e-170), np.full(50, 1e160)])
def test_a_call_whose_energy_is_zero_or_overflows_is_refused(samples):
    # the matched filter divides by the energy: NaN or zero everywhere otherwise
    with pytest.raises(ValueError, match="energy"):
        Call(samples, 400e3)


@pytest.mark.parametrize(
    "samples", [np.array([1.0 + 1.0j, 2.0]), np.array([True, False]), ["1", "2"]]
)
def test_samples_that_are_not_real_numbers_are_refused_with_type_error(samples):
    with pytest.raises(TypeError, match="samples"):
        Call(samples, 400e3)


def test_calls_with_the_same_samples_rate_and_name_are_equal():
    a = Call.linear_fm(80e3, 60e3, duration_s=1e-3)
    b = Call(list(a.samples), a.fs, a.name)
    assert a == b
    assert a != Call.linear_fm(80e3, 50e3, duration_s=1e-3)
    assert a != Call(a.samples, a.fs, "other")


def test_equal_calls_hash_alike():
    a = Call.cf_fm(70e3, 2e-3, 60e3, 1e-3)
    assert hash(a) == hash(Call(a.samples.copy(), a.fs, a.name))


def test_the_wav_file_is_stereo_for_two_ears_time_expanded_and_normalised(two_ears, tmp_path):
    from scipy.io import wavfile

    path = two_ears.to_wav(tmp_path / "ears.wav", time_expansion=10)
    rate, data = wavfile.read(path)
    assert rate == 40_000
    assert data.shape == (2 * two_ears.impulse.shape[-1], 2) and data.dtype == np.int16
    assert np.abs(data).max() == round(32767 * 0.99)
    # read back: the poses one after another, each channel one ear
    x = np.transpose(two_ears.impulse, (0, 2, 1)).reshape(-1, 2)
    scale = np.abs(x).max() / (32767 * 0.99)
    assert np.max(np.abs(data * scale - x)) <= scale
    rate, mono = wavfile.read(two_ears.to_wav(tmp_path / "right.wav", 20, receiver=1))
    assert rate == 20_000 and mono.ndim == 1
    right = x[:, 1]
    scale = np.abs(right).max() / (32767 * 0.99)  # normalised on its own
    assert np.max(np.abs(mono * scale - right)) <= scale


def test_the_wav_file_of_the_received_call_is_seeded(two_ears, tmp_path):
    from scipy.io import wavfile

    call = CALLS["linear_fm"]()
    a = wavfile.read(two_ears.to_wav(tmp_path / "a.wav", call=call, noise_rms=1e-7, rng=1))[1]
    b = wavfile.read(two_ears.to_wav(tmp_path / "b.wav", call=call, noise_rms=1e-7, rng=1))[1]
    assert np.array_equal(a, b) and a.shape[1] == 2
    with pytest.raises(ValueError, match="receiver 2 out of range"):
        two_ears.to_wav(tmp_path / "c.wav", receiver=2)


@pytest.mark.parametrize("kw", [dict(noise_rms=1e-7), dict(rng=1)], ids=lambda kw: next(iter(kw)))
def test_noise_for_a_wav_file_without_a_call_is_refused(two_ears, kw, tmp_path):
    # (the noise and its seed were ignored: the file held the noiseless impulse responses)
    with pytest.raises(ValueError, match="pass call= too"):
        two_ears.to_wav(tmp_path / "n.wav", **kw)
    assert not (tmp_path / "n.wav").exists()


def test_the_mat_file_round_trips(two_ears, tmp_path):
    from scipy.io import loadmat

    m = loadmat(two_ears.to_mat(tmp_path / "echoes.mat"))
    assert np.array_equal(m["impulse"], two_ears.impulse)
    assert np.array_equal(m["spectrum"], two_ears.spectrum)
    assert np.array_equal(m["n_leaves"], two_ears.n_leaves)
    assert np.array_equal(m["times"].ravel(), two_ears.times)
    assert np.array_equal(m["positions"], two_ears.poses.positions)
    assert m["receiver_offsets"].tolist() == [[0.0, 0.01, 0.0], [0.0, -0.01, 0.0]]
    assert json.loads(str(m["sonar_json"][0]))["receivers"][0]["offset_m"] == [0.0, 0.01, 0.0]


def test_the_xarray_dataset_round_trips_through_zarr(two_ears, tmp_path):
    import xarray as xr

    ds = two_ears.to_xarray()
    assert ds["impulse"].dims == ("pose", "receiver", "time")
    assert ds["spectrum"].dims == ("pose", "receiver", "frequency")
    assert list(ds["receiver"].values) == ["left", "right"]
    assert ds["time"].attrs["units"] == "s" and ds["frequency"].attrs["units"] == "Hz"
    assert ds.attrs["fs_hz"] == 400e3
    ds.to_zarr(tmp_path / "echoes.zarr", consolidated=False)
    back = xr.open_zarr(tmp_path / "echoes.zarr", consolidated=False).load()
    assert np.array_equal(back["impulse"].values, two_ears.impulse)
    assert np.array_equal(back["spectrum"].values, two_ears.spectrum)
    assert json.loads(back.attrs["sonar_json"]) == json.loads(ds.attrs["sonar_json"])


def test_exports_without_receivers_have_one_receiver_at_the_emitter(one_ear, tmp_path):
    from scipy.io import loadmat, wavfile

    ds = one_ear.to_xarray()
    assert ds.sizes["receiver"] == 1 and list(ds["receiver"].values) == ["emitter"]
    assert np.array_equal(ds["impulse"].values[:, 0], one_ear.impulse)
    assert loadmat(one_ear.to_mat(tmp_path / "e.mat"))["impulse"].shape == (1, 1, 24000)
    assert wavfile.read(one_ear.to_wav(tmp_path / "e.wav"))[1].ndim == 1


def test_editing_the_xarray_dataset_leaves_the_echoes_and_the_given_record_alone(two_ears):
    call = CALLS["linear_fm"]()
    record = two_ears.received(call)
    kept_impulse, kept_record = two_ears.impulse.copy(), record.copy()
    ds = two_ears.to_xarray(call=call, received=record)
    ds["impulse"] /= 2.0
    ds["received"] /= 2.0
    record[...] = 0.0
    assert np.array_equal(two_ears.impulse, kept_impulse)
    assert np.array_equal(ds["received"].values * 2.0, kept_record)


@pytest.mark.parametrize("export", ["to_xarray", "to_mat"])
def test_a_given_record_of_the_wrong_shape_is_refused_by_name(two_ears, export, tmp_path):
    args = (tmp_path / "e.mat",) if export == "to_mat" else ()
    with pytest.raises(ValueError, match="received must have the impulse responses' shape"):
        getattr(two_ears, export)(*args, call=CALLS["linear_fm"](), received=np.zeros((3, 5)))
    assert not (tmp_path / "e.mat").exists()


@pytest.mark.parametrize("export", ["to_xarray", "to_mat"])
def test_a_given_record_of_complex_numbers_is_refused_by_name(two_ears, export, tmp_path):
    # its imaginary part was dropped with only a NumPy warning
    args = (tmp_path / "e.mat",) if export == "to_mat" else ()
    call = CALLS["linear_fm"]()
    record = two_ears.received(call) + 1j
    with pytest.raises(TypeError, match="received must hold real numbers"):
        getattr(two_ears, export)(*args, call=call, received=record)
    assert not (tmp_path / "e.mat").exists()


@pytest.mark.parametrize("export", ["to_xarray", "to_mat"])
def test_a_given_record_without_its_call_is_refused(two_ears, export, tmp_path):
    args = (tmp_path / "e.mat",) if export == "to_mat" else ()
    with pytest.raises(ValueError, match="pass call="):
        getattr(two_ears, export)(*args, received=two_ears.impulse)


@pytest.mark.parametrize("export", ["to_xarray", "to_mat"])
def test_a_given_record_with_a_call_at_another_rate_is_refused(one_ear, export, tmp_path):
    args = (tmp_path / "e.mat",) if export == "to_mat" else ()
    call = Call.linear_fm(80e3, 60e3, 2e-3, fs=250e3)
    with pytest.raises(ValueError, match="sampled at 250000 Hz"):
        getattr(one_ear, export)(*args, call=call, received=one_ear.impulse)
    with pytest.raises(TypeError, match="batecho.Call"):
        getattr(one_ear, export)(*args, call=np.ones(10), received=one_ear.impulse)
    assert not (tmp_path / "e.mat").exists()


@pytest.mark.parametrize("export", ["to_mat", "to_wav"])
def test_writing_into_a_missing_folder_names_the_folder(one_ear, export, tmp_path):
    with pytest.raises(FileNotFoundError, match="nodir"):
        getattr(one_ear, export)(tmp_path / "nodir" / "e.out")


@pytest.mark.parametrize("export", ["to_mat", "to_wav"])
def test_writing_onto_a_folder_is_refused_naming_it(one_ear, export, tmp_path):
    folder = tmp_path / "a_folder"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="a_folder"):
        getattr(one_ear, export)(folder)


def test_a_time_expansion_given_as_text_is_refused(one_ear, tmp_path):
    with pytest.raises(TypeError, match="time_expansion"):
        one_ear.to_wav(tmp_path / "e.wav", time_expansion="10")


def test_a_call_longer_than_the_record_costs_no_more_than_the_record():
    # only the call's first n samples reach the record's n: the convolution of all 10^7 of
    # them, for 64 poses, needed 5 GiB
    from _isolated import call_in_child

    r = call_in_child(
        "e = batecho.simulate(Leaves([[2.0, 0, 0]], [[1.0, 0, 0]], [0.02]), Sonar(),\n"
        "                     Poses(np.zeros((64, 3)), [1.0, 0, 0]))\n"
        "call = Call(np.ones(10_000_000), 400e3)\n"
        "e.received(call)\n"
        "e.compressed(call)",
        "import numpy as np\nimport batecho\nfrom batecho import Call, Leaves, Poses, Sonar",
        memory_gb=2.0,
    )
    assert r["raised"] is None, r


@pytest.mark.filterwarnings("ignore::batecho.CallBandWarning")  # (white noise as a call)
def test_received_of_a_call_longer_than_the_record_equals_numpy_convolve(one_ear):
    n = one_ear.times.size
    call = Call(np.random.default_rng(3).normal(size=n + 500), 400e3)
    want = np.convolve(one_ear.impulse[0], call.samples)[:n]
    got = one_ear.received(call)[0]
    assert np.max(np.abs(got - want)) <= 1e-10 * np.max(np.abs(want))


@pytest.mark.filterwarnings("ignore::batecho.CallBandWarning")  # (white noise as a call)
def test_compressed_of_a_call_longer_than_the_record_is_its_correlation_with_the_call(one_ear):
    n = one_ear.times.size
    call = Call(np.random.default_rng(3).normal(size=n + 500), 400e3)
    x = one_ear.received(call)[0]
    want = np.array([np.dot(x[t:], call.samples[: n - t]) for t in range(0, n, 997)])
    got = one_ear.compressed(call)[0][::997] * call.energy
    assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))


@pytest.mark.parametrize("record", ["received", "compressed"])
def test_a_call_mostly_beyond_the_band_warns_naming_its_share_and_the_band(one_ear, record):
    # an 80-40 kHz sweep: about half its energy lies below the default 60-80 kHz band
    with pytest.warns(
        batecho.CallBandWarning, match=r"(4[5-9]|5[0-5])% of the call's energy .*60000, 80000"
    ):
        getattr(one_ear, record)(Call.linear_fm(80e3, 40e3, 2e-3))


def test_a_call_within_the_band_records_without_a_warning(one_ear):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        one_ear.received(Call.linear_fm(79e3, 61e3, 2e-3))


def test_the_out_of_band_share_is_that_of_the_calls_spectrum():
    from batecho.echoes.received import out_of_band_share

    fs = 400e3
    t = np.arange(4000) / fs
    # two tones of equal power, one in the band and one below it
    call = Call(np.sin(2 * np.pi * 70e3 * t) + np.sin(2 * np.pi * 40e3 * t), fs)
    assert out_of_band_share(call, (60e3, 80e3)) == pytest.approx(0.5, abs=1e-6)
    assert out_of_band_share(call, (30e3, 80e3)) == pytest.approx(0.0, abs=1e-6)
