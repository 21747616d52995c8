//! The paper model's leaf factor at the plan's nodes for a batch of leaves (lanes), at the
//! precision the tolerance needs, and the node count chosen from a sample of those values.
use crate::echo::term::LeafTerm;
use crate::echo::{paper_regime, PaperRegime};
use crate::fast::lanes::PaperLanes;
use crate::fast::lanes::LB;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::math::vmath::{
    cos_0_pi_k, erf_cheb_lanes, erf_exp_cheb_lanes, exp_nonpos_d, sincos_unit_k,
};
use crate::physics::leaf::{
    PAPER_A0, PAPER_A2, PAPER_B0, PAPER_B1, PAPER_BETA_REF, PAPER_P0, PAPER_P1, PAPER_PSI0,
};
use crate::sonar::LeafModel;
use multiversion::multiversion;
use std::f64::consts::PI;

/// From this tolerance up, node values use the short series of [`crate::math::vmath`] (errors
/// below 1e-12, far under the `tol / 5` budget) instead of the full ones (~1e-16).
pub const SHORT_SERIES_TOL: f64 = 1e-9;
/// From this tolerance up, node values use the shortest series: relative errors below 1e-8
/// (erf 1.9e-9, cos 6.6e-10, exp 7.0e-9, all tested), 2.5e-8 after interpolation, still
/// eight times under the `tol / 5` budget; a term more in each would only cost time.
pub const LOW_SERIES_TOL: f64 = 1e-6;

/// [`paper_nodes_p`] at the precision the plan's tolerance needs.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn paper_nodes<const ATTEN: bool>(
    plan: &FastPlan,
    amp: &[f64; LB],
    range: &[f64; LB],
    beta: &[f64; LB],
    a: &[f64; LB],
    ap: &[f64; LB],
    aq: &[f64; LB],
    s: &mut BatchScratch,
) {
    if plan.tol >= LOW_SERIES_TOL {
        paper_nodes_p::<ATTEN, 2>(plan, amp, range, beta, a, ap, aq, s)
    } else if plan.tol >= SHORT_SERIES_TOL {
        paper_nodes_p::<ATTEN, 1>(plan, amp, range, beta, a, ap, aq, s)
    } else {
        paper_nodes_p::<ATTEN, 0>(plan, amp, range, beta, a, ap, aq, s)
    }
}

/// Work arrays of the paper model's node values and strengths for one batch (lanes = leaves,
/// rows = nodes), made once per task and reused by every batch: rows past the plan's node
/// count are never read, so nothing is zeroed per batch (zeroing and returning these 2 KB
/// arrays by value would cost a noticeable share of a fast pulse).
pub(crate) struct BatchScratch {
    /// The erf's arguments, its Taylor coefficients and its values at the nodes.
    pub(super) zz: [[f64; LB]; MAX_NODES],
    pub(super) coef: [[f64; LB]; MAX_NODES],
    pub(super) ee: [[f64; LB]; MAX_NODES],
    /// Node values of the leaf factor.
    pub(super) fr: [[f64; LB]; MAX_NODES],
    pub(super) fi: [[f64; LB]; MAX_NODES],
    /// Strengths (node values times the phase), real and imaginary parts interleaved
    /// (lane `i` at `2 i`, `2 i + 1`), as the spreading reads them.
    pub(super) sc: [[f64; 2 * LB]; MAX_NODES],
}

impl BatchScratch {
    pub(crate) fn new() -> Box<BatchScratch> {
        let z = [[0.0; LB]; MAX_NODES];
        Box::new(BatchScratch {
            zz: z,
            coef: z,
            ee: z,
            fr: z,
            fi: z,
            sc: [[0.0; 2 * LB]; MAX_NODES],
        })
    }
}

/// Largest `|z_q - z_c| / (|z_c| + 1.5)` for which [`erf_at_nodes`] uses its Taylor series
/// (in the 60-80 kHz band it is at most 0.051; the node values use `K` = 11 and 14 terms at
/// the two finer levels, the fewest for which the truncation stays below the error of the
/// centre's erf: 1.8e-13 and 2.7e-16 worst, tested; one term fewer errs 5x more; at the
/// shortest level 7 terms, 1.9e-9, within that level's budget, see [`LOW_SERIES_TOL`]).
const ERF_TAYLOR_REACH: f64 = 0.055;

