//! Fast passes over leaf terms: the tasks of a first pass (chunking, routing, spreading), the
//! passes for the leaves it leaves, and the entry points `fast_sum_terms` and
//! `fast_band_spectrum`.
use crate::echo::paper_regime;
use crate::echo::{leaf_term, sum_terms, LeafTerm};
use crate::fast::batch::paper_batch;
use crate::fast::finish::add_grids;
use crate::fast::finish::finish_grids;
use crate::fast::finish::Direct;
use crate::fast::kinks::paper_route;
use crate::fast::kinks::PaperRoute;
use crate::fast::lanes::PaperLanes;
use crate::fast::lanes::LB;
use crate::fast::nodes::choose_nodes;
use crate::fast::nodes::BatchScratch;
use crate::fast::plan::FastPlan;
use crate::fast::po::po_leaf;
use crate::fast::pool::take_grid;
use crate::fast::prepared::FastSonar;
use crate::fast::schedule::TaskCount;
use crate::fast::subband::{KinkPass, KinkedLeaf, KinkedShare};
use crate::lobe::Member;
use crate::scene::Scene;
use crate::sonar::LeafModel;
use multiversion::multiversion;
use rayon::prelude::*;

/// The most leaves per parallel task (each task spreads into its own grid; grids are added in
/// order).
pub const FAST_CHUNK: usize = 65_536;
/// Second-pass chunk lengths are whole multiples of this.
pub(super) const SUB_CHUNK: usize = 1024;

/// Leaves per task per point of its spread grid, at least (where there are leaves enough for
/// four tasks): each task zeroes its own grid and the grids are summed, which at fewer leaves
/// per point costs more than a few percent of the spreading.
pub(super) const LEAVES_PER_GRID_POINT: usize = 10;

/// Leaves per parallel task for `n` leaves spread onto grids of `grid_points` points: 4 to 16
/// tasks, as many as keep [`LEAVES_PER_GRID_POINT`], of about 4096 to [`FAST_CHUNK`] leaves (a
/// function of `n` and the grid only, so that results do not depend on the thread count).
/// The tasks are of equal length but for the last, which is at most one leaf per task
/// shorter: a much shorter last task would leave a thread idle at the end of the pass.
pub fn chunk_len(n: usize, grid_points: usize) -> usize {
    let tasks = (n / (LEAVES_PER_GRID_POINT * grid_points.max(1))).clamp(4, 16);
    let len = n.div_ceil(tasks).clamp(4096, FAST_CHUNK);
    n.div_ceil(n.div_ceil(len).max(1)).max(1)
}
/// One task's share: spread grids (P channels, each a run of complex values), the terms
/// added bin by bin, and the leaves deferred to a later pass.
struct Partial {
    grid: Vec<f64>,
    /// Terms added straight to band bins (kinked leaves' sides).
    direct: Direct,
    /// Leaves (indices into the chunk, ascending) the interpolation cannot represent to tol,
    /// but kinked paper-model ones, which go to `kinked` (in order).
    deferred: Vec<usize>,
    kinked: Vec<KinkedLeaf>,
    /// Leaves (indices into the chunk, ascending) routed to the exact sum: outside the paper
    /// model's domain.
    exact: Vec<usize>,
}

/// How far ahead (in terms) a first pass prefetches its terms: without it the batches wait on
/// memory for the 64-byte terms (the hardware prefetcher does not run far enough ahead).
const TERMS_AHEAD: usize = 128;

