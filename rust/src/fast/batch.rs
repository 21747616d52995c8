//! One batch of paper-model leaves through a fast pass: node values, the smoothness check
//! (with a kinked leaf's rounding floor), phases and grid positions, the kinks, the spreading.
use crate::fast::finish::Direct;
use crate::fast::kinks::add_interpolant;
use crate::fast::lanes::PaperLanes;
use crate::fast::lanes::LB;
use crate::fast::lanes::NOT_KINKED;
use crate::fast::nodes::paper_nodes;
use crate::fast::nodes::BatchScratch;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::fast::spread::spread_lanes;
use crate::math::vmath::cis_neg_cycles;
use crate::physics::leaf::{PAPER_A0, PAPER_A2};
use crate::physics::phase::CyclesPerBin;

/// The rounding floor of a kinked leaf's node values, relative to the factor's scale without
/// the cosine (`amp A(c)`, largest over the nodes): near its corner `cos(B beta)` is accurate
/// to ~2e-16 of that scale, not of its own small value. Where the live part is small (a corner
/// in the band's top bins, live values ~1e-4 of the scale) that is ~1e-12 of them, so the
/// check is `|c_last| + KINK_FLOOR scale <= 2 tol live`, and a leaf whose floor alone takes
/// half its budget (`KINK_FLOOR scale > tol live`) is summed exactly: over the whole band
/// when a first pass finds it (sub-bands would meet the same floor, and their exact sums round
/// differently from the band's by ~1e-12 of such a leaf), over the sub-band when a sub-band
/// does. On 20,000 single leaves (radii 3-90 mm, incidence 0-1.5 rad, ranges 0.5-10 m) at
/// `tol = 1e-12` the worst error against the exact sum is 0.24 tol with this term and 3.4 tol
/// without it (the same for 1e-15 ... 1e-14). It matters only near
/// `tol = 1e-12`: at 1e-6 a leaf fails it only where its live part is under ~1e-8 of its
/// scale. (The exact sum has the same floor, ~1e-12 of such a leaf against mpmath: see the
/// README.)
const KINK_FLOOR: f64 = 3e-15;

