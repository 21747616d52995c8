//! Kinked paper-model leaves: the first live bin, the route of a leaf by its regime, and the
//! interpolant added or subtracted bin by bin on one side of the corner.
use crate::echo::{first_live_bin, PaperRegime};
use crate::fast::lanes::LB;
use crate::fast::lanes::NOT_KINKED;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::math::vmath::cis_neg_cycles;
use crate::physics::phase::CyclesPerBin;

/// The first band bin where a kinked paper-model leaf's factor is nonzero: below it
/// `B(c) beta >= pi/2` (the cosine is negative and `L` clamps to 0). `B` falls with frequency,
/// so the bins split into a zero side `0..m*` and a live side `m*..M`.
#[inline(always)]
pub(crate) fn kink_bin(sonar: &FastSonar, ap: f64, beta: f64) -> usize {
    first_live_bin(&sonar.tables, ap, beta, 0, sonar.tables.m - 1)
}

/// How a paper-model leaf enters a fast pass.
pub(crate) enum PaperRoute {
    /// `L = 0` at every bin.
    Skip,
    /// Into a batch, with its first live bin when kinked ([`NOT_KINKED`] otherwise).
    Batch(usize),
    /// To the exact sum: outside the paper model's domain.
    Defer,
}

/// The route of a paper-model leaf of regime `regime` with `radius^-0.9065 = ap`.
#[inline(always)]
pub(crate) fn paper_route(
    sonar: &FastSonar,
    regime: PaperRegime,
    ap: f64,
    beta: f64,
) -> PaperRoute {
    match regime {
        PaperRegime::Zero => PaperRoute::Skip,
        PaperRegime::Smooth => PaperRoute::Batch(NOT_KINKED),
        PaperRegime::Kinked => PaperRoute::Batch(kink_bin(sonar, ap, beta)),
        PaperRegime::OutOfDomain => PaperRoute::Defer,
    }
}

/// Add `sign g(m) exp(-2 pi j (k0 + m) q)` to `dre`, `dim` (unwindowed band bins, length at
/// least `M + LB`) for the band bins `lo..hi`, with `g` the interpolant through the node
/// values `gr + j gi`: the same values the NUFFT channels give for a spread leaf.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn add_interpolant(
    sonar: &FastSonar,
    plan: &FastPlan,
    gr: &[f64; MAX_NODES],
    gi: &[f64; MAX_NODES],
    cq: &CyclesPerBin,
    (lo, hi): (usize, usize),
    sign: f64,
    dre: &mut [f64],
    dim: &mut [f64],
) {
    let row = sonar.n_bins() + LB;
    let k0 = sonar.tables.k0;
    // phases advance by LB bins per block (a rotation), re-anchored exactly every ANCHOR
    // blocks; an anchor takes each lane's phase directly, lanes = bins (a chain of one-bin
    // rotations for the lanes' offsets would be a long chain of latency per call)
    const ANCHOR: usize = 16;
    let (rr, ri) = cis_neg_cycles(cq.frac_at(LB as f64));
    let mut m0 = lo;
    while m0 < hi {
        let (mut pr, mut pi) = ([0.0; LB], [0.0; LB]);
        for l in 0..LB {
            (pr[l], pi[l]) = cis_neg_cycles(cq.frac_at(k0 + (m0 + l) as f64));
        }
        let end = (m0 + ANCHOR * LB).min(hi);
        while m0 < end {
            let (mut vr, mut vi) = ([0.0; LB], [0.0; LB]);
            for q in 0..plan.p {
                let lq: &[f64; LB] = plan.lagrange_t[q * row + m0..q * row + m0 + LB]
                    .try_into()
                    .unwrap();
                for l in 0..LB {
                    vr[l] = lq[l].mul_add(gr[q], vr[l]);
                    vi[l] = lq[l].mul_add(gi[q], vi[l]);
                }
            }
            let or: &mut [f64; LB] = (&mut dre[m0..m0 + LB]).try_into().unwrap();
            let oi: &mut [f64; LB] = (&mut dim[m0..m0 + LB]).try_into().unwrap();
            for l in 0..LB {
                let w = if m0 + l < hi { sign } else { 0.0 };
                let cr = vr[l].mul_add(pr[l], -vi[l] * pi[l]);
                let ci = vr[l].mul_add(pi[l], vi[l] * pr[l]);
                or[l] = w.mul_add(cr, or[l]);
                oi[l] = w.mul_add(ci, oi[l]);
                let t = pr[l].mul_add(rr, -pi[l] * ri);
                pi[l] = pr[l].mul_add(ri, pi[l] * rr);
                pr[l] = t;
            }
            m0 += LB;
        }
    }
}
