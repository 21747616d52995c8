//! Echoes for receivers at their own places (docs/model.md §5a, §9): per pose, one lobe query
//! for all receivers (the union of their lobes), one pass over the candidates that makes every
//! receiver's terms, the branch pieces each receiver hears, then each receiver's band spectrum
//! (leaves and wood) and impulse response.
use crate::budget;
use crate::echo::impulse::impulse_from_band;
use crate::echo::receivers::heard_terms;
use crate::echo::spectrum::sum_terms;
use crate::echo::term_pool::give_terms;
use crate::echo::LeafTerm;
use crate::echo::{heard_branch_term, BranchTerm};
use crate::error::Result;
use crate::fast::{fast_sum_terms, FastPlan, FastSonar};
use crate::lobe::{branch_members_heard, candidates_heard, place_receivers, Search};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::simulate::scatter::wood_spectrum;
use crate::simulate::{check_finite, cost_exact, cost_fast, Echoes, Method};
use crate::sonar::Sonar;
use rayon::prelude::*;
use std::sync::Arc;

/// The windowed band spectrum of one receiver's terms by `method` (`plan`: the fast method's,
/// None for the exact sum); `auto` takes the cheaper for their number.
fn receiver_spectrum(
    sonar: &FastSonar,
    method: Method,
    plan: Option<&FastPlan>,
    terms: &[LeafTerm],
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    match (method, plan) {
        (Method::Fast { .. }, Some(pl)) => fast_sum_terms(sonar, pl, terms),
        (Method::Auto { .. }, Some(pl))
            if cost_fast(terms.len(), m, pl) < cost_exact(terms.len(), m) =>
        {
            fast_sum_terms(sonar, pl, terms)
        }
        _ => sum_terms(sonar, terms),
    }
}

/// One receiver's echo of one pose: the windowed band spectrum, the impulse response (empty
/// when not asked for), the counting leaves, the wood's share of the spectrum (empty without
/// branches) and the counting branch pieces.
struct HeardEcho {
    re: Vec<f64>,
    im: Vec<f64>,
    y: Vec<f64>,
    n_leaves: u64,
    wood_re: Vec<f64>,
    wood_im: Vec<f64>,
    n_pieces: u64,
}

