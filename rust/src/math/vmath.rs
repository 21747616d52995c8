//! Branch-free elementary functions for the spectrum kernel, written so that a loop over a
//! block of lanes vectorises (no calls, no branches on data). Each holds on a stated domain
//! to about 1e-16 absolute error; tests compare them with libm.

use crate::math::erf_table::{ERFCX_CHEB, ERF_DEGREE, ERF_INTERVALS, ERF_TAYLOR, ERF_WIDTH};

const PIO2_HI: f64 = std::f64::consts::FRAC_PI_2; // pi/2 rounded to f64
const PIO2_LO: f64 = 6.123_233_995_736_766e-17; // pi/2 - PIO2_HI

/// Taylor coefficients of sin: `(-1)^k / (2k + 1)!`.
const SIN_C: [f64; 12] = [
    1.0,
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5040.0,
    1.0 / 362_880.0,
    -1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    -1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    -1.0 / 121_645_100_408_832_000.0,
    1.0 / 51_090_942_171_709_440_000.0,
    -1.0 / 25_852_016_738_884_976_640_000.0,
];

/// Taylor coefficients of cos: `(-1)^k / (2k)!`.
const COS_C: [f64; 12] = [
    1.0,
    -1.0 / 2.0,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40_320.0,
    -1.0 / 3_628_800.0,
    1.0 / 479_001_600.0,
    -1.0 / 87_178_291_200.0,
    1.0 / 20_922_789_888_000.0,
    -1.0 / 6_402_373_705_728_000.0,
    1.0 / 2_432_902_008_176_640_000.0,
    -1.0 / 1_124_000_727_777_607_680_000.0,
];

/// Horner in `y2` over the first `K` coefficients.
#[inline(always)]
fn horner<const K: usize>(c: &[f64; 12], y2: f64) -> f64 {
    let mut p = c[K - 1];
    for k in (0..K - 1).rev() {
        p = p.mul_add(y2, c[k]);
    }
    p
}

/// `sin(y)` for |y| <= pi/2 + 0.01 from the first `K` Taylor terms (K = 12: truncation
/// < 1e-20; K = 9: < 5e-14).
#[inline(always)]
pub fn sin_small_k<const K: usize>(y: f64) -> f64 {
    y * horner::<K>(&SIN_C, y * y)
}

/// `cos(x)` for x in [0, pi]: `-sin(x - pi/2)` with pi/2 in two parts.
#[inline(always)]
pub fn cos_0_pi(x: f64) -> f64 {
    cos_0_pi_k::<12>(x)
}

/// [`cos_0_pi`] from the first `K` Taylor terms of sin.
#[inline(always)]
pub fn cos_0_pi_k<const K: usize>(x: f64) -> f64 {
    -sin_small_k::<K>((x - PIO2_HI) - PIO2_LO)
}

/// `(sin e, cos e)` for |e| <= 1: Taylor series to e^21 / e^22.
#[inline(always)]
pub fn sincos_unit(e: f64) -> (f64, f64) {
    sincos_unit_k::<11, 12>(e)
}

/// `(sin e, cos e)` for |e| <= 1 from the first `KS` / `KC` Taylor terms (7 / 8: < 8e-13).
#[inline(always)]
pub fn sincos_unit_k<const KS: usize, const KC: usize>(e: f64) -> (f64, f64) {
    let e2 = e * e;
    (e * horner::<KS>(&SIN_C, e2), horner::<KC>(&COS_C, e2))
}