/// The paper model's node values, phases and kernel weights for a batch of up to `LB` smooth
/// or kinked leaves (lanes), then the spreading; returns the leaves it did not take
/// ([`Failures`]: not spread, for the caller to defer or sum exactly).
///
/// A kinked leaf's factor is `max(0, g)` with `g` smooth (the unclamped cosine), zero on the
/// bins `0..m*` and `g` on `m*..M`. Where the zero side is the shorter, `g` is spread and its
/// interpolant subtracted on the zero side; where the live side is, the interpolant is added
/// there and nothing is spread: at most `M / 2` bins either way. The error is that of the
/// interpolant on the live side, checked against the peak there (or the lane's
/// [`PaperLanes::floor`], a bound on its peak over a wider band).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn paper_batch<const ATTEN: bool>(
    sonar: &FastSonar,
    plan: &FastPlan,
    lanes: &PaperLanes,
    grid: &mut [f64],
    direct: &mut Direct,
    s: &mut BatchScratch,
) -> Failures {
    let (p, w) = (plan.p, plan.nufft.w);
    let sp = &sonar.params;
    let n = lanes.n;
    let m = sonar.n_bins();
    let PaperLanes {
        amp,
        range,
        beta,
        a,
        ap,
        aq,
        kink,
        floor,
        skip,
        ..
    } = lanes;
    paper_nodes::<ATTEN>(plan, amp, range, beta, a, ap, aq, s);
    let BatchScratch { fr, fi, sc, .. } = s;
    // Smoothness check per lane: the last Chebyshev coefficient against the lane's peak.
    let mut ok = [true; LB];
    let (mut lr, mut li, mut peak) = ([0.0; LB], [0.0; LB], [0.0f64; LB]);
    for q in 0..p {
        for i in 0..LB {
            lr[i] = plan.cheb_last[q].mul_add(fr[q][i], lr[i]);
            li[i] = plan.cheb_last[q].mul_add(fi[q][i], li[i]);
            peak[i] = peak[i].max(fr[q][i].abs()).max(fi[q][i].abs());
        }
    }
    for i in 0..LB {
        peak[i] = peak[i].max(floor[i]);
        ok[i] = lr[i].abs().max(li[i].abs()) <= 2.0 * plan.tol * peak[i];
    }
    // Kinked lanes (their first live bin given): the check against the peak on the live side.
    let mut below_floor = [false; LB];
    if kink.iter().any(|&mk| mk != NOT_KINKED) {
        for i in 0..n {
            let mk = kink[i];
            if mk == NOT_KINKED {
                continue;
            }
            let live = (0..p)
                .filter(|&q| plan.node_x[q] >= mk as f64)
                .fold(floor[i], |mx, q| mx.max(fr[q][i].abs()).max(fi[q][i].abs()));
            // the factor's scale without the cosine, `amp A(c)` times the node's scale: first
            // a bound from the band's top (A grows with c; no absorption), and where that could
            // matter, the largest over the nodes times the weakest absorption (one `exp`)
            let nt = &plan.nodes;
            let c_top = plan.k_top * a[i];
            let mut scale =
                amp[i].abs() * (PAPER_A2 * c_top).mul_add(c_top, PAPER_A0) * plan.scale_top;
            if KINK_FLOOR * scale > 0.01 * plan.tol * live {
                scale = (0..p).fold(0.0f64, |mx, q| {
                    let c = nt.k[q] * a[i];
                    let s = amp[i] * (PAPER_A2 * c).mul_add(c, PAPER_A0) * plan.node_scale[q];
                    mx.max(s.abs())
                });
                if ATTEN {
                    let weakest = nt.atten[..p].iter().fold(f64::INFINITY, |m, &x| m.min(x));
                    scale *= (-weakest * range[i]).exp();
                }
            }
            let floor_err = KINK_FLOOR * scale;
            below_floor[i] = live > 0.0 && floor_err > plan.tol * live;
            ok[i] = live > 0.0 && lr[i].abs().max(li[i].abs()) + floor_err <= 2.0 * plan.tol * live;
        }
    }
    // Phases and grid positions from the exactly reduced delay, lanes = leaves.
    let (mut x, mut pr, mut pi) = ([0.0; LB], [0.0; LB], [0.0; LB]);
    let shift = sonar.tables.k0 + plan.m_c as f64;
    for i in 0..LB {
        let cq = CyclesPerBin::new(range[i], sp.fs, sp.n_samples, sp.sound_speed);
        let f = cq.frac_at(1.0);
        x[i] = if f < 0.0 { f + 1.0 } else { f };
        (pr[i], pi[i]) = cis_neg_cycles(cq.frac_at(shift));
    }
    // Grid positions, lanes = leaves (the weights follow per leaf, lanes = taps).
    let nf = plan.nufft.nf as f64;
    let mut l0f = [0.0; LB];
    let mut u = [0.0; LB];
    for i in 0..LB {
        let left = x[i] * nf - w as f64 / 2.0;
        l0f[i] = left.ceil();
        u[i] = l0f[i] - left;
    }
    // Strengths (node values times the phase), lanes = leaves, then interleaved for the
    // spreading (a loop writing `sc` directly is vectorised over nodes, with gathers and
    // scatters).
    for (q, row) in sc.iter_mut().enumerate().take(p) {
        let (mut re, mut im) = ([0.0; LB], [0.0; LB]);
        for i in 0..LB {
            re[i] = fr[q][i].mul_add(pr[i], -fi[q][i] * pi[i]);
            im[i] = fr[q][i].mul_add(pi[i], fi[q][i] * pr[i]);
        }
        *row = std::array::from_fn(|t| if t % 2 == 0 { re[t / 2] } else { im[t / 2] });
    }
    let mut out = Failures {
        defer: [false; LB],
        exact: [false; LB],
    };
    let mut live = [false; LB];
    for i in 0..n {
        if skip[i] {
            continue;
        }
        if !ok[i] {
            if below_floor[i] {
                out.exact[i] = true;
            } else {
                out.defer[i] = true;
            }
            continue;
        }
        if kink[i] != NOT_KINKED {
            let mk = kink[i];
            let cq = CyclesPerBin::new(range[i], sp.fs, sp.n_samples, sp.sound_speed);
            let gr: [f64; MAX_NODES] = std::array::from_fn(|q| fr[q][i]);
            let gi: [f64; MAX_NODES] = std::array::from_fn(|q| fi[q][i]);
            let (dre, dim) = (&mut direct.re, &mut direct.im);
            if m - mk <= mk {
                // live side the shorter: its interpolant added there, nothing spread
                add_interpolant(sonar, plan, &gr, &gi, &cq, (mk, m), 1.0, dre, dim);
                continue;
            }
            add_interpolant(sonar, plan, &gr, &gi, &cq, (0, mk), -1.0, dre, dim);
        }
        live[i] = true;
    }
    // (integers below 2^51 in size, finite as the ranges are, converted exactly by the
    // 1.5 2^52 shift: vector adds, where `as i64`, saturating, is scalar)
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let pad = plan.nufft.pad as f64;
    let l0: [usize; LB] = std::array::from_fn(|i| {
        ((l0f[i] + pad + SHIFT).to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64) as usize
    });
    spread_lanes(plan, grid, &u, &l0, sc, &live);
    out
}

/// The lanes of a batch that [`paper_batch`] did not take: `defer`, those its interpolant
/// cannot represent to tol (for a later pass); `exact`, kinked lanes whose live part lies
/// below the node values' rounding floor ([`KINK_FLOOR`]), for the exact sum over the whole
/// band (a later pass would only meet the same floor).
pub(crate) struct Failures {
    pub(crate) defer: [bool; LB],
    pub(crate) exact: [bool; LB],
}