/// Echoes of every pose for every receiver of `sonar` (which has some), poses in parallel:
/// spectra `(p, R, M)`, impulses `(p, R, n)`, counts `(p, R)`; with branches the wood's
/// spectra `(p, R, M)` and the counting pieces `(p, R)`. `plan` is that of each part's share
/// of `tol`.
pub fn simulate_heard(
    scene: &Scene,
    sonar: &FastSonar,
    poses: &[Pose],
    with_impulse: bool,
    search: Search,
    method: Method,
    plan: Option<Arc<FastPlan>>,
) -> Result<Echoes> {
    let m = sonar.n_bins();
    let n = sonar.params.n_samples;
    let r = sonar.params.receivers.len();
    let wood = !scene.branches.is_empty();
    let per_pose: Vec<Vec<HeardEcho>> = poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            let rxs = place_receivers(sonar, pose);
            let cands = candidates_heard(scene, sonar, pose, &rxs, search);
            let terms = heard_terms(scene, sonar, pose, i, &rxs, &cands)?;
            let pieces = branch_members_heard(scene, sonar, pose, i, &rxs)?;
            // The receivers' sums side by side: each is the same whatever runs beside it (its
            // chunks are fixed), and one's serial steps (the transforms) overlap the other's
            // spreading.
            terms
                .into_par_iter()
                .zip(pieces)
                .map(|(t, pc)| {
                    let (mut re, mut im) = receiver_spectrum(sonar, method, plan.as_deref(), &t);
                    let n_leaves = t.len() as u64;
                    give_terms(t);
                    let (mut wood_re, mut wood_im) = (Vec::new(), Vec::new());
                    if wood {
                        let wt: Vec<BranchTerm> =
                            pc.iter().map(|p| heard_branch_term(sonar, p)).collect();
                        (wood_re, wood_im) = if wt.is_empty() {
                            (vec![0.0; m], vec![0.0; m])
                        } else {
                            wood_spectrum(sonar, plan.as_deref(), &wt)
                        };
                        for j in 0..m {
                            re[j] += wood_re[j];
                            im[j] += wood_im[j];
                        }
                    }
                    let mut y = Vec::new();
                    if with_impulse {
                        y = budget::filled(n, 0.0, "the impulse response")?;
                        impulse_from_band(n, sonar.k0, &re, &im, &mut y);
                    }
                    check_finite(i, &re, &im, &y, sonar)?;
                    Ok(HeardEcho {
                        re,
                        im,
                        y,
                        n_leaves,
                        wood_re,
                        wood_im,
                        n_pieces: pc.len() as u64,
                    })
                })
                .collect::<Result<Vec<HeardEcho>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    let what = "simulate's output";
    let records = poses.len().saturating_mul(r);
    let mut out = Echoes {
        n_bins: m,
        n_receivers: r,
        spectrum_re: budget::with_capacity(records.saturating_mul(m), what)?,
        spectrum_im: budget::with_capacity(records.saturating_mul(m), what)?,
        impulse: budget::with_capacity(
            if with_impulse {
                records.saturating_mul(n)
            } else {
                0
            },
            what,
        )?,
        n_leaves: budget::with_capacity(records, what)?,
        wood_re: budget::with_capacity(if wood { records.saturating_mul(m) } else { 0 }, what)?,
        wood_im: budget::with_capacity(if wood { records.saturating_mul(m) } else { 0 }, what)?,
        n_pieces: budget::with_capacity(records, what)?,
        n_shaded: budget::filled(poses.len(), 0, what)?,
    };
    for e in per_pose.into_iter().flatten() {
        out.spectrum_re.extend_from_slice(&e.re);
        out.spectrum_im.extend_from_slice(&e.im);
        out.impulse.extend_from_slice(&e.y);
        out.n_leaves.push(e.n_leaves);
        out.wood_re.extend_from_slice(&e.wood_re);
        out.wood_im.extend_from_slice(&e.wood_im);
        out.n_pieces.push(e.n_pieces);
    }
    Ok(out)
}

/// The largest delay range `(r_tx + r_rx) / 2` (m) of a counting leaf or piece over the receivers, per
/// pose (0 where none counts), poses in parallel; the same errors as [`simulate_heard`].
pub fn farthest_heard(
    scene: &Scene,
    sonar: &Sonar,
    poses: &[Pose],
    search: Search,
) -> Result<Vec<f64>> {
    poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            let rxs = place_receivers(sonar, pose);
            let cands = candidates_heard(scene, sonar, pose, &rxs, search);
            let terms = heard_terms(scene, sonar, pose, i, &rxs, &cands)?;
            let far = terms.iter().flatten().fold(0.0f64, |a, t| a.max(t.range));
            terms.into_iter().for_each(give_terms);
            let pieces = branch_members_heard(scene, sonar, pose, i, &rxs)?;
            Ok(pieces
                .iter()
                .flatten()
                .fold(far, |a, p| a.max(p.heard.range())))
        })
        .collect()
}

/// The stored indices (ascending) of the leaves that count for receiver `k` of one pose.
pub fn heard_members(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    search: Search,
    k: usize,
) -> Result<Vec<u32>> {
    let rxs = place_receivers(sonar, pose);
    let rx = &rxs[k..=k];
    let cands = candidates_heard(scene, sonar, pose, rx, search);
    let ids = crate::echo::receivers::heard_members(scene, sonar, pose, 0, rx, &cands);
    match ids {
        Ok(mut ids) => Ok(ids.pop().expect("one receiver")),
        // (the error names the receiver by its index in the sonar)
        Err(crate::error::Error::TooCloseToReceiver {
            pose,
            leaf,
            range,
            min_range,
            ..
        }) => Err(crate::error::Error::TooCloseToReceiver {
            pose,
            receiver: k,
            leaf,
            range,
            min_range,
        }),
        Err(e) => Err(e),
    }
}
