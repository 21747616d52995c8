//! The per-leaf spectrum kernel: one leaf's unwindowed term added to every band bin, by the
//! paper model's smooth (interpolated) or pointwise vector blocks, physical optics' blocks, or
//! the scalar libm path.
use crate::echo::po::po_blocks;
use crate::echo::prepared::Prepared;
use crate::echo::regime::first_live_bin;
use crate::echo::regime::paper_regime;
use crate::echo::regime::PaperRegime;
use crate::echo::tables::BandTables;
use crate::echo::tables::Tables;
use crate::echo::tables::ANCHOR_BINS;
use crate::echo::tables::LANES;
use crate::echo::tables::NODES;
use crate::echo::tables::POLY_BLOCK;
use crate::echo::tables::POLY_DEG;
use crate::echo::tables::{lanes, lanes_mut};
use crate::echo::term::LeafTerm;
use crate::math::vmath::{cos_0_pi, erf_in, erf_interval, exp_nonpos, sincos_unit};
use crate::physics::leaf::PAPER_A0;
use crate::physics::leaf::PAPER_A2;
use crate::physics::leaf::PAPER_B0;
use crate::physics::leaf::PAPER_B1;
use crate::physics::leaf::PAPER_BETA_REF;
use crate::physics::leaf::PAPER_P0;
use crate::physics::leaf::PAPER_P1;
use crate::physics::leaf::PAPER_PSI0;
use crate::physics::leaf::{self};
use crate::physics::phase::CyclesPerBin;
use crate::sonar::LeafModel;
use multiversion::multiversion;
use std::f64::consts::{FRAC_PI_2, PI};

/// A block is interpolated only if its polynomial reproduces the exact factor at the block's
/// end (where Chebyshev interpolation errs most) to this fraction of the block's peak |F|, and
/// its last Chebyshev coefficient is below [`CHEB_TOL`] of that peak; otherwise the block is
/// evaluated pointwise.
pub const SMOOTH_TOL: f64 = 1e-12;
/// See [`SMOOTH_TOL`]: a coarse second check (for the analytic factors of the paper model the
/// last coefficient is ~1e-12 of the peak; a kink or noise makes it ~1e-3).
pub const CHEB_TOL: f64 = 1e-6;

/// `exp(-j 2 pi t)` for `t` in cycles.
#[inline]
pub(crate) fn cis_neg(t: f64) -> (f64, f64) {
    let (s, c) = (2.0 * PI * t).sin_cos();
    (c, -s)
}

#[inline(always)]
fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0.mul_add(b.0, -a.1 * b.1), a.0.mul_add(b.1, a.1 * b.0))
}

/// Add one leaf's unwindowed contribution to `re`, `im` (length `m_pad`).
pub fn add_leaf(sonar: &Prepared, t: &LeafTerm, re: &mut [f64], im: &mut [f64]) {
    let tab = &sonar.tables;
    debug_assert!(re.len() == tab.m_pad && im.len() == tab.m_pad);
    let p = &sonar.params;
    let q = CyclesPerBin::new(t.range, p.fs, p.n_samples, p.sound_speed);
    if p.leaf_model == LeafModel::Paper {
        let regime = paper_regime(tab, t);
        if regime == PaperRegime::Zero {
            return; // cos(B beta) <= 0 at every bin: L = 0, the leaf adds nothing
        }
        if regime != PaperRegime::OutOfDomain {
            let leaf = PaperLeaf::new(t);
            // Only a leaf with no zero crossing of the cosine in the band is smooth in k.
            // (kinked leaves: per block, see `paper_blocks`)
            let smooth = regime == PaperRegime::Smooth;
            if tab.atten.is_empty() {
                paper_blocks::<false>(tab, &leaf, &q, smooth, re, im);
            } else {
                paper_blocks::<true>(tab, &leaf, &q, smooth, re, im);
            }
            return;
        }
    }
    if p.leaf_model == LeafModel::PhysicalOptics {
        if tab.atten.is_empty() {
            po_blocks::<false>(tab, t, &q, re, im);
        } else {
            po_blocks::<true>(tab, t, &q, re, im);
        }
        return;
    }
    add_leaf_scalar(sonar, t, &q, re, im);
}

/// The straightforward per-bin evaluation with libm (any leaf model, any size).
pub fn add_leaf_scalar(
    sonar: &Prepared,
    t: &LeafTerm,
    q: &CyclesPerBin,
    re: &mut [f64],
    im: &mut [f64],
) {
    let model = |c: f64| match sonar.params.leaf_model {
        LeafModel::Paper => leaf::paper(c, t.beta),
        LeafModel::PhysicalOptics => leaf::physical_optics(c, t.cos_beta, t.sin_beta),
    };
    let tab = &sonar.tables;
    for j in 0..tab.m {
        let k = tab.k[j];
        let (l, psi) = model(k * t.radius);
        let mut amp = t.amp * l / k;
        if !tab.atten.is_empty() {
            amp *= (-tab.atten[j] * t.range).exp();
        }
        let phase = -2.0 * PI * q.frac_at(tab.k0 + j as f64) - psi;
        let (s, c) = phase.sin_cos();
        re[j] += amp * c;
        im[j] += amp * s;
    }
}