/// `erf(z_q)` at the `p` nodes of a batch (lanes = leaves). `z` moves little across the band,
/// so the erf is evaluated once, at the centre `z_c` of each lane's range (`N`-term Chebyshev
/// series), and carried to the nodes by its `K`-term Taylor series:
/// `erf(z_c + d) = erf(z_c) + (2/sqrt(pi)) exp(-z_c^2) sum_n g_n d^(n+1) / (n+1)` with
/// `g_n = (-1)^n H_n(z_c) / n!`, so `g_(n+1) = -(2 z_c g_n + 2 g_(n-1)) / (n+1)`. A batch
/// with a wider range (a band wider than 60-80 kHz) evaluates the erf at every node.
#[inline(always)]
pub(super) fn erf_at_nodes<const N: usize, const K: usize>(
    p: usize,
    z: &[[f64; LB]; MAX_NODES],
    c: &mut [[f64; LB]; MAX_NODES],
    out: &mut [[f64; LB]; MAX_NODES],
) {
    // z is monotone in frequency: the first and last nodes bound each lane's range
    let mut zc = [0.0; LB];
    let mut fits = true;
    for i in 0..LB {
        zc[i] = 0.5 * (z[0][i] + z[p - 1][i]);
        let half = 0.5 * (z[0][i] - z[p - 1][i]).abs();
        fits &= half <= ERF_TAYLOR_REACH * (zc[i].abs() + 1.5);
    }
    if !fits {
        // the erf at every node: groups of three nodes, so that their Clenshaw chains
        // interleave
        const NG: usize = 3;
        for q0 in (0..p).step_by(NG) {
            let mut zz = [0.0; NG * LB];
            for h in 0..NG {
                zz[h * LB..(h + 1) * LB].copy_from_slice(&z[(q0 + h).min(p - 1)]);
            }
            let e = erf_cheb_lanes::<N, { NG * LB }>(&zz);
            for h in 0..NG.min(p - q0) {
                out[q0 + h].copy_from_slice(&e[h * LB..(h + 1) * LB]);
            }
        }
        return;
    }
    let (e0, ex) = erf_exp_cheb_lanes::<N, LB>(&zc);
    // c_(n+1) = E g_n / (n + 1), E = (2/sqrt(pi)) exp(-z_c^2)
    const { assert!(K <= MAX_NODES) };
    let (mut g0, mut g1) = ([1.0f64; LB], [0.0f64; LB]);
    for i in 0..LB {
        let e = std::f64::consts::FRAC_2_SQRT_PI * ex[i];
        g1[i] = -2.0 * zc[i];
        c[0][i] = e;
        c[1][i] = e * g1[i] * 0.5;
        g0[i] = e;
        g1[i] *= e;
    }
    // (g0, g1) now hold E g_(n-1), E g_n
    for n in 1..K - 1 {
        let m2inv = -2.0 / (n + 1) as f64;
        let inv2 = 1.0 / (n + 2) as f64;
        for i in 0..LB {
            // one FMA on the chain through g1 (g0's product is off it)
            let g2 = (m2inv * zc[i]).mul_add(g1[i], m2inv * g0[i]);
            c[n + 1][i] = g2 * inv2;
            g0[i] = g1[i];
            g1[i] = g2;
        }
    }
    for q in 0..p {
        for i in 0..LB {
            let d = z[q][i] - zc[i];
            let mut acc = c[K - 1][i];
            for cn in c[..K - 1].iter().rev() {
                acc = acc.mul_add(d, cn[i]);
            }
            out[q][i] = acc.mul_add(d, e0[i]);
        }
    }
}

