//! Branch pieces by the fast method: each point of a piece's echo ([`branch_points`]) has a
//! factor analytic across the band, taken at the plan's Chebyshev nodes, checked as a
//! physical-optics leaf's and spread onto the NUFFT grid; a piece with a point that fails the
//! check is summed exactly.
use crate::echo::{branch_points, sum_branch_terms_unwindowed, BranchTerm};
use crate::fast::finish::finish_grids;
use crate::fast::pass::chunk_len;
use crate::fast::plan::{FastPlan, MAX_NODES};
use crate::fast::pool::take_grid;
use crate::fast::prepared::FastSonar;
use crate::fast::spread::spread_at;
use multiversion::multiversion;
use rayon::prelude::*;

/// Spread a task's pieces onto `grid`; the pieces that fail their check, to be summed exactly.
/// (Compiled per target: the kernel weights' and the spreading's `mul_add`s are instructions,
/// not library calls.)
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn spread_branches(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[BranchTerm],
    grid: &mut [f64],
) -> Vec<BranchTerm> {
    terms
        .iter()
        .filter(|t| !spread_branch(sonar, plan, t, grid))
        .copied()
        .collect()
}

/// Spread one piece's points; false (nothing spread) when one of them cannot be interpolated
/// to `tol` (the caller sums the piece exactly).
#[inline(always)]
fn spread_branch(sonar: &FastSonar, plan: &FastPlan, t: &BranchTerm, grid: &mut [f64]) -> bool {
    let nt = &plan.nodes;
    let p = plan.p;
    let (pts, n) = branch_points(t, sonar.tables.k[0]);
    let mut values = [([0.0; MAX_NODES], [0.0; MAX_NODES]); 2];
    for (pt, (fr, fi)) in pts[..n].iter().zip(values.iter_mut()) {
        let (mut peak, mut lr, mut li) = (0.0f64, 0.0, 0.0);
        for q in 0..p {
            let k = nt.k[q];
            // the channel carries F k node_scale (F itself, or k F: see `K_FACTOR_TOL`)
            let mut g = pt.form.at(k) * k * plan.node_scale[q];
            if !nt.atten.is_empty() {
                g *= (-nt.atten[q] * pt.range).exp();
            }
            fr[q] = g * pt.phase.0;
            fi[q] = g * pt.phase.1;
            peak = peak.max(fr[q].abs()).max(fi[q].abs());
            lr = plan.cheb_last[q].mul_add(fr[q], lr);
            li = plan.cheb_last[q].mul_add(fi[q], li);
        }
        if !(lr.abs().max(li.abs()) <= 2.0 * plan.tol * peak) && peak > 0.0 {
            return false;
        }
    }
    for (pt, (fr, fi)) in pts[..n].iter().zip(&values) {
        spread_at(sonar, plan, pt.delay, fr, fi, grid);
    }
    true
}

/// The windowed band spectrum of branch terms by the fast method: tasks of [`chunk_len`]
/// pieces spread onto grids of their own, added in order (so the result does not depend on
/// the number of threads); the pieces that fail their check summed exactly.
pub fn fast_branch_spectrum(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[BranchTerm],
) -> (Vec<f64>, Vec<f64>) {
    let glen = 2 * plan.p * plan.nufft.grid_len();
    let chunk = chunk_len(terms.len(), plan.nufft.nf);
    let parts: Vec<(Vec<f64>, Vec<BranchTerm>)> = terms
        .par_chunks(chunk.max(1))
        .map(|c| {
            let mut grid = take_grid(glen);
            let exact = spread_branches(sonar, plan, c, &mut grid);
            (grid, exact)
        })
        .collect();
    let mut grids = Vec::with_capacity(parts.len().max(1));
    let mut exact = Vec::new();
    for (g, e) in parts {
        grids.push(g);
        exact.extend(e);
    }
    if grids.is_empty() {
        grids.push(take_grid(glen));
    }
    let m = sonar.n_bins();
    let direct = if exact.is_empty() {
        (vec![0.0; m], vec![0.0; m])
    } else {
        sum_branch_terms_unwindowed(sonar, &exact)
    };
    finish_grids(sonar, plan, grids, direct)
}