/// `exp(x)` for x <= 0 (clamped below at -700, where exp is 1e-304): reduction by ln 2 and a
/// Taylor polynomial to degree 13 on |r| <= ln(2)/2, by Estrin's scheme for the terms from
/// r^2 on (a chain of 4 FMAs and the powers, where Horner's is 11 long: the lobe test's gains
/// wait on it) and Horner's for the last two. (A loop version for every degree broke the
/// vectorisation of the callers' lane loops.)
#[inline(always)]
pub fn exp_nonpos(x: f64) -> f64 {
    const C: [f64; 14] = INV_FACT;
    let (n, r) = exp_reduce(x);
    let (r2, r4) = (r * r, (r * r) * (r * r));
    let q0 = C[5].mul_add(r, C[4]).mul_add(r2, C[3].mul_add(r, C[2]));
    let q1 = C[9].mul_add(r, C[8]).mul_add(r2, C[7].mul_add(r, C[6]));
    let q2 = C[13].mul_add(r, C[12]).mul_add(r2, C[11].mul_add(r, C[10]));
    let high = q2.mul_add(r4, q1).mul_add(r4, q0);
    times_pow2(high.mul_add(r, C[1]).mul_add(r, C[0]), n)
}

/// `x` (clamped to [-700, 0]) as `n ln 2 + r`, `|r| <= ln(2)/2`: `(n, r)`.
#[inline(always)]
fn exp_reduce(x: f64) -> (f64, f64) {
    const LN2_HI: f64 = 6.931_471_803_691_238e-1; // 0x3fe62e42fee00000
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let x = x.clamp(-700.0, 0.0);
    let n = (x * std::f64::consts::LOG2_E).round_ties_even();
    (n, n.mul_add(-LN2_LO, n.mul_add(-LN2_HI, x)))
}

/// `p 2^n` for an integer-valued `n` in [-1010, 0], without a float-to-int conversion: the low
/// mantissa bits of `n + 1023 + 2^52` hold `n + 1023`; shifted into the exponent field.
#[inline(always)]
fn times_pow2(p: f64, n: f64) -> f64 {
    let t = n + (1023.0 + 4_503_599_627_370_496.0);
    p * f64::from_bits(t.to_bits() << 52)
}

/// `1 / k!`, k = 0..13.
const INV_FACT: [f64; 14] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40_320.0,
    1.0 / 362_880.0,
    1.0 / 3_628_800.0,
    1.0 / 39_916_800.0,
    1.0 / 479_001_600.0,
    1.0 / 6_227_020_800.0,
];

/// [`exp_nonpos`]'s reduction with a Taylor polynomial of degree `D` by Horner's scheme (D = 10:
/// relative error < 4e-13; at D = 13 not the same bits as [`exp_nonpos`], whose polynomial is
/// Estrin's).
#[inline(always)]
pub fn exp_nonpos_d<const D: usize>(x: f64) -> f64 {
    let (n, r) = exp_reduce(x);
    let mut p = INV_FACT[D];
    for &c in INV_FACT[..D].iter().rev() {
        p = p.mul_add(r, c);
    }
    times_pow2(p, n)
}

/// Index of the erf interval holding |z| (the last one is the constant 1 beyond 6).
#[inline(always)]
pub fn erf_interval(z: f64) -> usize {
    let t = (z.abs() * (1.0 / ERF_WIDTH)).min(ERF_INTERVALS as f64);
    t as usize
}

/// `erf(z)` using interval `i` (which must hold |z|, see [`erf_interval`]).
#[inline(always)]
pub fn erf_in(i: usize, z: f64) -> f64 {
    let c = &ERF_TAYLOR[i];
    let a = z.abs().min(ERF_WIDTH * (ERF_INTERVALS as f64 + 1.0));
    let u = a - (i as f64 + 0.5) * ERF_WIDTH;
    let mut p = c[ERF_DEGREE];
    for k in (0..ERF_DEGREE).rev() {
        p = p.mul_add(u, c[k]);
    }
    p.copysign(z)
}

/// `erf(z)` for any finite z.
#[inline(always)]
pub fn erf(z: f64) -> f64 {
    erf_in(erf_interval(z), z)
}

/// `erf(z)` for any finite z without table lookups (for lanes with unrelated arguments):
/// `1 - exp(-z^2) erfcx(|z|)`, erfcx by its Chebyshev series on [0, 6] (Clenshaw), erf = 1
/// beyond 6. Absolute error about 3e-16.
#[inline(always)]
pub fn erf_cheb(z: f64) -> f64 {
    erf_cheb_n::<40>(z)
}