/// Node values of the paper model's leaf factor for a batch of leaves (lanes = leaves):
/// `F(t_q) = amp L exp(-j psi) / k [exp(-atten r)]` at each of the plan's nodes, times `k_q`
/// below [`K_FACTOR_TOL`] (the plan's `node_scale`); `LEVEL`
/// selects the series: 0 full (~1e-16), 1 short (~1e-12), 2 shortest (~1e-9).
///
/// Mirrors [`crate::physics::leaf::paper`] in vector form (unclamped, as
/// [`crate::echo::exact`]'s `paper_factor` without `CLAMP`); held to it by
/// `fast::tests::paper_node_values_match_the_scalar_leaf_model_at_each_level`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn paper_nodes_p<const ATTEN: bool, const LEVEL: u8>(
    plan: &FastPlan,
    amp: &[f64; LB],
    range: &[f64; LB],
    beta: &[f64; LB],
    a: &[f64; LB],
    ap: &[f64; LB],
    aq: &[f64; LB],
    s: &mut BatchScratch,
) {
    let nt = &plan.nodes;
    let (h0r, h0i) = (PAPER_PSI0.cos(), -PAPER_PSI0.sin());
    let BatchScratch {
        zz,
        coef,
        ee,
        fr,
        fi,
        ..
    } = s;
    // The erf's arguments at every node: z_q = P(c_q) (1.57 - beta).
    let p = plan.p;
    for (q, zq) in zz.iter_mut().enumerate().take(p) {
        let kq = nt.kq[q];
        for i in 0..LB {
            zq[i] = PAPER_P1.mul_add(kq * aq[i], PAPER_P0) * (PAPER_BETA_REF - beta[i]);
        }
    }
    if LEVEL == 2 {
        erf_at_nodes::<22, 7>(p, zz, coef, ee)
    } else if LEVEL == 1 {
        erf_at_nodes::<28, 11>(p, zz, coef, ee)
    } else {
        erf_at_nodes::<40, 14>(p, zz, coef, ee)
    }
    for q in 0..p {
        let (k, kp, scale) = (nt.k[q], nt.kp[q], plan.node_scale[q]);
        for i in 0..LB {
            let c = k * a[i];
            let ac = (PAPER_A2 * c).mul_add(c, PAPER_A0);
            let bc = PAPER_B1.mul_add(kp * ap[i], PAPER_B0);
            let cx = if LEVEL == 2 {
                cos_0_pi_k::<7>(bc * beta[i])
            } else if LEVEL == 1 {
                cos_0_pi_k::<9>(bc * beta[i])
            } else {
                cos_0_pi_k::<12>(bc * beta[i])
            };
            // unclamped: smooth leaves are positive anyway; for a kinked leaf this is the
            // smooth extension `g` of its factor (see `paper_batch`)
            let l = ac * cx;
            let ei = ee[q][i];
            let (se, ce) = if LEVEL == 2 {
                sincos_unit_k::<6, 7>(ei)
            } else if LEVEL == 1 {
                sincos_unit_k::<7, 8>(ei)
            } else {
                sincos_unit_k::<11, 12>(ei)
            };
            let hr = h0r.mul_add(ce, h0i * se);
            let hi = h0i.mul_add(ce, -h0r * se);
            let mut am = amp[i] * l * scale;
            if ATTEN {
                let x = -nt.atten[q] * range[i];
                am *= if LEVEL == 2 {
                    exp_nonpos_d::<7>(x)
                } else if LEVEL == 1 {
                    exp_nonpos_d::<10>(x)
                } else {
                    exp_nonpos_d::<13>(x)
                };
            }
            fr[q][i] = am * hr;
            fi[q][i] = am * hi;
        }
    }
}

/// Calls with fewer leaves than this use the node count of the worst leaf (`nodes_for_tol`);
/// larger ones choose it from a sample of their own leaves.
pub const ADAPT_MIN_LEAVES: usize = 8192;
/// Leaves sampled to choose the node count.
const ADAPT_SAMPLE: usize = 128;

