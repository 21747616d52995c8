//! The end of a fast pass: the direct (bin by bin) sums, the tasks' grids added in order, one
//! NUFFT per channel and the Lagrange combination into the windowed band spectrum.
use crate::echo::term::LeafTerm;
use crate::fast::lanes::LB;
use crate::fast::plan::FastPlan;
use crate::fast::pool::give_grid;
use crate::fast::prepared::FastSonar;
use multiversion::multiversion;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;

/// Unwindowed band-bin accumulators (length `M + LB`) for the terms a fast pass adds directly.
pub(crate) struct Direct {
    pub re: Vec<f64>,
    pub im: Vec<f64>,
}

impl Direct {
    pub(crate) fn new(m: usize) -> Direct {
        Direct {
            re: vec![0.0; m + LB],
            im: vec![0.0; m + LB],
        }
    }

    pub(crate) fn add(&mut self, other: &Direct) {
        for (a, b) in self.re.iter_mut().zip(&other.re) {
            *a += b;
        }
        for (a, b) in self.im.iter_mut().zip(&other.im) {
            *a += b;
        }
    }

    /// Add the exact (unwindowed) sum of `terms`, if any.
    pub(crate) fn add_exact(&mut self, sonar: &FastSonar, terms: &[LeafTerm]) {
        if terms.is_empty() {
            return;
        }
        let (re, im) = crate::echo::spectrum::sum_terms_unwindowed(sonar, terms);
        for (a, b) in self.re.iter_mut().zip(&re) {
            *a += b;
        }
        for (a, b) in self.im.iter_mut().zip(&im) {
            *a += b;
        }
    }
}

/// Values per parallel block of [`add_grids`].
const GRID_SUM_BLOCK: usize = 8192;

/// Add tasks' spread grids into `acc`, in their order at every value (so the sums do not
/// depend on the thread count), in parallel over blocks of the grid; the grids go back to the
/// pool.
pub(crate) fn add_grids(acc: &mut [f64], grids: Vec<Vec<f64>>) {
    acc.par_chunks_mut(GRID_SUM_BLOCK)
        .enumerate()
        .for_each(|(b, a)| {
            let (at, n) = (b * GRID_SUM_BLOCK, a.len());
            for g in &grids {
                for (x, v) in a.iter_mut().zip(&g[at..at + n]) {
                    *x += v;
                }
            }
        });
    grids.into_iter().for_each(give_grid);
}

/// One channel (`span` of each grid) of the tasks' grids summed in their order, as complex
/// values.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn channel_sum(grids: &[Vec<f64>], span: std::ops::Range<usize>) -> Vec<Complex64> {
    let mut acc: Vec<Complex64> = grids[0][span.clone()]
        .chunks_exact(2)
        .map(|v| Complex64::new(v[0], v[1]))
        .collect();
    for g in &grids[1..] {
        for (a, v) in acc.iter_mut().zip(g[span.clone()].chunks_exact(2)) {
            a.re += v[0];
            a.im += v[1];
        }
    }
    acc
}

/// The windowed band spectrum from the tasks' spread grids (their sum, one NUFFT per
/// channel, then the Lagrange combination) plus the unwindowed exactly summed part `direct`.
/// The grids are summed in their order at every value (so the sums do not depend on the
/// thread count) while each channel is copied for its transform, and go back to the pool.
pub(crate) fn finish_grids(
    sonar: &FastSonar,
    plan: &FastPlan,
    grids: Vec<Vec<f64>>,
    direct: (Vec<f64>, Vec<f64>),
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let (p, glen) = (plan.p, plan.nufft.grid_len());
    // One NUFFT per channel, then the Lagrange combination.
    let modes: Vec<Vec<Complex64>> = (0..p)
        .into_par_iter()
        .map(|c| {
            let mut cg = channel_sum(&grids, 2 * c * glen..2 * (c + 1) * glen);
            let mut out = vec![Complex64::new(0.0, 0.0); m];
            plan.nufft.finish(&mut cg, &mut out);
            out
        })
        .collect();
    grids.into_iter().for_each(give_grid);
    lagrange_sum(sonar, plan, &modes, direct)
}

/// `window (direct + sum_c L_c modes_c)` at each band bin, the channels added in order.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn lagrange_sum(
    sonar: &FastSonar,
    plan: &FastPlan,
    modes: &[Vec<Complex64>],
    (mut re, mut im): (Vec<f64>, Vec<f64>),
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let row = m + LB;
    re.truncate(m);
    im.truncate(m);
    for (c, mc) in modes.iter().enumerate() {
        let lt = &plan.lagrange_t[c * row..c * row + m];
        for (((r, i), z), &l) in re.iter_mut().zip(im.iter_mut()).zip(mc).zip(lt) {
            // (a product, then a sum: not fused)
            *r += z.re * l;
            *i += z.im * l;
        }
    }
    for ((r, i), &w) in re.iter_mut().zip(im.iter_mut()).zip(&sonar.window) {
        *r *= w;
        *i *= w;
    }
    (re, im)
}