/// [`erf_cheb`] from the first `N` (even) Chebyshev terms of erfcx (N = 28: absolute error
/// < 3e-13): one lane of [`erf_cheb_lanes`].
#[inline(always)]
pub fn erf_cheb_n<const N: usize>(z: f64) -> f64 {
    erf_cheb_lanes::<N, 1>(&[z])[0]
}

/// [`erf_cheb_n`] over `L` independent lanes, coefficient loop outermost, so that the lanes'
/// recurrences interleave (for `L` up to a few vector registers). N = 22 (with a shorter exp):
/// absolute error < 1e-9.
#[inline(always)]
pub fn erf_cheb_lanes<const N: usize, const L: usize>(z: &[f64; L]) -> [f64; L] {
    erf_exp_cheb_lanes::<N, L>(z).0
}

/// The first `N` (even) Chebyshev terms of erfcx split as `lo(t) + T_(N/2)(t) hi(t)`, both of
/// degree `N/2 - 1` (`T_(m+j) = 2 T_m T_j - T_(m-j)`), so that two independent Clenshaw chains
/// of half the length replace one.
const fn split_cheb<const N: usize>() -> ([f64; 20], [f64; 20]) {
    let m = N / 2;
    // (N = 40 is not split, see `erf_exp_cheb_lanes`; its table is never read)
    assert!(N == 22 || N == 28 || N == 40, "cheb_t has T_11 and T_14");
    let (mut lo, mut hi) = ([0.0; 20], [0.0; 20]);
    let mut n = 0;
    while n < m {
        lo[n] = ERFCX_CHEB[n];
        if n > 0 {
            lo[n] -= ERFCX_CHEB[2 * m - n];
        }
        hi[n] = if n == 0 {
            ERFCX_CHEB[m]
        } else {
            2.0 * ERFCX_CHEB[m + n]
        };
        n += 1;
    }
    (lo, hi)
}

/// `T_(N/2)(t)` for the even `N` of [`split_cheb`] (by doubling and `T_(a+b) = 2 T_a T_b - T_(a-b)`).
#[inline(always)]
fn cheb_t<const N: usize>(t: f64) -> f64 {
    let t2 = (2.0 * t).mul_add(t, -1.0);
    let t3 = (2.0 * t).mul_add(t2, -t);
    let t4 = (2.0 * t2).mul_add(t2, -1.0);
    let t5 = (2.0 * t2).mul_add(t3, -t);
    let t8 = (2.0 * t4).mul_add(t4, -1.0);
    match N / 2 {
        11 => (2.0 * t8).mul_add(t3, -t5),
        14 => {
            let t6 = (2.0 * t3).mul_add(t3, -1.0);
            (2.0 * t8).mul_add(t6, -t2)
        }
        _ => unreachable!(),
    }
}