/// Per-leaf constants of the paper model's vector paths.
pub(super) struct PaperLeaf {
    pub(super) amp: f64,
    pub(super) range: f64,
    pub(super) beta: f64,
    pub(super) a: f64,
    pub(super) ap: f64,
    pub(super) aq: f64,
}

impl PaperLeaf {
    fn new(t: &LeafTerm) -> Self {
        PaperLeaf {
            amp: t.amp,
            range: t.range,
            beta: t.beta,
            a: t.radius,
            ap: t.radius_pow_b,
            aq: t.radius_pow_p,
        }
    }
}

/// The leaf factor `F = amp L exp(-j psi) / k [exp(-atten r)]` of the paper model on one block
/// of lanes, from the per-bin tables `k`, `1/k`, `k^-0.9065`, `k^0.3523` (and `atten`); without
/// `CLAMP`, its smooth extension `g` (`L = A cos(B beta)` unclamped: negative past the kink).
///
/// Mirrors [`crate::physics::leaf::paper`] in vector form (the powers of `c = k a` split
/// into per-bin and per-leaf factors, polynomial erf, cos, sincos and exp); held to it by
/// `echo::tests::smooth_and_pointwise_paths_match_libm_per_leaf` and
/// `kinked_leaves_match_libm_with_the_kink_anywhere_in_a_block`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn paper_factor<const ATTEN: bool, const CLAMP: bool>(
    lf: &PaperLeaf,
    k: &[f64; LANES],
    inv_k: &[f64; LANES],
    kp: &[f64; LANES],
    kq: &[f64; LANES],
    atten: &[f64],
    fr: &mut [f64; LANES],
    fi: &mut [f64; LANES],
) {
    // exp(-j psi) = exp(-j psi0) (cos e - j sin e), psi = e + psi0, e = erf(P(c)(1.57 - beta))
    let (h0r, h0i) = (PAPER_PSI0.cos(), -PAPER_PSI0.sin());
    let s_ref = PAPER_BETA_REF - lf.beta;
    let mut zz = [0.0; LANES];
    for i in 0..LANES {
        zz[i] = PAPER_P1.mul_add(kq[i] * lf.aq, PAPER_P0) * s_ref;
    }
    // One erf polynomial for the block when all lanes share an interval.
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &z in &zz {
        lo = lo.min(z.abs());
        hi = hi.max(z.abs());
    }
    let (i_lo, i_hi) = (erf_interval(lo), erf_interval(hi));
    let mut e = [0.0; LANES];
    if i_lo == i_hi {
        for i in 0..LANES {
            e[i] = erf_in(i_lo, zz[i]);
        }
    } else {
        for i in 0..LANES {
            e[i] = erf_in(erf_interval(zz[i]), zz[i]);
        }
    }
    for i in 0..LANES {
        let c = k[i] * lf.a;
        let ac = (PAPER_A2 * c).mul_add(c, PAPER_A0);
        let bc = PAPER_B1.mul_add(kp[i] * lf.ap, PAPER_B0);
        let l = ac * cos_0_pi(bc * lf.beta);
        let l = if CLAMP { l.max(0.0) } else { l };
        let (se, ce) = sincos_unit(e[i]);
        let hr = h0r.mul_add(ce, h0i * se);
        let hi_ = h0i.mul_add(ce, -h0r * se);
        let mut amp = lf.amp * l * inv_k[i];
        if ATTEN {
            amp *= exp_nonpos(-atten[i] * lf.range);
        }
        fr[i] = amp * hr;
        fi[i] = amp * hi_;
    }
}

/// [`paper_factor`] at the `LANES` table positions from `at`.
#[inline(always)]
fn factor_at<const ATTEN: bool, const CLAMP: bool>(
    lf: &PaperLeaf,
    (k, inv_k, kp, kq, atten): Tables,
    at: usize,
    fr: &mut [f64; LANES],
    fi: &mut [f64; LANES],
) {
    let atten = if ATTEN {
        &atten[at..at + LANES]
    } else {
        &[][..]
    };
    let (k, inv_k, kp, kq) = (lanes(k, at), lanes(inv_k, at), lanes(kp, at), lanes(kq, at));
    paper_factor::<ATTEN, CLAMP>(lf, k, inv_k, kp, kq, atten, fr, fi);
}

