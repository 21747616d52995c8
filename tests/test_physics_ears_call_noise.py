"""The two ears, the emitted call and the noise checked against computations of their own
(docs/model.md §5a, §5b): each ear's one-leaf spectrum from plain geometry and the documented
formulas, the level difference of ears at one place from their Gaussian patterns alone, the
calls from ``scipy.signal.chirp``, the received echo as the call's spectrum times the leaf's
transfer, and the noise's power, whiteness, independence and matched-filter gain by sampling.

Nothing here calls the library's own formulas: the geometry, beams, leaf model, windows and
statistics are written out below from the model page, so that a fault shared by the Rust core
and the NumPy reference would show. The statistical tests use fixed seeds and a tolerance of
five standard deviations of their estimator (a false alarm about once in 1.7 million runs, had
the seeds been random)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _helpers import rel_err
from scipy.signal import chirp, get_window
from scipy.special import erf

import batecho
from batecho import Call, Leaves, Poses, Sonar
from batecho.echoes.binaural import interaural_level_difference

SOUND_SPEED = 340.0  # m/s, the model's default
FS = 400e3  # Hz, the model's default sample rate
N_SAMPLES = 24_000  # the model's default record
BAND_HZ = (60e3, 80e3)  # the model's default band
GAIN = 0.2  # g, the model's default


# ---- the model page written out independently (docs/model.md §1, §2, §4, §5, §5a) -----------


def sonar_frame(forward, up):
    """(d, l, u): the beam axis, left = u x d and the up vector re-orthogonalised (§1)."""
    d = np.asarray(forward, float) / np.linalg.norm(forward)
    u = np.asarray(up, float) - np.dot(up, d) * d
    u /= np.linalg.norm(u)
    return d, np.cross(u, d), u


def azimuth_elevation(e, frame):
    d, left, u = frame
    return math.atan2(e @ left, e @ d), math.atan2(e @ u, math.hypot(e @ d, e @ left))


def gaussian_sigma_rad(beamwidth_deg):
    """σ of the one-way Gaussian whose full width at amplitude 0.7079 (−3 dB) is the beamwidth."""
    return math.radians(beamwidth_deg / 2.0) / math.sqrt(-2.0 * math.log(0.7079))


def one_way_pattern(e, frame, beamwidth_deg, center_deg=(0.0, 0.0)):
    """The circular Gaussian beam of §2 centred on ``center_deg`` = (az0, el0)."""
    az, el = azimuth_elevation(e, frame)
    d_az = (az - math.radians(center_deg[0]) + math.pi) % (2.0 * math.pi) - math.pi
    d_el = el - math.radians(center_deg[1])
    s = gaussian_sigma_rad(beamwidth_deg)
    return math.exp(-(d_az**2 + d_el**2) / (2.0 * s * s))


def band_bins_and_window():
    """The band's rFFT bins and the periodic Hann window over them (§5)."""
    df = FS / N_SAMPLES
    k0, k1 = (math.floor(f / df + 0.5) for f in BAND_HZ)
    bins = np.arange(k0, k1 + 1)
    m = np.arange(bins.size)
    return bins, 0.5 - 0.5 * np.cos(2.0 * np.pi * m / bins.size)


def paper_leaf(ka, beta):
    """Ming et al.'s fit (§4): the factor L and the phase ψ at c = k a and incidence β."""
    a_c = 0.5003 * ka**2 + 0.6867
    b_c = 0.3999 * ka**-0.9065 + 0.9979
    p_c = 0.9824 * ka**0.3523 - 0.9459
    return np.maximum(0.0, a_c * np.cos(b_c * beta)), erf(p_c * (1.57 - beta)) - 2.6343