/// [`erf_cheb_lanes`] and the `exp(-z^2)` it uses (the same polynomial exp, of the unclamped
/// `z`; past |z| = 6, where the erf is 1, it is not used for the erf).
#[inline(always)]
pub fn erf_exp_cheb_lanes<const N: usize, const L: usize>(z: &[f64; L]) -> ([f64; L], [f64; L]) {
    let mut t = [0.0; L];
    let mut b1 = [0.0; L];
    let mut b2 = [0.0; L];
    for j in 0..L {
        t[j] = z[j].abs().min(6.0) * (1.0 / 3.0) - 1.0;
    }
    // The short series (the fast path's node values) as two chains of half the length; the
    // full one (N = 40, ~3e-16) as one chain, whose rounding is the smaller.
    let split = N < 40;
    let (lo, hi) = const { split_cheb::<N>() };
    let (mut d1, mut d2) = ([0.0; L], [0.0; L]);
    if split {
        for n in (1..N / 2).rev() {
            let (c, d) = (lo[n], hi[n]);
            for j in 0..L {
                let b0 = (2.0 * t[j]).mul_add(b1[j], c - b2[j]);
                b2[j] = b1[j];
                b1[j] = b0;
                let e0 = (2.0 * t[j]).mul_add(d1[j], d - d2[j]);
                d2[j] = d1[j];
                d1[j] = e0;
            }
        }
    } else {
        for &c in ERFCX_CHEB[1..N].iter().rev() {
            for j in 0..L {
                let b0 = (2.0 * t[j]).mul_add(b1[j], c - b2[j]);
                b2[j] = b1[j];
                b1[j] = b0;
            }
        }
    }
    let (mut out, mut exps) = ([0.0; L], [0.0; L]);
    for j in 0..L {
        let tt = t[j];
        let erfcx = if split {
            let s_lo = tt.mul_add(b1[j], lo[0] - b2[j]);
            let s_hi = tt.mul_add(d1[j], hi[0] - d2[j]);
            cheb_t::<N>(tt).mul_add(s_hi, s_lo)
        } else {
            tt.mul_add(b1[j], ERFCX_CHEB[0] - b2[j])
        };
        let ex = if N >= 40 {
            exp_nonpos_d::<13>(-(z[j] * z[j]))
        } else if N > 22 {
            exp_nonpos_d::<10>(-(z[j] * z[j]))
        } else {
            exp_nonpos_d::<8>(-(z[j] * z[j]))
        };
        exps[j] = ex;
        let e = 1.0 - ex * erfcx;
        let e = if z[j].abs() >= 6.0 { 1.0 } else { e };
        out[j] = e.copysign(z[j]);
    }
    (out, exps)
}

/// `atan2(y, x)` for finite arguments, branch-free (selects only): reduction to
/// `t = min(|x|, |y|) / max(|x|, |y|)` in [0, 1], then to `|t'| <= tan(pi/8)` by
/// `atan t = pi/4 + atan((t - 1)/(t + 1))` (one division either way), then `atan(t')/t'` as a
/// degree-11 polynomial in `u = t'^2` on `[0, tan^2(pi/8)]`: its interpolant at 12 Chebyshev
/// nodes, solved in 50-digit arithmetic (mpmath) and rounded (truncation ~2e-17, as accurate in
/// f64 as the 21-term Taylor series it replaced, nine FMAs shorter). Absolute error about
/// 4e-16; `atan2(0, 0) = 0`.
#[inline(always)]
pub fn atan2_fast(y: f64, x: f64) -> f64 {
    let (tn, td) = atan2_ratio(y, x);
    atan2_from_ratio(y, x, tn / td)
}

/// `tan(pi/8)`: where [`atan2_fast`]'s reduction switches to `(t - 1)/(t + 1)`.
const TAN_PI_8: f64 = 0.414_213_562_373_095_03;

/// The reduced ratio `t' = num / den` of [`atan2_fast`] as `(num, den)`, with `den > 0`
/// (`(0, 1)` at the origin): a caller may divide several at once.
#[inline(always)]
pub fn atan2_ratio(y: f64, x: f64) -> (f64, f64) {
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    // t = num / den; past tan(pi/8), (t - 1)/(t + 1) = (num - den)/(num + den)
    let big = num > TAN_PI_8 * den;
    let (tn, td) = if big {
        (num - den, num + den)
    } else {
        (num, den)
    };
    if td > 0.0 {
        (tn, td)
    } else {
        (0.0, 1.0)
    }
}

/// [`atan2_fast`] from its reduced ratio `tr` ([`atan2_ratio`]'s quotient).
#[inline(always)]
pub fn atan2_from_ratio(y: f64, x: f64, tr: f64) -> f64 {
    const PIO4: f64 = std::f64::consts::FRAC_PI_4;
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let (num, den) = if swap { (ax, ay) } else { (ay, ax) };
    let big = num > TAN_PI_8 * den;
    let u = tr * tr;
    const C: [f64; 12] = [
        1.0,
        -0.333_333_333_333_331_2,
        0.199_999_999_999_408_93,
        -0.142_857_142_792_502_45,
        0.111_111_107_449_196_58,
        -0.090_908_968_090_640_27,
        0.076_920_453_309_022_25,
        -0.066_629_518_136_291_91,
        0.058_468_782_973_308_72,
        -0.050_351_024_566_015_52,
        0.037_965_257_453_865_93,
        -0.017_805_397_205_419_446,
    ];
    let mut p = C[11];
    for &c in C[..11].iter().rev() {
        p = p.mul_add(u, c);
    }
    let mut a = tr.mul_add(p, if big { PIO4 } else { 0.0 });
    if swap {
        a = std::f64::consts::FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = std::f64::consts::PI - a;
    }
    a.copysign(y)
}

