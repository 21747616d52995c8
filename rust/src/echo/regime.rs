//! Where a paper-model leaf's `B(c) beta` lies over the band: zero, smooth, kinked or outside
//! the polynomial cosine's domain, and the first bin where its factor is live.
use crate::echo::tables::BandTables;
use crate::echo::term::LeafTerm;
use crate::physics::leaf::PAPER_B0;
use crate::physics::leaf::PAPER_B1;
use std::f64::consts::{FRAC_PI_2, PI};

/// The first bin in `lo..=hi` where the paper model's `L` is nonzero (`B(c) beta < pi/2`;
/// `B` falls with k, so the dead bins come first), for `ap = radius^-0.9065`; `lo` when `L > 0`
/// there already, `hi + 1` when `L = 0` throughout. (Inlined into the multiversioned kernels:
/// compiled apart, its `mul_add` and `ceil` would be library calls.)
#[inline(always)]
pub(crate) fn first_live_bin(tab: &BandTables, ap: f64, beta: f64, lo: usize, hi: usize) -> usize {
    let x = |j: usize| PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) * beta;
    let (x_lo, x_hi) = (x(lo), x(hi));
    if x_lo < FRAC_PI_2 {
        return lo;
    }
    if x_hi >= FRAC_PI_2 {
        return hi + 1;
    }
    // Bin `lo` is dead and bin `hi` live. `x` falls smoothly with the bin (as k^-0.9065). The
    // first guess is the bin after the table's inverse at the crossing's `kp` (within a bin
    // of it over a 60-80 kHz band); where that is not the answer, one Newton step on the local
    // slope (within a bin or two); then a walk finds the first bin the predicate calls live
    // (the same as bisection, in fewer steps).
    let guess = |j: f64| (j.max(0.0) as usize).clamp(lo + 1, hi);
    let crossing = (FRAC_PI_2 - PAPER_B0 * beta) / (PAPER_B1 * ap * beta);
    let mut j = guess(tab.bin_of_kp.at(crossing).ceil());
    if !(x(j) < FRAC_PI_2 && x(j - 1) >= FRAC_PI_2) && j < hi {
        let (xj, slope) = (x(j), x(j) - x(j + 1));
        if slope > 0.0 {
            j = guess(j as f64 + ((xj - FRAC_PI_2) / slope).ceil());
        }
    }
    while x(j) >= FRAC_PI_2 {
        j += 1; // (ends by `hi`: live)
    }
    while x(j - 1) < FRAC_PI_2 {
        j -= 1; // (ends by `lo + 1`: `lo` dead)
    }
    j
}

/// Where `B(c) beta` (which decreases with k) lies over the band: `L = max(0, A cos(B beta))`
/// is zero at every bin (`Zero`), analytic in k (`Smooth`, no zero crossing of the cosine), or
/// kinked where the cosine crosses zero inside the band (`Kinked`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PaperRegime {
    Zero,
    Smooth,
    Kinked,
    /// `B beta` exceeds pi somewhere: outside the polynomial cosine's domain (tiny leaves).
    OutOfDomain,
}

pub(crate) fn paper_regime(tab: &BandTables, t: &LeafTerm) -> PaperRegime {
    paper_regime_of(tab, t.radius_pow_b, t.beta)
}

/// [`paper_regime`] of a leaf with `radius^-0.9065 = ap` at incidence `beta`.
///
/// `B(c) beta` mirrors [`crate::physics::leaf::paper`]'s (with the table's `k^-0.9065`), as
/// in [`paper_regime_bits`] and [`first_live_bin`]; held to it by
/// `echo::tests::paper_regimes_and_first_live_bins_agree_with_the_scalar_leaf_model`.
#[inline(always)]
pub(crate) fn paper_regime_of(tab: &BandTables, ap: f64, beta: f64) -> PaperRegime {
    // (`paper_regime_bits` is the same, branch-free; keep the two in step)
    let x_lo = PAPER_B1.mul_add(tab.kp[tab.m - 1] * ap, PAPER_B0) * beta;
    let x_hi = PAPER_B1.mul_add(tab.kp[0] * ap, PAPER_B0) * beta;
    if x_lo >= FRAC_PI_2 {
        PaperRegime::Zero
    } else if x_hi > PI {
        PaperRegime::OutOfDomain
    } else if x_hi < FRAC_PI_2 {
        PaperRegime::Smooth
    } else {
        PaperRegime::Kinked
    }
}

/// [`paper_regime_of`] as a bit set, branch-free (for a block's lanes at once): one of
/// [`REGIME_ZERO`], [`REGIME_SMOOTH`], [`REGIME_KINKED`]; 0 when out of the domain (or NaN).
#[inline(always)]
pub(crate) fn paper_regime_bits(tab: &BandTables, ap: f64, beta: f64) -> u8 {
    // (the same operations as `paper_regime_of`; keep the two in step)
    let x_lo = PAPER_B1.mul_add(tab.kp[tab.m - 1] * ap, PAPER_B0) * beta;
    let x_hi = PAPER_B1.mul_add(tab.kp[0] * ap, PAPER_B0) * beta;
    let zero = x_lo >= FRAC_PI_2;
    let smooth = !zero & (x_hi < FRAC_PI_2);
    let kinked = !zero & (FRAC_PI_2..=PI).contains(&x_hi);
    (u8::from(zero) * REGIME_ZERO)
        | (u8::from(smooth) * REGIME_SMOOTH)
        | (u8::from(kinked) * REGIME_KINKED)
}

/// [`paper_regime_bits`]' values.
pub(crate) const REGIME_ZERO: u8 = 1;
pub(crate) const REGIME_SMOOTH: u8 = 2;
pub(crate) const REGIME_KINKED: u8 = 4;