/// Lane offsets `w1^i` and the block step `w1^LANES` of the round-trip phase.
#[inline(always)]
pub(super) fn phase_steps(q: &CyclesPerBin) -> ([(f64, f64); LANES], (f64, f64)) {
    let w1 = cis_neg(q.frac_at(1.0));
    let mut pw = [(1.0, 0.0); LANES];
    for i in 1..LANES {
        pw[i] = cmul(pw[i - 1], w1);
    }
    (pw, cis_neg(q.frac_at(LANES as f64)))
}

/// Accumulate `F z` over one block and advance `z` (re-anchoring at `ANCHOR_BINS`, or here
/// when `anchor`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn accumulate_block(
    anchor: bool,
    j0: usize,
    k0: f64,
    q: &CyclesPerBin,
    pw: &[(f64, f64); LANES],
    w8: (f64, f64),
    fr: &[f64; LANES],
    fi: &[f64; LANES],
    zr: &mut [f64; LANES],
    zi: &mut [f64; LANES],
    re_b: &mut [f64; LANES],
    im_b: &mut [f64; LANES],
) {
    if anchor || j0.is_multiple_of(ANCHOR_BINS) {
        let z0 = cis_neg(q.frac_at(k0 + j0 as f64));
        for i in 0..LANES {
            (zr[i], zi[i]) = cmul(z0, pw[i]);
        }
    }
    for i in 0..LANES {
        re_b[i] = fr[i].mul_add(zr[i], (-fi[i]).mul_add(zi[i], re_b[i]));
        im_b[i] = fr[i].mul_add(zi[i], fi[i].mul_add(zr[i], im_b[i]));
        let nr = zr[i].mul_add(w8.0, -zi[i] * w8.1);
        let ni = zr[i].mul_add(w8.1, zi[i] * w8.0);
        zr[i] = nr;
        zi[i] = ni;
    }
}

/// The magnitude of a block's last Chebyshev coefficient from its node lanes, and the peak of
/// its node values.
#[inline(always)]
pub(super) fn last_coefficient(
    tab: &BandTables,
    fr: &[f64; LANES],
    fi: &[f64; LANES],
) -> (f64, f64) {
    let mut peak = 0.0f64;
    for i in 0..NODES {
        peak = peak.max(fr[i].abs()).max(fi[i].abs());
    }
    let (mut lr, mut li) = (0.0, 0.0);
    for i in 0..NODES {
        lr = tab.cheb_last[i].mul_add(fr[i], lr);
        li = tab.cheb_last[i].mul_add(fi[i], li);
    }
    (lr.abs().max(li.abs()), peak)
}

/// Interpolate one block's factor from its node lanes: monomial coefficients in t, or None
/// when the block fails the smoothness checks (its last Chebyshev coefficient above
/// `cheb_tol` of its peak, or its end value off).
#[inline(always)]
pub(super) fn block_poly(
    tab: &BandTables,
    fr: &[f64; LANES],
    fi: &[f64; LANES],
    cheb_tol: f64,
) -> Option<([f64; NODES], [f64; NODES])> {
    let (last, peak) = last_coefficient(tab, fr, fi);
    if !(last <= cheb_tol * peak) {
        return None;
    }
    // (a whole vector of coefficients per node, the nodes in order)
    let mut cr_l = [0.0f64; LANES];
    let mut ci_l = [0.0f64; LANES];
    for i in 0..NODES {
        for p in 0..LANES {
            cr_l[p] = tab.vinv[i][p].mul_add(fr[i], cr_l[p]);
            ci_l[p] = tab.vinv[i][p].mul_add(fi[i], ci_l[p]);
        }
    }
    let cr: [f64; NODES] = std::array::from_fn(|p| cr_l[p]);
    let ci: [f64; NODES] = std::array::from_fn(|p| ci_l[p]);
    // At t = 1 the polynomial is the sum of its coefficients; compare with the exact end value.
    let (er, ei) = (
        cr.iter().sum::<f64>() - fr[NODES],
        ci.iter().sum::<f64>() - fi[NODES],
    );
    if !(er.abs().max(ei.abs()) <= SMOOTH_TOL * peak.max(fr[NODES].abs()).max(fi[NODES].abs())) {
        return None;
    }
    Some((cr, ci))
}

/// Blocks whose node values and interpolants are computed together before their bins (their
/// dependent chains overlap; one block at a time, each waited on the last).
const STAGE: usize = 8;

