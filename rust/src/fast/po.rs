//! Physical-optics leaves in a fast pass: their factor at the nodes, the route it decides, and
//! the spreading of one leaf.
use crate::echo::term::LeafTerm;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::fast::spread::spread_at;
use crate::physics::leaf;

/// First positive zero of the Bessel function J1.
const J1_FIRST_ZERO: f64 = 3.831_705_970_207_512;

/// How one leaf enters the fast sum.
enum Route {
    Skip,
    Direct,
    Spread,
}

/// The physical-optics leaf factor at the nodes, into `fr`, `fi`; decides the route. (The
/// paper model goes through [`paper_batch`], eight leaves at a time.)
#[inline(always)]
fn po_node_values(
    sonar: &FastSonar,
    plan: &FastPlan,
    t: &LeafTerm,
    fr: &mut [f64; MAX_NODES],
    fi: &mut [f64; MAX_NODES],
) -> Route {
    let nt = &plan.nodes;
    let p = plan.p;
    // |2 J1(x)/x| is analytic and bell-shaped only before J1's first zero (x = 3.8317);
    // past it the factor has kinks and oscillates across the band: sum such leaves exactly.
    let x_hi = 2.0 * sonar.tables.k[sonar.tables.m - 1] * t.radius * t.sin_beta;
    if !(x_hi < J1_FIRST_ZERO) {
        return Route::Direct;
    }
    for q in 0..p {
        let k = nt.k[q];
        let (l, psi) = leaf::physical_optics(k * t.radius, t.cos_beta, t.sin_beta);
        let mut amp = t.amp * l * plan.node_scale[q];
        if !nt.atten.is_empty() {
            amp *= (-nt.atten[q] * t.range).exp();
        }
        let (s, c) = (-psi).sin_cos();
        fr[q] = amp * c;
        fi[q] = amp * s;
    }
    let mut peak = 0.0f64;
    let (mut lr, mut li) = (0.0, 0.0);
    for q in 0..p {
        peak = peak.max(fr[q].abs()).max(fi[q].abs());
        lr = plan.cheb_last[q].mul_add(fr[q], lr);
        li = plan.cheb_last[q].mul_add(fi[q], li);
    }
    if peak == 0.0 {
        return Route::Skip;
    }
    if !(lr.abs().max(li.abs()) <= 2.0 * plan.tol * peak) {
        return Route::Direct;
    }
    Route::Spread
}

/// Spread one physical-optics leaf; false when its factor cannot be interpolated to tol (the
/// caller sums it exactly).
#[inline(always)]
pub(crate) fn po_leaf(sonar: &FastSonar, plan: &FastPlan, t: &LeafTerm, grid: &mut [f64]) -> bool {
    let (mut fr, mut fi) = ([0.0; MAX_NODES], [0.0; MAX_NODES]);
    match po_node_values(sonar, plan, t, &mut fr, &mut fi) {
        Route::Skip => true,
        Route::Direct => false,
        Route::Spread => {
            spread_at(sonar, plan, t.range, &fr, &fi, grid);
            true
        }
    }
}