/// `(cos 2 pi t, -sin 2 pi t)` for `t` in [-0.5, 0.5] cycles, branch-free: quarter turns
/// `n = round(4t)` and the Taylor series of sin and cos on `|2 pi (t - n/4)| <= pi/4` (to
/// y^15 and y^16: truncation below 7e-17 there).
#[inline(always)]
pub fn cis_neg_cycles(t: f64) -> (f64, f64) {
    let n = (4.0 * t).round_ties_even();
    let y = (t - 0.25 * n) * (2.0 * std::f64::consts::PI);
    let (s, c) = sincos_unit_k::<8, 9>(y);
    // rotate (c, s) by n quarter turns: n mod 4 = 0: (c, s), 1: (-s, c), 2: (-c, -s), 3: (s, -c)
    let q = (n + 4.0) % 4.0;
    let (cr, sr) = if q == 0.0 {
        (c, s)
    } else if q == 1.0 {
        (-s, c)
    } else if q == 2.0 {
        (-c, -s)
    } else {
        (s, -c)
    };
    (cr, -sr)
}

/// The lower ends of fdlibm's intervals for `P1`, `Q1` (its high-word thresholds): interval
/// 0 is `[8, inf)`, 1 `[4.5454.., 8)`, 2 `[2.8571.., 4.5454..)`, 3 `[2, 2.8571..)`.
pub const J1_EDGES: [f64; 4] = [8.0, 4.545_452_117_919_922, 2.857_141_494_750_976_6, 2.0];

#[rustfmt::skip]
#[allow(clippy::excessive_precision)]
mod j1_coefficients {
    /// fdlibm's `pone` numerators (`R`) and denominators (`S`) on [8, inf), [4.5454, 8),
    /// [2.8571, 4.5454), [2, 2.8571) (copied from the `libm` crate's `j1.rs`).
    pub(super) const J1_P1_R: [[f64; 6]; 4] = [
        [0.0, 0.11718749999998865, 13.239480659307358, 412.05185430737856, 3874.7453891396053, 7914.479540318917],
        [1.3199051955624352e-11, 0.1171874931906141, 6.802751278684329, 108.30818299018911, 517.6361395331998, 528.7152013633375],
        [3.025039161373736e-09, 0.11718686556725359, 3.9329775003331564, 35.11940355916369, 91.05501107507813, 48.55906851973649],
        [1.0771083010687374e-07, 0.11717621946268335, 2.368514966676088, 12.242610914826123, 17.693971127168773, 5.073523125888185],
    ];
    pub(super) const J1_P1_S: [[f64; 5]; 4] = [
        [114.20737037567841, 3650.9308342085346, 36956.206026903346, 97602.79359349508, 30804.27206278888],
        [59.28059872211313, 991.4014187336144, 5353.26695291488, 7844.690317495512, 1504.0468881036106],
        [34.79130950012515, 336.76245874782575, 1046.8713997577513, 890.8113463982564, 103.78793243963928],
        [21.43648593638214, 125.29022716840275, 232.2764690571628, 117.6793732871471, 8.364638933716183],
    ];
    pub(super) const J1_Q1_R: [[f64; 6]; 4] = [
        [0.0, -0.10253906249999271, -16.271753454459, -759.6017225139501, -11849.806670242959, -48438.512428575035],
        [-2.089799311417641e-11, -0.10253905024137543, -8.05644828123936, -183.66960747488838, -1373.1937606550816, -2612.4444045321566],
        [-5.078312264617666e-09, -0.10253782982083709, -4.610115811394734, -57.847221656278364, -228.2445407376317, -219.21012847890933],
        [-1.7838172751095887e-07, -0.10251704260798555, -2.7522056827818746, -19.663616264370372, -42.32531333728305, -21.371921170370406],
    ];
    pub(super) const J1_Q1_S: [[f64; 6]; 4] = [
        [161.3953697007229, 7825.385999233485, 133875.33628724958, 719657.7236832409, 666601.2326177764, -294490.26430383464],
        [81.27655013843358, 1991.7987346048596, 17468.48519249089, 49851.42709103523, 27948.075163891812, -4719.183547951285],
        [47.66515503237295, 673.8651126766997, 3380.1528667952634, 5547.729097207228, 1903.119193388108, -135.20119144430734],
        [29.533362906052385, 252.98154998219053, 757.5028348686454, 739.3932053204672, 155.94900333666612, -4.959498988226282],
    ];
    /// fdlibm's `j1` on [0, 2): `J1(x)/x = 1/2 + z R(z) / S(z)`, `z = x^2`.
    pub(super) const J1_SMALL_R: [f64; 4] = [-0.0625, 0.001407056669551897, -1.599556310840356e-05, 4.9672799960958445e-08];
    pub(super) const J1_SMALL_S: [f64; 5] = [0.019153759953836346, 0.00018594678558863092, 1.1771846404262368e-06, 5.0463625707621704e-09, 1.2354227442613791e-11];
}
use j1_coefficients::*;