#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn spread_chunk(sonar: &FastSonar, plan: &FastPlan, terms: &[LeafTerm], floors: &[f64]) -> Partial {
    let (p, glen) = (plan.p, plan.nufft.grid_len());
    let mut part = Partial {
        grid: take_grid(2 * p * glen),
        direct: Direct::new(sonar.n_bins()),
        deferred: Vec::new(),
        kinked: Vec::new(),
        exact: Vec::new(),
    };
    match sonar.params.leaf_model {
        LeafModel::Paper => {
            // Route by regime; smooth and kinked leaves go through the vector batches.
            let mut lanes = PaperLanes::new();
            let mut ids = [0usize; LB];
            let atten = !plan.nodes.atten.is_empty();
            let mut s = BatchScratch::new();
            let mut flush = |lanes: &mut PaperLanes, ids: &[usize; LB], part: &mut Partial| {
                if lanes.n == 0 {
                    return;
                }
                lanes.pad();
                let (grid, sums) = (&mut part.grid, &mut part.direct);
                let failed = if atten {
                    paper_batch::<true>(sonar, plan, lanes, grid, sums, &mut s)
                } else {
                    paper_batch::<false>(sonar, plan, lanes, grid, sums, &mut s)
                };
                for (k, &id) in ids[..lanes.n].iter().enumerate() {
                    if failed.defer[k] {
                        match lanes.kinked_leaf(sonar, plan, k) {
                            Some(kl) => part.kinked.push(kl),
                            None => part.deferred.push(id),
                        }
                    } else if failed.exact[k] {
                        part.exact.push(id);
                    }
                }
                lanes.n = 0;
            };
            let tab = &sonar.tables;
            for (b, block) in terms.chunks(LB).enumerate() {
                // A block is a batch as it stands where it can be (`ready_whole`); otherwise
                // each leaf goes its route.
                let base = b * LB;
                crate::math::prefetch::ahead::<_, LB>(terms, base + TERMS_AHEAD);
                if let Ok(block) = <&[LeafTerm; LB]>::try_from(block) {
                    let mut bl = {
                        #[cfg(target_arch = "x86_64")]
                        {
                            if multiversion::target::target_cfg_f!(target_feature = "avx512f") {
                                // SAFETY: this clone runs only where AVX-512F is present.
                                unsafe { PaperLanes::of_block_avx512(block) }
                            } else {
                                PaperLanes::of_block(block)
                            }
                        }
                        #[cfg(not(target_arch = "x86_64"))]
                        PaperLanes::of_block(block)
                    };
                    if let Some(f) = floors.get(base..base + LB) {
                        bl.floor.copy_from_slice(f);
                    }
                    if bl.ready_whole(sonar, &[false; LB], &[true; LB]) {
                        flush(&mut bl, &std::array::from_fn(|k| base + k), &mut part);
                        continue;
                    }
                }
                for (k, t) in block.iter().enumerate() {
                    let idx = base + k;
                    let regime = paper_regime(tab, t);
                    match paper_route(sonar, regime, t.radius_pow_b, t.beta) {
                        PaperRoute::Skip => {}
                        PaperRoute::Defer => part.exact.push(idx),
                        PaperRoute::Batch(kink) => {
                            ids[lanes.n] = idx;
                            lanes.push(t, kink);
                            if let Some(&f) = floors.get(idx) {
                                lanes.floor[lanes.n - 1] = f;
                            }
                            if lanes.n == LB {
                                flush(&mut lanes, &ids, &mut part);
                            }
                        }
                    }
                }
            }
            flush(&mut lanes, &ids, &mut part);
        }
        LeafModel::PhysicalOptics => {
            for (idx, t) in terms.iter().enumerate() {
                if !po_leaf(sonar, plan, t, &mut part.grid) {
                    part.deferred.push(idx);
                }
            }
        }
    }
    // Leaves the interpolation cannot represent to tol (ascending): the caller gives them a
    // second pass or sums them exactly.
    part.deferred.sort_unstable();
    part
}

/// Leaves per task of a second pass over `n` deferred leaves: smaller tasks than
/// [`chunk_len`] (a few thousand such leaves would otherwise be one or two uneven tasks), a
/// function of `n` only.
pub(crate) fn second_chunk_len(n: usize) -> usize {
    n.div_ceil(4)
        .clamp(SUB_CHUNK, FAST_CHUNK)
        .div_ceil(SUB_CHUNK)
        * SUB_CHUNK
}

/// The second fast pass over deferred leaves: the plan's full node count, tasks of
/// [`second_chunk_len`], the leaves it still cannot represent summed exactly (None for none).
pub(crate) fn second_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    leaves: &[LeafTerm],
) -> Option<(Vec<f64>, Vec<f64>)> {
    (!leaves.is_empty())
        .then(|| fast_sum_fixed(sonar, plan, leaves, &[], second_chunk_len(leaves.len())))
}

