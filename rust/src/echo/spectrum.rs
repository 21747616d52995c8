//! The band spectrum of one pose (docs/model.md §5):
//! `Y_k = w_k sum_i A_ki exp(j phi_ki)`, accumulated in f64 over (scatterer, bin).
//!
//! Leaves are summed in fixed chunks of [`LEAF_CHUNK`] (by ascending leaf index); the chunk
//! partial sums are added in chunk order. The grouping depends only on the member list, never
//! on the number of threads, so results are bit-identical for any `RAYON_NUM_THREADS`.
use crate::math::aligned::Aligned;

use crate::echo::term::leaf_term;
use crate::echo::term::LeafTerm;
use crate::echo::Prepared;
use crate::lobe::Member;
use crate::scene::Scene;
use rayon::prelude::*;

/// Leaves per partial sum.
pub const LEAF_CHUNK: usize = 64;
/// Partial sums held at once (bounds memory to `BATCH * M` complex values).
const BATCH: usize = 256;

/// Adds one term's unwindowed contribution to every band bin (`re`, `im` of length `m_pad`).
pub type AddTerm<T> = fn(&Prepared, &T, &mut [f64], &mut [f64]);

/// Sum a chunk of terms into `re`, `im` (length M, zeroed by the caller).
fn chunk_sum<T>(sonar: &Prepared, add: AddTerm<T>, terms: &[T], re: &mut [f64], im: &mut [f64]) {
    for t in terms {
        add(sonar, t, re, im);
    }
}

/// The windowed band spectrum `(re, im)` over the M band bins for the given members.
pub fn band_spectrum(sonar: &Prepared, scene: &Scene, members: &[Member]) -> (Vec<f64>, Vec<f64>) {
    let terms: Vec<LeafTerm> = members
        .iter()
        .map(|mb| leaf_term(sonar, scene, mb))
        .collect();
    sum_terms(sonar, &terms)
}

/// The windowed band spectrum of the given leaf terms, summed in their order.
pub fn sum_terms(sonar: &Prepared, terms: &[LeafTerm]) -> (Vec<f64>, Vec<f64>) {
    let (mut re, mut im) = sum_terms_unwindowed(sonar, terms);
    for j in 0..re.len() {
        re[j] *= sonar.window[j];
        im[j] *= sonar.window[j];
    }
    (re, im)
}

/// The band spectrum of the given leaf terms without the window, summed in their order.
pub fn sum_terms_unwindowed(sonar: &Prepared, terms: &[LeafTerm]) -> (Vec<f64>, Vec<f64>) {
    sum_chunked(sonar, crate::echo::add_leaf, terms)
}

/// The band spectrum of `terms` without the window, each added by `add`, in fixed chunks of
/// [`LEAF_CHUNK`] whose partial sums are added in order.
pub fn sum_chunked<T: Sync>(
    sonar: &Prepared,
    add: AddTerm<T>,
    terms: &[T],
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let m_pad = sonar.tables.m_pad;
    // (accumulators on cache lines: see `crate::math::aligned`)
    let (mut re, mut im) = (Aligned::zeros(m_pad), Aligned::zeros(m_pad));
    if terms.len() <= LEAF_CHUNK {
        chunk_sum(sonar, add, terms, &mut re, &mut im);
    } else {
        // One set of partial sums for the whole call, zeroed again for each batch: allocated
        // afresh per batch (5 MB), they would go back to the system and come again as new
        // pages, at the cost of page faults.
        let mut partials: Vec<(Aligned, Aligned)> = Vec::new();
        for batch in terms.chunks(LEAF_CHUNK * BATCH) {
            let n = batch.len().div_ceil(LEAF_CHUNK);
            let used = partials.len();
            while partials.len() < n {
                partials.push((Aligned::zeros(m_pad), Aligned::zeros(m_pad)));
            }
            partials[..n]
                .par_iter_mut()
                .zip(batch.par_chunks(LEAF_CHUNK))
                .enumerate()
                .for_each(|(c, ((pr, pi), chunk))| {
                    // (those an earlier batch used)
                    if c < used {
                        pr.fill(0.0);
                        pi.fill(0.0);
                    }
                    chunk_sum(sonar, add, chunk, pr, pi);
                });
            for (pr, pi) in &partials[..n] {
                for j in 0..m {
                    re[j] += pr[j];
                    im[j] += pi[j];
                }
            }
        }
    }
    let (mut re, mut im) = (re.into_vec(), im.into_vec());
    re.truncate(m);
    im.truncate(m);
    (re, im)
}