/// `sum_d c[d] z^d` (Horner, with FMA).
#[inline(always)]
fn poly(c: &[f64], z: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &v| acc.mul_add(z, v))
}

/// fdlibm's interval of `x` (0 to 3, see `J1_EDGES`), or 4 for `x < 2` (also NaN).
#[inline(always)]
pub fn j1_interval(x: f64) -> usize {
    J1_EDGES.iter().position(|&e| x >= e).unwrap_or(4)
}

/// The Bessel function `J1(x)` for `x` in fdlibm's interval `IV` (0 to 3: `x >= 2`),
/// branch-free, given `1/x`: `J1 = (P1 (sin x - cos x) + Q1 (sin x + cos x)) / sqrt(pi x)`
/// (Hankel), with fdlibm's rationals for `P1`, `Q1` on that interval (one division for both)
/// and `sin x`, `cos x` from `x / 2 pi` reduced with an FMA-split product (exact to ~1e-16
/// cycles for `x` up to 1e5). The error is below 1e-15 of the envelope `sqrt(2 / (pi x))`
/// (tested against libm to `x = 1e5`); no care is taken near the zeros, so the *relative*
/// error there is larger.
#[inline(always)]
pub fn j1_hankel<const IV: usize>(x: f64, inv_x: f64) -> f64 {
    const INV_2PI_HI: f64 = 0.159_154_943_091_895_35; // 1/(2 pi) rounded
    const INV_2PI_LO: f64 = -9.839_338_337_591_243e-18; // 1/(2 pi) - INV_2PI_HI
    const INVSQRTPI: f64 = 0.564_189_583_547_756_3; // 1/sqrt(pi)
    let t = x * INV_2PI_HI;
    let e = x.mul_add(INV_2PI_HI, -t) + x * INV_2PI_LO;
    let f = (t - t.round_ties_even()) + e;
    let (c, ms) = cis_neg_cycles(f);
    let s = -ms;
    let z = inv_x * inv_x;
    let (rp, sp) = (poly(&J1_P1_R[IV], z), z.mul_add(poly(&J1_P1_S[IV], z), 1.0));
    let (rq, sq) = (poly(&J1_Q1_R[IV], z), z.mul_add(poly(&J1_Q1_S[IV], z), 1.0));
    let inv = 1.0 / (sp * sq);
    let p1 = 1.0 + rp * sq * inv;
    let q1 = (0.375 + rq * sp * inv) * inv_x;
    INVSQRTPI * p1.mul_add(s - c, q1 * (s + c)) * inv_x.sqrt()
}