/// The paper model over all bins: per block of [`POLY_BLOCK`] bins, the interpolated factor
/// (`smooth`) or the factor at every bin (pointwise), then the phase and the accumulation.
/// Blocks go in stages of [`STAGE`]: first every block's node values, then its interpolant,
/// then its bins.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn paper_blocks<const ATTEN: bool>(
    tab: &BandTables,
    lf: &PaperLeaf,
    q: &CyclesPerBin,
    smooth: bool,
    re: &mut [f64],
    im: &mut [f64],
) {
    let nt = &tab.nodes;
    let (pw, w8) = phase_steps(q);
    let (mut zr, mut zi) = ([0.0; LANES], [0.0; LANES]);
    let (mut fr, mut fi) = ([0.0; LANES], [0.0; LANES]);
    let mut anchor = false;
    let x_at = |j: usize| PAPER_B1.mul_add(tab.kp[j] * lf.ap, PAPER_B0) * lf.beta;
    for b0 in (0..nt.n_blocks).step_by(STAGE) {
        let nb = STAGE.min(nt.n_blocks - b0);
        // Per block of the stage: its bins, its first live bin (None: L = 0 throughout), and
        // whether it is interpolated (then its node values).
        let mut span = [(0usize, 0usize, None::<usize>, false); STAGE];
        let (mut nr, mut ni) = ([[0.0; LANES]; STAGE], [[0.0; LANES]; STAGE]);
        for (s, sp) in span.iter_mut().enumerate().take(nb) {
            let b = b0 + s;
            let j_start = b * POLY_BLOCK;
            let j_end = if b + 1 == nt.n_blocks {
                tab.m_pad
            } else {
                j_start + POLY_BLOCK
            };
            // For a kinked leaf, decide per block: x = B(c) beta decreases with k, so a block
            // whose smallest x is >= pi/2 holds only L = 0, and one whose largest x is < pi/2
            // is smooth.
            let last = j_end.min(tab.m) - 1;
            let (block_smooth, block_zero) = if smooth {
                (true, false)
            } else {
                (x_at(j_start) < FRAC_PI_2, x_at(last) >= FRAC_PI_2)
            };
            if block_zero {
                *sp = (j_start, j_end, None, false);
                continue;
            }
            // The first bin where L > 0 (x falls with k; in a smooth block, the first).
            let live = if block_smooth {
                j_start
            } else {
                first_live_bin(tab, lf.ap, lf.beta, j_start, last)
            };
            // The block's interpolant; in a block holding the kink, that of the smooth
            // extension g (its bins before `live` zeroed), when at least a quarter of the block
            // is live (then the interpolant's error, a fraction of |g| over the block, stays
            // within a few times that of the live part). Otherwise the live bins are evaluated
            // pointwise.
            let interpolate = block_smooth || last + 1 - live >= POLY_BLOCK / 4;
            *sp = (j_start, j_end, Some(live), interpolate);
            if interpolate {
                let q0 = b * LANES;
                factor_at::<ATTEN, false>(lf, nt.tables(), q0, &mut nr[s], &mut ni[s]);
            }
        }
        let polys: [Option<([f64; NODES], [f64; NODES])>; STAGE] = std::array::from_fn(|s| {
            if s < nb && span[s].3 {
                block_poly(tab, &nr[s], &ni[s], CHEB_TOL)
            } else {
                None
            }
        });
        for (&(j_start, j_end, live, _), poly) in span.iter().zip(&polys).take(nb) {
            let Some(live) = live else {
                // L = 0 here: nothing to add; the phase is anchored afresh at the next block
                anchor = true;
                continue;
            };
            for j0 in (j_start..j_end).step_by(LANES) {
                if j0 + LANES <= live {
                    // all zero: skip, and anchor the phase afresh at the next lanes
                    anchor = true;
                    continue;
                }
                match poly {
                    Some((cr, ci)) => {
                        let t = lanes(&tab.t, j0);
                        for i in 0..LANES {
                            let (mut r, mut m) = (cr[POLY_DEG], ci[POLY_DEG]);
                            for p in (0..POLY_DEG).rev() {
                                r = r.mul_add(t[i], cr[p]);
                                m = m.mul_add(t[i], ci[p]);
                            }
                            fr[i] = r;
                            fi[i] = m;
                        }
                        if j0 < live {
                            for i in 0..live - j0 {
                                (fr[i], fi[i]) = (0.0, 0.0);
                            }
                        }
                    }
                    None => {
                        factor_at::<ATTEN, true>(lf, tab.tables(), j0, &mut fr, &mut fi);
                    }
                }
                accumulate_block(
                    std::mem::take(&mut anchor),
                    j0,
                    tab.k0,
                    q,
                    &pw,
                    w8,
                    &fr,
                    &fi,
                    &mut zr,
                    &mut zi,
                    lanes_mut(re, j0),
                    lanes_mut(im, j0),
                );
            }
        }
    }
}
