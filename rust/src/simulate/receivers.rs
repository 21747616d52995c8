//! Echoes for receivers at their own places (docs/model.md §5a): per pose, one lobe query for
//! all receivers (the union of their lobes), one pass over the candidates that makes every
//! receiver's terms, then each receiver's band spectrum and impulse response.
use crate::budget;
use crate::echo::impulse::impulse_from_band;
use crate::echo::receivers::heard_terms;
use crate::echo::spectrum::sum_terms;
use crate::echo::term_pool::give_terms;
use crate::echo::LeafTerm;
use crate::error::Result;
use crate::fast::{fast_sum_terms, FastPlan, FastSonar};
use crate::lobe::{candidates_heard, place_receivers, Search};
use crate::physics::pose::Pose;
use crate::scene::Scene;
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

/// Echoes of every pose for every receiver of `sonar` (which has some), poses in parallel:
/// spectra `(p, R, M)`, impulses `(p, R, n)`, counts `(p, R)`.
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
    // Per pose and receiver: spectrum (re, im), impulse, number of counting leaves.
    type Heard = Vec<(Vec<f64>, Vec<f64>, Vec<f64>, u64)>;
    let per_pose: Vec<Heard> = poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            let rxs = place_receivers(sonar, pose);
            let cands = candidates_heard(scene, sonar, pose, &rxs, search);
            let terms = heard_terms(scene, sonar, pose, i, &rxs, &cands)?;
            // The receivers' sums side by side: each is the same whatever runs beside it (its
            // chunks are fixed), and one's serial steps (the transforms) overlap the other's
            // spreading.
            terms
                .into_par_iter()
                .map(|t| {
                    let (re, im) = receiver_spectrum(sonar, method, plan.as_deref(), &t);
                    let count = t.len() as u64;
                    give_terms(t);
                    let mut y = Vec::new();
                    if with_impulse {
                        y = budget::filled(n, 0.0, "the impulse response")?;
                        impulse_from_band(n, sonar.k0, &re, &im, &mut y);
                    }
                    check_finite(i, &re, &im, &y, sonar)?;
                    Ok((re, im, y, count))
                })
                .collect::<Result<Heard>>()
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
        wood_re: Vec::new(),
        wood_im: Vec::new(),
        n_pieces: budget::filled(poses.len(), 0, what)?,
        n_shaded: budget::filled(poses.len(), 0, what)?,
    };
    for (re, im, y, c) in per_pose.into_iter().flatten() {
        out.spectrum_re.extend_from_slice(&re);
        out.spectrum_im.extend_from_slice(&im);
        out.impulse.extend_from_slice(&y);
        out.n_leaves.push(c);
    }
    Ok(out)
}

/// The largest delay range `(r_tx + r_rx) / 2` (m) of a counting leaf over the receivers, per
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
            Ok(far)
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