/// `2 J1(x) / x` for `|x| < 2` (limit 1 at 0): fdlibm's `1 + 2 z R(z) / S(z)`, `z = x^2`
/// (within 5e-16 of libm's `2 j1(x) / x`, tested).
#[inline(always)]
pub fn jinc_small(x: f64) -> f64 {
    let z = x * x;
    let r = z * poly(&J1_SMALL_R, z);
    let s = z.mul_add(poly(&J1_SMALL_S, z), 1.0);
    1.0 + 2.0 * r / s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
        (0..=n).map(move |i| lo + (hi - lo) * i as f64 / n as f64)
    }

    #[test]
    fn j1_hankel_matches_libm_to_1e_15_of_its_envelope_on_each_interval() {
        let mut worst = 0.0f64;
        let xs = grid(2.0, 60.0, 400_000)
            .chain(grid(60.0, 2000.0, 200_000))
            .chain(grid(2000.0, 1e5, 20_000));
        for x in xs {
            let j1 = match j1_interval(x) {
                0 => j1_hankel::<0>(x, 1.0 / x),
                1 => j1_hankel::<1>(x, 1.0 / x),
                2 => j1_hankel::<2>(x, 1.0 / x),
                3 => j1_hankel::<3>(x, 1.0 / x),
                _ => unreachable!("{x}"),
            };
            let envelope = (2.0 / (std::f64::consts::PI * x)).sqrt();
            worst = worst.max((j1 - libm::j1(x)).abs() / envelope);
        }
        assert!(worst < 1e-15, "{worst:e}");
    }

    #[test]
    fn jinc_small_matches_libm_to_5e_16() {
        // (libm's `2 j1(x) / x` itself rounds three times)
        let mut worst = 0.0f64;
        for x in grid(0.0, 2.0, 200_000).filter(|&x| x < 2.0) {
            let want = if x == 0.0 { 1.0 } else { 2.0 * libm::j1(x) / x };
            worst = worst.max((jinc_small(x) - want).abs());
        }
        assert!(worst < 5e-16, "{worst:e}");
        assert_eq!(j1_interval(1.999), 4);
        assert_eq!(j1_interval(2.0), 3);
        assert_eq!(j1_interval(8.0), 0);
        assert_eq!(j1_interval(f64::NAN), 4);
    }

    #[test]
    fn erf_matches_libm_to_3e_16() {
        let mut worst: f64 = 0.0;
        for z in grid(-7.0, 7.0, 700_001) {
            worst = worst.max((erf(z) - libm::erf(z)).abs());
        }
        assert!(worst <= 3e-16, "max |erf - libm::erf| = {worst:e}");
    }

    #[test]
    fn erf_cheb_matches_libm_to_4e_16() {
        let mut worst: f64 = 0.0;
        for z in grid(-7.0, 7.0, 700_001) {
            worst = worst.max((erf_cheb(z) - libm::erf(z)).abs());
        }
        assert!(worst <= 4e-16, "max |erf_cheb - libm::erf| = {worst:e}");
    }

    #[test]
    fn short_series_meet_their_stated_bounds() {
        let mut worst = [0.0f64; 5];
        for z in grid(-7.0, 7.0, 140_001) {
            worst[0] = worst[0].max((erf_cheb_n::<28>(z) - libm::erf(z)).abs());
        }
        for x in grid(0.0, std::f64::consts::PI, 50_000) {
            worst[1] = worst[1].max((cos_0_pi_k::<9>(x) - x.cos()).abs());
        }
        for e in grid(-1.0, 1.0, 50_000) {
            let (s, c) = sincos_unit_k::<7, 8>(e);
            worst[2] = worst[2].max((s - e.sin()).abs());
            worst[3] = worst[3].max((c - e.cos()).abs());
        }
        for x in grid(-700.0, 0.0, 50_000) {
            worst[4] = worst[4].max(((exp_nonpos_d::<10>(x) - x.exp()) / x.exp()).abs());
        }
        let bounds = [3e-13, 1e-13, 1e-12, 1e-13, 4e-13];
        for (w, b) in worst.iter().zip(bounds) {
            assert!(w <= &b, "{worst:?}");
        }
    }

    #[test]
    fn shortest_series_meet_their_stated_bounds() {
        // (the fast path's node values at tol >= 1e-6; relative errors, as they scale the
        // leaf factor)
        let mut worst = [0.0f64; 2];
        for x in grid(0.0, std::f64::consts::PI, 200_001) {
            let c = x.cos();
            if c != 0.0 {
                worst[0] = worst[0].max(((cos_0_pi_k::<7>(x) - c) / c).abs());
            }
        }
        for x in grid(-700.0, 0.0, 200_001) {
            worst[1] = worst[1].max(((exp_nonpos_d::<7>(x) - x.exp()) / x.exp()).abs());
        }
        let bounds = [7e-10, 7.5e-9];
        for (w, b) in worst.iter().zip(bounds) {
            assert!(w <= &b, "{worst:?}");
        }
    }

    #[test]
    fn atan2_fast_matches_libm() {
        let mut worst: f64 = 0.0;
        let mut uniform = crate::test_util::uniforms(3);
        let mut u = || uniform() * 2.0 - 1.0;
        for _ in 0..400_000 {
            let (y, x) = (u() * 10f64.powf(3.0 * u()), u() * 10f64.powf(3.0 * u()));
            worst = worst.max((atan2_fast(y, x) - y.atan2(x)).abs());
        }
        for &(y, x) in &[
            (0.0, 1.0),
            (0.0, -1.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (0.0, 0.0),
            (-0.0, -1.0),
        ] {
            worst = worst.max((atan2_fast(y, x) - f64::atan2(y, x)).abs());
        }
        assert!(worst <= 5e-16, "{worst:e}");
    }

    #[test]
    fn erf_cheb_lanes_gives_each_lane_what_one_lane_gives() {
        let z: [f64; 16] = std::array::from_fn(|i| -7.0 + i as f64 * 0.93);
        let e = erf_cheb_lanes::<40, 16>(&z);
        let e28 = erf_cheb_lanes::<28, 16>(&z);
        for i in 0..16 {
            assert_eq!(e[i], erf_cheb(z[i]));
            assert_eq!(e28[i], erf_cheb_n::<28>(z[i]));
        }
    }

    #[test]
    fn cis_neg_cycles_matches_libm() {
        let mut worst: f64 = 0.0;
        for t in grid(-0.5, 0.5, 200_000) {
            let (c, s) = cis_neg_cycles(t);
            let a = 2.0 * std::f64::consts::PI * t;
            worst = worst.max((c - a.cos()).abs()).max((s + a.sin()).abs());
        }
        assert!(worst <= 4e-16, "{worst:e}");
    }

    #[test]
    fn erf_is_odd_and_saturates() {
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(erf(-1.3), -erf(1.3));
        assert_eq!(erf(6.5), 1.0);
        assert_eq!(erf(1e300), 1.0);
        assert_eq!(erf(-1e300), -1.0);
    }

    #[test]
    fn cos_matches_libm_on_0_pi() {
        let mut worst: f64 = 0.0;
        for x in grid(0.0, std::f64::consts::PI, 100_000) {
            worst = worst.max((cos_0_pi(x) - x.cos()).abs());
        }
        assert!(worst <= 3e-16, "{worst:e}");
    }

    #[test]
    fn sincos_matches_libm_on_unit_interval() {
        let mut worst: f64 = 0.0;
        for e in grid(-1.0, 1.0, 100_000) {
            let (s, c) = sincos_unit(e);
            worst = worst.max((s - e.sin()).abs()).max((c - e.cos()).abs());
        }
        assert!(worst <= 3e-16, "{worst:e}");
    }

    #[test]
    fn exp_matches_libm_relatively() {
        let mut worst: f64 = 0.0;
        for x in grid(-700.0, 0.0, 200_000) {
            worst = worst.max(((exp_nonpos(x) - x.exp()) / x.exp()).abs());
        }
        assert!(worst <= 4e-16, "{worst:e}");
    }
}