def one_leaf_spectrum_at_ear(
    p, frame, centre, normal, radius, ear_offset_m, beamwidth_deg, ear_center_deg
):
    """Y_k of one paper-model leaf heard by an ear at ``ear_offset_m`` (forward, left, up) in
    the sonar's frame facing ``ear_center_deg``, the emitter at ``p`` (§5a)."""
    d, left, u = frame
    ear = p + ear_offset_m[0] * d + ear_offset_m[1] * left + ear_offset_m[2] * u
    r_tx, r_rx = np.linalg.norm(centre - p), np.linalg.norm(centre - ear)
    e_tx, e_rx = (centre - p) / r_tx, (centre - ear) / r_rx
    s_tx = one_way_pattern(e_tx, frame, beamwidth_deg)
    s_rx = one_way_pattern(e_rx, frame, beamwidth_deg, ear_center_deg)
    bisector = (e_tx + e_rx) / np.linalg.norm(e_tx + e_rx)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    beta = math.atan2(np.linalg.norm(np.cross(bisector, n)), bisector @ n)
    beta = min(beta, math.pi - beta)
    bins, window = band_bins_and_window()
    k = 2.0 * np.pi * bins * (FS / N_SAMPLES) / SOUND_SPEED
    leaf, psi = paper_leaf(k * radius, beta)
    amplitude = GAIN * s_tx * s_rx * leaf / (k * r_tx * r_rx)
    return window * amplitude * np.exp(1j * (-k * (r_tx + r_rx) - psi))


def point_in_frame(p, frame, r, az_deg, el_deg):
    d, left, u = frame
    az, el = math.radians(az_deg), math.radians(el_deg)
    return p + r * (
        math.cos(el) * math.cos(az) * d + math.cos(el) * math.sin(az) * left + math.sin(el) * u
    )


# ---- two ears ---------------------------------------------------------------------------------

POSE_AT = np.array([0.5, -1.0, 2.0])
POSE_FORWARD, POSE_UP = np.array([1.0, 0.2, -0.1]), np.array([0.0, 0.1, 1.0])


@pytest.mark.parametrize(
    ("separation_m", "ear_yaw_deg", "ear_pitch_deg", "r_m", "az_deg", "el_deg"),
    [
        (0.02, 30.0, 0.0, 2.5, 15.0, 5.0),  # bat-like ears, a leaf ahead on the left
        (0.3, 25.0, 10.0, 0.6, -20.0, -8.0),  # wide ears, a near leaf: bistatic angle ~28 deg
        (0.0, 30.0, 0.0, 3.0, 8.0, 0.0),  # ears at the emitter turned apart
    ],
)
def test_each_ears_one_leaf_spectrum_is_the_bistatic_formula_from_plain_geometry(
    separation_m, ear_yaw_deg, ear_pitch_deg, r_m, az_deg, el_deg
):
    # Tolerance 1e-10 relative: the round-trip phase k (r_tx + r_rx) reaches ~1e4 rad, which
    # this naive NumPy sum holds to ~1e-12; a fault in the geometry, a pattern or a sign is O(1).
    frame = sonar_frame(POSE_FORWARD, POSE_UP)
    centre = point_in_frame(POSE_AT, frame, r_m, az_deg, el_deg)
    normal = -(centre - POSE_AT) + 0.4 * frame[2] + 0.3 * frame[1]
    sonar = Sonar.binaural(
        separation_m,
        ear_yaw_deg,
        ear_pitch_deg,
        beamwidth_deg=40.0,
        lobe="cone",
        cone_half_angle_deg=80.0,
    )
    pose = Poses(POSE_AT, POSE_FORWARD, POSE_UP)
    got = batecho.simulate(Leaves([centre], [normal], [0.02]), sonar, pose, method="exact")
    assert got.n_leaves.tolist() == [[1, 1]]
    for j, side in enumerate((+1.0, -1.0)):  # the left ear first
        want = one_leaf_spectrum_at_ear(
            POSE_AT,
            frame,
            centre,
            normal,
            0.02,
            (0.0, side * separation_m / 2.0, 0.0),
            40.0,
            (side * ear_yaw_deg, ear_pitch_deg),
        )
        assert rel_err(got.spectrum[0, j], want) <= 1e-10, j