/// Fewer failures than this are summed exactly rather than given a second fast pass.
const SECOND_PASS_MIN: usize = 256;

/// The leaves a first fast pass left, as a windowed band spectrum (None for none): of its
/// failures, the kinked paper-model ones (`kinked`) by sub-bands ([`crate::fast::subband`], where
/// the band has them) and the others (`retry`) by a second pass at the plan's full node count;
/// the exact-routed leaves (`exact`: outside the model's domain, or below a kinked leaf's
/// rounding floor) by the exact sum. The three run side by side and are added in that order.
pub(crate) fn leftover_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    retry: &[LeafTerm],
    kinked: &[KinkedLeaf],
    exact: &[LeafTerm],
    shares: Option<(&KinkPass, Vec<KinkedShare>)>,
) -> Option<(Vec<f64>, Vec<f64>)> {
    if retry.is_empty() && kinked.is_empty() && exact.is_empty() && shares.is_none() {
        return None;
    }
    let subs = match sonar.params.leaf_model {
        LeafModel::Paper => sonar.sub_bands(),
        LeafModel::PhysicalOptics => None,
    };
    let (mut retry2, mut exact2) = (retry.to_vec(), exact.to_vec());
    let kinked = if subs.is_some() {
        kinked
    } else {
        // (no sub-bands: kinked leaves take the second pass too)
        retry2.extend(kinked.iter().map(|k| k.term));
        &[]
    };
    if retry2.len() < SECOND_PASS_MIN {
        // (a second pass costs its grids and transforms: a few hundred exact leaves)
        exact2.append(&mut retry2);
    }
    let ((second, sub), (shared, direct)) = rayon::join(
        || {
            rayon::join(
                || second_pass(sonar, plan, &retry2),
                || {
                    let s = subs.as_ref().filter(|_| !kinked.is_empty())?;
                    // (a sub-band plan cannot fail where the band's did; if one did, the
                    // exact sum stands in)
                    Some(s.kinked_sum(sonar, plan.tol, kinked).unwrap_or_else(|_| {
                        let terms: Vec<LeafTerm> = kinked.iter().map(|k| k.term).collect();
                        sum_terms(sonar, &terms)
                    }))
                },
            )
        },
        || {
            rayon::join(
                || shares.and_then(|(pass, sh)| pass.finish(sonar, sh)),
                || (!exact2.is_empty()).then(|| sum_terms(sonar, &exact2)),
            )
        },
    );
    let m = sonar.n_bins();
    let (mut re, mut im) = (vec![0.0; m], vec![0.0; m]);
    for (pr, pi) in [second, sub, shared, direct].into_iter().flatten() {
        for j in 0..m {
            re[j] += pr[j];
            im[j] += pi[j];
        }
    }
    Some((re, im))
}

/// The windowed band spectrum `(re, im)` of the members by the fast method.
pub fn fast_band_spectrum(
    sonar: &FastSonar,
    plan: &FastPlan,
    scene: &Scene,
    members: &[Member],
) -> (Vec<f64>, Vec<f64>) {
    let terms: Vec<LeafTerm> = members
        .iter()
        .map(|mb| leaf_term(sonar, scene, mb))
        .collect();
    fast_sum_terms(sonar, plan, &terms)
}

/// A first pass's spectrum (`first`: its transforms) plus its leftover leaves' (`left`, from
/// [`leftover_pass`]), the two computed side by side.
pub(crate) fn beside_leftovers(
    left: impl FnOnce() -> Option<(Vec<f64>, Vec<f64>)> + Send,
    first: impl FnOnce() -> (Vec<f64>, Vec<f64>) + Send,
) -> (Vec<f64>, Vec<f64>) {
    let (left, (mut re, mut im)) = rayon::join(left, first);
    if let Some((lr, li)) = left {
        for j in 0..re.len() {
            re[j] += lr[j];
            im[j] += li[j];
        }
    }
    (re, im)
}

/// A first pass of at most this many tasks spreads its kinked leaves in its tasks
/// ([`KinkPass`]); a longer one leaves them to a later pass. With few tasks the later pass's
/// sub-bands are a few small sums after the tasks, run mostly alone, so they cost less in the
/// tasks. With more, the later pass fills the threads while the transforms run, and in the
/// tasks they cost more.
pub(super) const KINKED_IN_TASKS_UP_TO: usize = 4;

