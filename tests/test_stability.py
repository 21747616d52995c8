"""Numerical stability on hard cases, each against a sum in higher precision: docs/model.md
evaluated in 40-digit arithmetic (mpmath) from the same f64 inputs, or the exactly rounded sum of
the f64 terms (math.fsum).

Conditioning, for reading the tolerances: ranges are computed from f64 coordinates, so r
carries a relative rounding error of ~1e-16, and a round-trip phase of Phi radians is
uncertain by ~1e-16 Phi (1e-10 rad at 1e6 rad). The core reduces phases exactly given r.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest
from _helpers import frame_points, kinked_leaf_at_the_top, rel_err

from batecho import Leaves, Poses, Sonar, reference, simulate

mp.mp.dps = 40


def mp_terms(leaves: Leaves, sonar: Sonar, pose: Poses, bins: np.ndarray) -> np.ndarray:
    """Windowed band spectrum Y at the given band-bin offsets, docs/model.md in mpmath; every
    leaf is assumed to count (the tests place them in the lobe)."""
    p = [mp.mpf(float(v)) for v in pose.positions[0]]
    frame = (pose.forward[0], pose.up[0], pose.left[0])
    d, u, l_ = ([mp.mpf(float(v)) for v in vec] for vec in frame)
    sx = (mp.radians(mp.mpf(sonar.beam.beamwidth_deg)) / 2) / mp.sqrt(2 * -mp.log(mp.mpf("0.7079")))
    a_coef = 1 / (2 * sx * sx)
    n, fs, v = sonar.n_samples, mp.mpf(sonar.fs), mp.mpf(sonar.sound_speed)
    k0, k1 = sonar.bins
    M = k1 - k0 + 1
    out = []
    for m in bins:
        f = (k0 + int(m)) * fs / n
        k = 2 * mp.pi * f / v
        hann = mp.mpf(0.5) - mp.cos(2 * mp.pi * int(m) / M) / 2
        w = mp.mpf(1) if sonar.window == "rect" else hann
        total = mp.mpc(0)
        for c, nv, a in zip(leaves.centers, leaves.normals, leaves.radii, strict=True):
            dx = [mp.mpf(float(ci)) - pi for ci, pi in zip(c, p, strict=True)]
            r = mp.sqrt(sum(x * x for x in dx))
            e = [x / r for x in dx]
            ed = sum(ei * di for ei, di in zip(e, d, strict=True))
            el_ = sum(ei * li for ei, li in zip(e, l_, strict=True))
            eu = sum(ei * ui for ei, ui in zip(e, u, strict=True))
            az, el = mp.atan2(el_, ed), mp.atan2(eu, mp.sqrt(ed * ed + el_ * el_))
            G = mp.exp(-a_coef * (az * az + el * el)) ** 2
            nn = [mp.mpf(float(x)) for x in nv]
            cr = [
                e[1] * nn[2] - e[2] * nn[1],
                e[2] * nn[0] - e[0] * nn[2],
                e[0] * nn[1] - e[1] * nn[0],
            ]
            cos_b = sum(x * y for x, y in zip(e, nn, strict=True))
            beta = mp.atan2(mp.sqrt(sum(x * x for x in cr)), cos_b)
            beta = min(beta, mp.pi - beta)
            cc = k * mp.mpf(float(a))
            if sonar.leaf_model == "paper":
                A = mp.mpf("0.5003") * cc**2 + mp.mpf("0.6867")
                B = mp.mpf("0.3999") * cc ** mp.mpf("-0.9065") + mp.mpf("0.9979")
                L = max(mp.mpf(0), A * mp.cos(B * beta))
                P = mp.mpf("0.9824") * cc ** mp.mpf("0.3523") - mp.mpf("0.9459")
                psi = mp.erf(P * (mp.mpf("1.57") - beta)) - mp.mpf("2.6343")
            else:
                x = 2 * cc * mp.sin(beta)
                jinc = mp.mpf(1) if x == 0 else 2 * mp.besselj(1, x) / x
                L, psi = cc**2 / 2 * mp.cos(beta) * abs(jinc), -mp.pi / 2
            amp = mp.mpf(sonar.gain) * G * L / k
            if sonar.spreading:
                amp /= r * r
            total += amp * mp.expj(-2 * k * r - psi)
        out.append(complex(w * total))
    return np.array(out)


AXIS = Poses([0.0, 0.0, 0.0], [1.0, 0.0, 0.0])


def few_leaves(rng, ranges, spread=0.05, radius=0.02):
    n = len(ranges)
    c = frame_points(
        AXIS, np.asarray(ranges), rng.uniform(-spread, spread, n), rng.uniform(-spread, spread, n)
    )
    return Leaves(c, rng.normal(size=(n, 3)), np.full(n, radius))


def test_phases_up_to_1e6_rad_match_mpmath():
    # r = 340 m: 2 k r = 2 (2 pi 80 kHz / 340) 340 = 1.0e6 rad at the top of the band.
    rng = np.random.default_rng(1)
    n = 2 * round(400 / 340 * 400e3)  # record range v n / (2 fs) = 400 m
    sonar = Sonar(
        lobe="cone", cone_half_angle_deg=10.0, max_range_m=400.0, n_samples=n, beamwidth_deg=30.0
    )
    leaves = few_leaves(rng, [339.9, 340.0, 340.05, 150.3], spread=0.01)
    bins = np.linspace(0, sonar.n_bins - 1, 25).astype(int)
    got = simulate(leaves, sonar, AXIS).spectrum[0, bins]
    want = mp_terms(leaves, sonar, AXIS, bins)
    assert 2 * 2 * np.pi * 80e3 / 340 * 340 > 1e6
    assert rel_err(got, want) <= 1e-9  # the f64 range alone moves the phase by ~1e-10 rad


def test_equal_amplitude_leaves_with_random_phases_cancel_as_the_exact_sum_does():
    # 1e5 leaves facing the sonar, spreading off: equal amplitudes, random round-trip phases.
    rng = np.random.default_rng(2)
    n = 100_000
    r = rng.uniform(2.0, 8.0, n)
    c = np.column_stack([r, np.zeros(n), np.zeros(n)])
    leaves = Leaves(c, np.tile([-1.0, 0.0, 0.0], (n, 1)), np.full(n, 0.02))
    sonar = Sonar(beamwidth_deg=30.0, spreading=False, window="rect")
    got = simulate(leaves, sonar, AXIS).spectrum[0]
    # the exactly rounded sum of the reference's f64 terms, at 40 bins
    bins = np.linspace(0, sonar.n_bins - 1, 40).astype(int)
    k0, _ = sonar.bins
    f = (k0 + bins) * sonar.fs / sonar.n_samples
    k = 2 * np.pi * f / sonar.sound_speed
    L, psi = reference._leaf_paper(k * 0.02, np.zeros(1))
    amp = sonar.gain * 1.0 * L / k  # G = 1 on the axis
    want = []
    for j in range(len(bins)):
        cyc = f[j] * (2.0 * r / sonar.sound_speed)
        phi = -2.0 * np.pi * (cyc - np.round(cyc)) - psi[j]
        want.append(complex(math.fsum(amp[j] * np.cos(phi)), math.fsum(amp[j] * np.sin(phi))))
    want = np.array(want)
    assert np.abs(want).mean() < 0.02 * n * amp.mean()  # the sum really cancels
    assert rel_err(got[bins], want) <= 1e-11  # reference's own phase rounding ~ 1e-12


def test_coincident_leaves_sum_to_n_times_one_leaf():
    rng = np.random.default_rng(3)
    one = few_leaves(rng, [3.7])
    n = 4096
    many = Leaves(
        np.repeat(one.centers, n, axis=0),
        np.repeat(one.normals, n, axis=0),
        np.repeat(one.radii, n),
    )
    sonar = Sonar(beamwidth_deg=30.0)
    a = simulate(one, sonar, AXIS).spectrum
    b = simulate(many, sonar, AXIS)
    assert b.n_leaves[0] == n
    assert rel_err(b.spectrum, n * a) <= 1e-13


def test_leaves_at_the_smallest_allowed_range_match_mpmath():
    sonar = Sonar(beamwidth_deg=30.0, min_range_m=0.01)
    rng = np.random.default_rng(4)
    leaves = few_leaves(rng, [0.01, 0.0100001, 0.02], spread=0.001)
    bins = np.linspace(0, sonar.n_bins - 1, 30).astype(int)
    got = simulate(leaves, sonar, AXIS)
    assert got.n_leaves[0] == 3 and np.isfinite(got.impulse).all()
    assert rel_err(got.spectrum[0, bins], mp_terms(leaves, sonar, AXIS, bins)) <= 1e-12
    too_near = few_leaves(rng, [0.0099999], spread=0.0)
    with pytest.raises(ValueError, match="closer than min_range_m"):
        simulate(too_near, sonar, AXIS)


@pytest.mark.parametrize("model", ["paper", "physical_optics"])
def test_leaves_at_the_ka_guard_match_mpmath(model):
    sonar = Sonar(beamwidth_deg=30.0, leaf_model=model, window="rect")
    k_lo = 2 * np.pi * sonar.freqs[0] / sonar.sound_speed
    a_min = sonar.min_ka / k_lo * (1 + 1e-12)
    rng = np.random.default_rng(5)
    leaves = few_leaves(rng, [1.0, 2.5, 4.0], radius=a_min)
    bins = np.linspace(0, sonar.n_bins - 1, 30).astype(int)
    got = simulate(leaves, sonar, AXIS).spectrum[0, bins]
    assert rel_err(got, mp_terms(leaves, sonar, AXIS, bins)) <= 1e-12
    smaller = few_leaves(rng, [1.0], radius=a_min * (1 - 1e-9))
    with pytest.raises(ValueError, match="below min_ka"):
        simulate(smaller, sonar, AXIS)


def test_records_of_1e6_samples_match_mpmath_and_place_echoes_right():
    sonar = Sonar(
        beamwidth_deg=30.0,
        n_samples=1_000_000,
        lobe="cone",
        cone_half_angle_deg=15.0,
        max_range_m=400.0,
    )
    assert sonar.n_bins == 50_001
    rng = np.random.default_rng(6)
    ranges = [5.0, 57.3, 233.0]
    leaves = few_leaves(rng, ranges, spread=0.002)
    echo = simulate(leaves, sonar, AXIS)
    bins = np.linspace(0, sonar.n_bins - 1, 20).astype(int)
    assert rel_err(echo.spectrum[0, bins], mp_terms(leaves, sonar, AXIS, bins)) <= 1e-10
    env = echo.envelope()[0]
    for r in ranges:
        t = round(2 * r / sonar.sound_speed * sonar.fs)
        window = env[t - 50 : t + 51]
        assert abs(int(np.argmax(window)) - 50) <= 1
    full = np.zeros(sonar.n_samples // 2 + 1, dtype=complex)
    k0, k1 = sonar.bins
    full[k0 : k1 + 1] = echo.spectrum[0]
    np.testing.assert_allclose(
        echo.impulse[0],
        2 * np.fft.irfft(full, sonar.n_samples),
        atol=1e-15 * np.abs(echo.impulse).max(),
    )


@pytest.mark.parametrize(
    ("radius", "live", "r"), [(0.003, 82, 4.0), (0.0056, 8, 9.48), (0.01, 34, 1.0)]
)
def test_a_kinked_leaf_with_a_tiny_live_part_matches_mpmath_to_the_cosines_floor(radius, live, r):
    # Near grazing incidence with the corner (cos(B(c) beta) turning positive) in the band's
    # top `live` bins, the live values are ~1e-4 of the factor's scale A(c); in f64, B(c) beta
    # (the powers' 1-ulp rounding alone) moves the cosine by ~1e-12 of them. Both methods sit
    # at that floor (measured for the exact sum: 1.7e-13, 2.7e-12 and 9.9e-13 for these three;
    # fast at 1e-9: 2.5e-13, 2.5e-12, 2.1e-13); the fast method at tol=1e-12 sums the last two
    # exactly.
    sonar = Sonar(beamwidth_deg=30.0)
    leaf = kinked_leaf_at_the_top(sonar, radius, live, r)
    bins = np.arange(sonar.n_bins - live - 2, sonar.n_bins)
    want = mp_terms(leaf, sonar, AXIS, bins)
    assert abs(np.count_nonzero(want) - live) <= 1
    exact = simulate(leaf, sonar, AXIS, method="exact").spectrum[0, bins]
    assert rel_err(exact, want) <= 4e-12
    assert (
        rel_err(simulate(leaf, sonar, AXIS, method="fast", tol=1e-12).spectrum[0, bins], want)
        <= 4e-12
    )
    assert (
        rel_err(simulate(leaf, sonar, AXIS, method="fast", tol=1e-9).spectrum[0, bins], want)
        <= 1e-9
    )