@pytest.mark.parametrize(("az_deg", "el_deg"), [(12.0, 8.0), (-7.0, -15.0)])
def test_ears_at_one_place_differ_in_level_by_their_patterns_alone(az_deg, el_deg):
    # At zero separation both ears share every path and incidence, so the level difference is
    # 20 log10(S_left / S_right) with the Gaussians centred on (+yaw, pitch) and (-yaw, pitch):
    # exp(-((az - yaw)^2 - (az + yaw)^2) / (2 sigma^2)) = exp(2 az yaw / sigma^2), whatever
    # the elevation (both ears pitch alike). Tolerance 1e-9 dB: a ratio of two sums of squares.
    yaw_deg, beamwidth_deg = 30.0, 40.0
    sonar = Sonar.binaural(0.0, yaw_deg, 10.0, beamwidth_deg=beamwidth_deg)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    frame = sonar_frame([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    centre = point_in_frame(np.zeros(3), frame, 2.0, az_deg, el_deg)
    echoes = batecho.simulate(Leaves([centre], [-centre], [0.02]), sonar, pose)
    sigma = gaussian_sigma_rad(beamwidth_deg)
    want_db = 20.0 / math.log(10.0) * 2.0 * math.radians(az_deg) * math.radians(yaw_deg) / sigma**2
    assert abs(interaural_level_difference(echoes)[0] - want_db) <= 1e-9


@pytest.mark.parametrize("method", ["exact", "fast"])
def test_ears_with_no_separation_facing_ahead_both_hear_the_one_ear_echo(method):
    # Tolerance 1e-12 relative, as tests/test_receivers.py holds a receiver at the emitter.
    from batecho.echoes.canonical import canonical_leaf_box, canonical_pose

    leaves = canonical_leaf_box(np.random.default_rng(3), density_per_m3=20.0)
    one = batecho.simulate(leaves, Sonar(beamwidth_deg=40.0), canonical_pose(), method=method)
    two = batecho.simulate(
        leaves, Sonar.binaural(0.0, 0.0, beamwidth_deg=40.0), canonical_pose(), method=method
    )
    assert one.n_leaves[0] > 100
    for ear in (0, 1):
        assert np.array_equal(two.n_leaves[:, ear], one.n_leaves)
        assert rel_err(two.spectrum[:, ear], one.spectrum) <= 1e-12
        assert rel_err(two.impulse[:, ear], one.impulse) <= 1e-12


# ---- the call -----------------------------------------------------------------------------------


def symmetric_window(name, m):
    """SciPy's symmetric window (§5b: Hann, Hamming, Blackman, Tukey with 25 % taper, none)."""
    if name == "rect":
        return np.ones(m)
    return get_window(("tukey", 0.25) if name == "tukey" else name, m, fftbins=False)


SWEEPS = [(80e3, 60e3, 2e-3), (45e3, 95e3, 3.3e-3)]


@pytest.mark.parametrize("window", ["hann", "hamming", "blackman", "tukey", "rect"])
@pytest.mark.parametrize(("f_start_hz", "f_end_hz", "duration_s"), SWEEPS)
def test_a_linear_sweep_is_scipys_linear_chirp_times_the_window(
    f_start_hz, f_end_hz, duration_s, window
):
    # sin = cos(. - 90 deg); the parameters are in Hz and s. Tolerance 1e-9: phases reach
    # ~2e3 rad, which the two computations round differently by ~1e-13.
    call = Call.linear_fm(f_start_hz, f_end_hz, duration_s, window=window)
    m = round(duration_s * FS)
    t = np.arange(m) / FS
    want = chirp(t, f_start_hz, duration_s, f_end_hz, method="linear", phi=-90.0)
    assert call.samples.shape == (m,) and call.duration_s == m / FS
    np.testing.assert_allclose(call.samples, want * symmetric_window(window, m), rtol=0, atol=1e-9)


@pytest.mark.parametrize(("f_start_hz", "f_end_hz", "duration_s"), SWEEPS)
def test_a_hyperbolic_sweep_is_scipys_hyperbolic_chirp_times_the_window(
    f_start_hz, f_end_hz, duration_s
):
    # SciPy's f(t) = f0 f1 T / ((f0 - f1) t + f1 T) is §5b's 1 / (1/f0 + (1/f1 - 1/f0) t / T).
    call = Call.hyperbolic_fm(f_start_hz, f_end_hz, duration_s)
    m = round(duration_s * FS)
    t = np.arange(m) / FS
    want = chirp(t, f_start_hz, duration_s, f_end_hz, method="hyperbolic", phi=-90.0)
    np.testing.assert_allclose(call.samples, want * symmetric_window("hann", m), rtol=0, atol=1e-9)


def test_a_cf_fm_call_holds_its_frequency_then_sweeps_on_in_phase_to_its_end_frequency():
    # The constant part is a chirp from f_cf to f_cf; the tail a linear chirp from f_cf to
    # f_end over T_fm, started at the phase the constant part reached (2 pi f_cf t_cf).
    f_cf_hz, f_end_hz, duration_s, fm_duration_s = 75e3, 62e3, 10e-3, 2.5e-3
    call = Call.cf_fm(f_cf_hz, duration_s, f_end_hz, fm_duration_s, window="rect")
    t = np.arange(round(duration_s * FS)) / FS
    t_cf = duration_s - fm_duration_s
    cf = t < t_cf
    want = np.empty_like(t)
    want[cf] = chirp(t[cf], f_cf_hz, duration_s, f_cf_hz, phi=-90.0)
    phase_at_t_cf_deg = 360.0 * ((f_cf_hz * t_cf) % 1.0) - 90.0
    tail = chirp(t[~cf] - t_cf, f_cf_hz, fm_duration_s, f_end_hz, phi=phase_at_t_cf_deg)
    want[~cf] = tail
    np.testing.assert_allclose(call.samples, want, rtol=0, atol=1e-9)


def one_leaf_echo():
    """A leaf 3 m away, 8 degrees off the axis and lit obliquely, and its echo at the default
    sonar (its transfer independently: ``one_leaf_spectrum_at_ear`` with the ear at the
    emitter)."""
    frame = sonar_frame([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    centre = point_in_frame(np.zeros(3), frame, 3.0, 8.0, 2.0)
    normal = np.array([-1.0, -0.1, 0.05])
    sonar = Sonar(beamwidth_deg=40.0)
    pose = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    echoes = batecho.simulate(Leaves([centre], [normal], [0.02]), sonar, pose, method="exact")
    transfer = one_leaf_spectrum_at_ear(
        np.zeros(3), frame, centre, normal, 0.02, (0.0, 0.0, 0.0), 40.0, (0.0, 0.0)
    )
    return echoes, transfer


def test_the_received_echo_of_one_leaf_is_the_calls_spectrum_times_the_leafs_transfer():
    # y = 2 irfft(Y) has rfft 2 Y; the record is y convolved with the call, so at the band
    # bins rfft(x) = 2 Y C with C the call's rfft over the record. The echo (at 17.6 ms) and
    # the call (2 ms) end well inside the 60 ms record; what the truncation to the record
    # changes is y's ringing at the record's ends (6e-9 of its peak), 6e-10 of the result
    # here. Tolerance 1e-8 relative.
    echoes, transfer = one_leaf_echo()
    duration_s = 2e-3
    m = round(duration_s * FS)
    t = np.arange(m) / FS
    call_samples = chirp(t, 80e3, duration_s, 60e3, phi=-90.0) * symmetric_window("hann", m)
    call_spectrum = np.fft.rfft(call_samples, N_SAMPLES)
    bins, _ = band_bins_and_window()
    got = np.fft.rfft(echoes.received(Call.linear_fm(80e3, 60e3, duration_s))[0])
    assert rel_err(got[bins], 2.0 * transfer * call_spectrum[bins]) <= 1e-8


@pytest.mark.filterwarnings("ignore::batecho.CallBandWarning")  # (warned of on purpose)
def test_a_call_reaching_beyond_the_band_is_heard_only_within_the_band():
    # An 80-40 kHz sweep holds half its energy below the 60-80 kHz band; the record holds only
    # the band's part (Y is zero outside it). The only energy outside comes from cutting y's
    # ringing at the record's ends (6e-9 of its peak here), ~1e-8 of the in-band part with
    # this call, against ~1 had the call's lower half been heard. Tolerance 1e-6.
    echoes, _ = one_leaf_echo()
    call = Call.linear_fm(80e3, 40e3, 2e-3)
    c = np.abs(np.fft.rfft(call.samples, N_SAMPLES)) ** 2
    bins, _ = band_bins_and_window()
    assert 0.45 < c[bins].sum() / c.sum() < 0.55
    x = np.fft.rfft(echoes.received(call)[0])
    outside = np.ones(x.size, bool)
    outside[bins] = False
    assert np.linalg.norm(x[outside]) <= 1e-6 * np.linalg.norm(x[bins])


# ---- the noise ----------------------------------------------------------------------------------

NOISE_RMS = 1e-3
N_SEEDS = 20


@pytest.fixture(scope="module")
def two_ears_two_poses():
    """One leaf heard by two ears from two poses (records (2, 2, 24000)) and a call."""
    leaves = Leaves([[3.0, 0.2, 0.0]], [[1.0, 0.0, 0.0]], [0.02])
    poses = Poses(np.zeros((2, 3)), [[1.0, 0.0, 0.0], [1.0, 0.1, 0.0]])
    echoes = batecho.simulate(leaves, Sonar.binaural(0.02, 30.0), poses)
    return echoes, Call.linear_fm(80e3, 60e3, 2e-3)


@pytest.fixture(scope="module")
def noise_draws(two_ears_two_poses):
    """(seeds, poses, ears, samples): what the noise added, for seeds 0 .. N_SEEDS - 1."""
    echoes, call = two_ears_two_poses
    clean = echoes.received(call)
    return np.stack([echoes.received(call, NOISE_RMS, seed) - clean for seed in range(N_SEEDS)])


def test_the_noise_power_per_sample_is_noise_rms_squared(noise_draws):
    # mean(w^2) of N independent N(0, σ²) samples has standard deviation σ² sqrt(2/N);
    # N = 1.92e6 gives 5 sd = 0.51 %.
    n = noise_draws.size
    power = np.mean(noise_draws**2)
    assert abs(power / NOISE_RMS**2 - 1.0) <= 5.0 * math.sqrt(2.0 / n)


def test_the_noise_has_zero_mean(noise_draws):
    # the sample mean has standard deviation σ / sqrt(N)
    assert abs(np.mean(noise_draws)) <= 5.0 * NOISE_RMS / math.sqrt(noise_draws.size)


def test_the_noise_is_white(noise_draws):
    # for independent samples the lag-k autocorrelation estimate mean(w_t w_t+k) / σ² has
    # standard deviation 1 / sqrt(N_k); a band-limited or coloured noise would fail at lag 1
    w = noise_draws.reshape(-1, noise_draws.shape[-1])
    for lag in range(1, 9):
        products = w[:, lag:] * w[:, :-lag]
        assert abs(np.mean(products) / NOISE_RMS**2) <= 5.0 / math.sqrt(products.size), lag


def test_the_two_ears_and_the_poses_hear_independent_noise(noise_draws):
    # the sample correlation of independent Gaussians has standard deviation 1 / sqrt(N)
    def correlation(a, b):
        return float(np.mean(a * b) / NOISE_RMS**2)

    left, right = noise_draws[:, :, 0], noise_draws[:, :, 1]
    assert abs(correlation(left, right)) <= 5.0 / math.sqrt(left.size)
    first, second = noise_draws[:, 0], noise_draws[:, 1]
    assert abs(correlation(first, second)) <= 5.0 / math.sqrt(first.size)


def test_the_noise_is_added_to_the_echo_whatever_the_echo(two_ears_two_poses):
    # the same seed adds the same noise to a quite different echo of the same record shape
    # (up to the rounding of the sum, ~1e-16 of the echo)
    echoes, call = two_ears_two_poses
    other = batecho.simulate(
        Leaves([[1.5, -0.3, 0.1], [4.0, 0.5, 0.0]], [[1.0, 0.2, 0.0], [1.0, 0.0, 0.3]], [0.03] * 2),
        echoes.sonar,
        echoes.poses,
    )
    assert other.impulse.shape == echoes.impulse.shape
    w1 = echoes.received(call, NOISE_RMS, 11) - echoes.received(call)
    w2 = other.received(call, NOISE_RMS, 11) - other.received(call)
    assert np.max(np.abs(w1 - w2)) <= 1e-9 * NOISE_RMS


def test_the_matched_filter_divides_the_noise_power_by_the_calls_energy(two_ears_two_poses):
    # z = sum_tau w[t + tau] c[tau] / E has variance σ² sum c² / E² = σ² / E where the call
    # fits in the record, and autocorrelation ρ[k], the call's normalised autocorrelation; the
    # sample mean of z² over N such samples then has relative standard deviation
    # sqrt(2 sum_k ρ[k]² / N) (Isserlis), ~0.9 % for 10 seeds here.
    echoes, call = two_ears_two_poses
    c = np.asarray(call.samples)
    energy = float(c @ c)
    rho = np.correlate(c, c, "full") / energy
    clean = echoes.compressed(call)
    fits = N_SAMPLES - c.size + 1
    z = np.stack([(echoes.compressed(call, NOISE_RMS, s) - clean)[..., :fits] for s in range(10)])
    relative_sd = math.sqrt(2.0 * np.sum(rho**2) / z.size)
    assert abs(np.mean(z**2) / (NOISE_RMS**2 / energy) - 1.0) <= 5.0 * relative_sd