/// The windowed band spectrum of the given leaf terms by the fast method; `plan` fixes the
/// tolerance and the largest node count (see [`choose_nodes`]).
pub fn fast_sum_terms(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
) -> (Vec<f64>, Vec<f64>) {
    if rayon::current_thread_index().is_none() {
        // Called from outside the pool: run on a pool thread, so that the parallel steps
        // follow one another there (from outside, each is injected into the pool and this
        // thread sleeps and wakes in between, before the tasks start and after they end).
        // The call is then the pool's only work, so its first
        // pass keeps a thread awake for the transforms after it ([`TaskCount`]).
        return rayon::scope(|_| fast_sum_terms_in(sonar, plan, terms, true));
    }
    fast_sum_terms_in(sonar, plan, terms, false)
}

/// [`fast_sum_terms`] on a pool thread; `alone`: the call is the pool's only work (see
/// [`TaskCount::new`]).
pub(super) fn fast_sum_terms_in(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    alone: bool,
) -> (Vec<f64>, Vec<f64>) {
    let p = choose_nodes(sonar, plan, terms);
    if p < plan.p {
        if let Ok(smaller) = sonar.plans.get_with_nodes(sonar, plan.tol, p) {
            // First pass with fewer nodes; leaves it cannot represent get the full count, in a
            // later pass that runs beside the first pass's transforms.
            let chunk = chunk_len(terms.len(), smaller.nufft.nf);
            // (with few tasks, each spreads its kinked leaves onto sub-band grids of its own)
            let kink = (terms.len().div_ceil(chunk) <= KINKED_IN_TASKS_UP_TO)
                .then(|| KinkPass::new(sonar, plan.tol, p))
                .flatten();
            let first = spread_pass(sonar, &smaller, terms, &[], chunk, kink.as_ref(), alone);
            let retry: Vec<LeafTerm> = first.deferred.iter().map(|&i| terms[i]).collect();
            let exact: Vec<LeafTerm> = first.exact.iter().map(|&i| terms[i]).collect();
            let shares = kink.as_ref().map(|k| (k, first.shares));
            return beside_leftovers(
                || leftover_pass(sonar, plan, &retry, &first.kinked, &exact, shares),
                || {
                    let (grids, sums) = (first.grids, first.sums);
                    finish_grids(sonar, &smaller, grids, (sums.re, sums.im))
                },
            );
        }
    }
    fast_sum_fixed(
        sonar,
        plan,
        terms,
        &[],
        chunk_len(terms.len(), plan.nufft.nf),
    )
}

/// One fast pass at the plan's node count, `chunk` leaves per task: the windowed band
/// spectrum, the leaves it cannot represent (and those outside the model's domain) summed
/// exactly. `floors` (empty, or one per term) are lower bounds of the leaves' peaks over a
/// wider band, for the smoothness check ([`PaperLanes::floor`]).
pub(crate) fn fast_sum_fixed(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
    chunk: usize,
) -> (Vec<f64>, Vec<f64>) {
    let Spread {
        grids,
        mut sums,
        deferred,
        kinked,
        exact,
        ..
    } = spread_pass(sonar, plan, terms, floors, chunk, None, false);
    sums.add_exact(sonar, &rest_terms(terms, deferred, exact, &kinked));
    finish_grids(sonar, plan, grids, (sums.re, sums.im))
}

/// The leaves a fast pass leaves to the exact sum, in its order: the deferred and the
/// exact-routed ones (indices into `terms`) ascending, then the kinked ones.
fn rest_terms(
    terms: &[LeafTerm],
    deferred: Vec<usize>,
    exact: Vec<usize>,
    kinked: &[KinkedLeaf],
) -> Vec<LeafTerm> {
    let mut all: Vec<usize> = deferred.into_iter().chain(exact).collect();
    all.sort_unstable();
    all.iter()
        .map(|&i| terms[i])
        .chain(kinked.iter().map(|k| k.term))
        .collect()
}