/// The number of Chebyshev nodes for these leaves: from a sample of them (smooth, paper model),
/// the node count each needs for `tol` is read off its Chebyshev coefficients at the plan's
/// node count, and the count with the least expected cost is taken. Leaves that need more
/// fail the per-leaf check and get a second pass at the full count (or the exact sum), so the
/// choice changes the speed, never the error bound.
pub(super) fn choose_nodes(sonar: &FastSonar, plan: &FastPlan, terms: &[LeafTerm]) -> usize {
    if terms.len() < ADAPT_MIN_LEAVES || sonar.params.leaf_model != LeafModel::Paper {
        return plan.p;
    }
    let stride = (terms.len() / ADAPT_SAMPLE).max(1);
    let sample: Vec<&LeafTerm> = terms.iter().step_by(stride).collect();
    choose_nodes_from(sonar, plan, &sample)
}

/// [`choose_nodes`] from a sample of the call's leaves (paper model; at most [`ADAPT_SAMPLE`]
/// smooth ones are used).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(crate) fn choose_nodes_from(sonar: &FastSonar, plan: &FastPlan, sample: &[&LeafTerm]) -> usize {
    let sample: Vec<&LeafTerm> = sample
        .iter()
        .copied()
        .filter(|t| paper_regime(&sonar.tables, t) == PaperRegime::Smooth)
        .take(ADAPT_SAMPLE)
        .collect();
    if sample.len() < 32 {
        return plan.p;
    }
    let p = plan.p;
    let atten = !plan.nodes.atten.is_empty();
    // T_d(t_q) for the DCT of node values
    let mut tdq = [[0.0f64; MAX_NODES]; MAX_NODES];
    for (d, row) in tdq.iter_mut().enumerate().take(p) {
        for (q, v) in row.iter_mut().enumerate().take(p) {
            *v = (d as f64 * ((2 * q + 1) as f64 * PI / (2 * p) as f64)).cos();
        }
    }
    let mut need: Vec<usize> = Vec::with_capacity(sample.len());
    let mut s = BatchScratch::new();
    for batch in sample.chunks(LB) {
        let l = PaperLanes::of(sonar, batch);
        let args = (&l.amp, &l.range, &l.beta, &l.a, &l.ap, &l.aq);
        if atten {
            paper_nodes::<true>(plan, args.0, args.1, args.2, args.3, args.4, args.5, &mut s)
        } else {
            paper_nodes::<false>(plan, args.0, args.1, args.2, args.3, args.4, args.5, &mut s)
        }
        let (fr, fi) = (&s.fr, &s.fi);
        // (lanes = leaves, so that the DCT vectorises)
        let mut peak = [0.0f64; LB];
        for q in 0..p {
            for i in 0..LB {
                peak[i] = peak[i].max(fr[q][i].abs()).max(fi[q][i].abs());
            }
        }
        // the last coefficient above 2 tol peak decides: P must reach one past it
        let mut last = [0usize; LB];
        for (d, row) in tdq.iter().enumerate().take(p).skip(1) {
            let (mut cr, mut ci) = ([0.0f64; LB], [0.0f64; LB]);
            for q in 0..p {
                for i in 0..LB {
                    cr[i] += row[q] * fr[q][i];
                    ci[i] += row[q] * fi[q][i];
                }
            }
            for i in 0..LB {
                if (cr[i].abs().max(ci[i].abs()) * 2.0 / p as f64) > 2.0 * plan.tol * peak[i] {
                    last[i] = d;
                }
            }
        }
        need.extend(last[..batch.len()].iter().map(|&l| (l + 2).min(p)));
    }
    // Expected cost per leaf of P nodes (in units of about 1 ns): node values and spreading grow
    // with P; a leaf that needs more goes to a second pass at the plan's full node count.
    let node_cost = |q: usize| q as f64 * (8.0 + 0.5 * plan.nufft.w as f64);
    // (a deferred leaf costs about twice a full-count leaf, plus its copy)
    let second_pass = 2.0 * node_cost(p) + 100.0;
    (2..=p)
        .min_by(|&x, &y| {
            let cost = |q: usize| {
                let fail = need.iter().filter(|&&n| n > q).count() as f64 / need.len() as f64;
                node_cost(q) + fail * second_pass
            };
            cost(x).total_cmp(&cost(y))
        })
        .unwrap_or(p)
}