/// One task's fast sum of `terms` without its transforms: its spread grid, and its direct
/// bins (unwindowed) with the leaves the grid cannot take summed exactly, as
/// [`fast_sum_fixed`] sums them.
pub(crate) fn spread_task(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
) -> (Vec<f64>, Direct) {
    let part = spread_chunk(sonar, plan, terms, floors);
    let mut direct = part.direct;
    direct.add_exact(
        sonar,
        &rest_terms(terms, part.deferred, part.exact, &part.kinked),
    );
    (part.grid, direct)
}

/// The spreading of one fast pass: the tasks' grids (for [`finish_grids`] to sum), the terms
/// they added bin by bin, and the leaves they left, as ascending indices into the terms (the
/// kinked ones as [`KinkedLeaf`]s).
pub(crate) struct Spread {
    /// The tasks' grids, in order (their sum is the pass's grid).
    grids: Vec<Vec<f64>>,
    sums: Direct,
    /// Leaves the interpolation cannot represent (for a later pass), kinked paper-model ones
    /// apart (in task order).
    pub(crate) deferred: Vec<usize>,
    pub(crate) kinked: Vec<KinkedLeaf>,
    /// Leaves outside the model's domain (for the exact sum).
    pub(crate) exact: Vec<usize>,
    /// The tasks' kinked leaves on their sub-band grids (in task order; empty without a
    /// [`KinkPass`], the kinked leaves then in `kinked`).
    pub(crate) shares: Vec<KinkedShare>,
}

/// The spreading part of a fast pass ([`fast_sum_fixed`]): `chunk` leaves per task, the
/// tasks' grids kept in task order; `alone`: the pass is the pool's only work (see
/// [`TaskCount::new`]).
pub(crate) fn spread_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
    chunk: usize,
    kink: Option<&KinkPass>,
    alone: bool,
) -> Spread {
    let m = sonar.n_bins();
    // A task: its share of the pass, its kinked leaves onto its own sub-band grids.
    let task = |terms: &[LeafTerm], floors: &[f64]| {
        let mut part = spread_chunk(sonar, plan, terms, floors);
        let share = kink.map(|k| k.spread(&std::mem::take(&mut part.kinked)));
        (part, share)
    };
    if terms.len() <= chunk {
        // One task: its grid and sums are the pass's (adding them to zeros changes nothing).
        let (part, share) = task(terms, floors);
        return Spread {
            grids: vec![part.grid],
            sums: part.direct,
            deferred: part.deferred,
            kinked: part.kinked,
            exact: part.exact,
            shares: share.into_iter().collect(),
        };
    }
    let mut grids: Vec<Vec<f64>> = Vec::new();
    let mut sums = Direct::new(m);
    let (mut deferred, mut exact): (Vec<usize>, Vec<usize>) = (Vec::new(), Vec::new());
    let (mut kinked, mut shares) = (Vec::new(), Vec::new());
    let mut offset = 0usize;
    let mut add = |parts: Vec<((Partial, Option<KinkedShare>), usize)>| {
        if grids.len() > 1 {
            // (a later batch: the earlier ones summed into the first grid, in order)
            let rest = grids.split_off(1);
            add_grids(&mut grids[0], rest);
        }
        for ((part, share), len) in parts {
            shares.extend(share);
            deferred.extend(part.deferred.iter().map(|&i| i + offset));
            kinked.extend_from_slice(&part.kinked);
            exact.extend(part.exact.iter().map(|&i| i + offset));
            sums.add(&part.direct);
            offset += len;
            grids.push(part.grid);
        }
    };
    // (16 grids at a time at most: memory stays bounded for long records)
    for (b, batch) in terms.chunks(chunk * 16).enumerate() {
        let tasks = TaskCount::new(batch.len().div_ceil(chunk), alone);
        let parts: Vec<_> = batch
            .par_chunks(chunk)
            .enumerate()
            .map(|(k, c)| {
                let start = b * chunk * 16 + k * chunk;
                let f = floors.get(start..start + c.len()).unwrap_or(&[]);
                tasks.run(|| (task(c, f), c.len()))
            })
            .collect();
        add(parts);
    }
    Spread {
        grids,
        sums,
        deferred,
        kinked,
        exact,
        shares,
    }
}
