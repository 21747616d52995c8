//! Echoes for receivers at their own places (docs/model.md §5a): per pose, one lobe query for
//! all receivers (the union of their lobes), one pass over the candidates that makes every
//! receiver's terms, with shading their factors (§10: one cast from the emitter, one from
//! each receiver), then each receiver's band spectrum and impulse response.
use crate::budget;
use crate::echo::impulse::impulse_from_band;
use crate::echo::receivers::{heard_pass, heard_terms};
use crate::echo::spectrum::sum_terms;
use crate::echo::LeafTerm;
use crate::error::Result;
use crate::fast::{fast_sum_terms, FastPlan, FastSonar};
use crate::lobe::{candidates_heard, place_receivers, PlacedReceiver, Search};
use crate::physics::pose::Pose;
use crate::physics::shading::two_way_shading_factor;
use crate::scene::Scene;
use crate::shade::{cast, Target};
use crate::simulate::{check_finite, cost_exact, cost_fast, Echoes, Method};
use crate::sonar::Shading;
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
    // Per pose and receiver: spectrum (re, im), impulse, numbers of counting and shaded leaves.
    type Heard = Vec<(Vec<f64>, Vec<f64>, Vec<f64>, u64, u64)>;
    let per_pose: Vec<Heard> = poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            let rxs = place_receivers(sonar, pose);
            let cands = candidates_heard(scene, sonar, pose, &rxs, search);
            let (ids, mut terms) = heard_pass(scene, sonar, pose, i, &rxs, &cands)?;
            let counts: Vec<u64> = terms.iter().map(|t| t.len() as u64).collect();
            let shaded = match sonar.params.shading {
                Some(sh) => shade_heard(scene, sh, pose.position, &rxs, &ids, &mut terms),
                None => vec![0; rxs.len()],
            };
            terms
                .iter()
                .zip(counts.iter().zip(&shaded))
                .map(|(t, (&count, &shaded))| {
                    let (re, im) = receiver_spectrum(sonar, method, plan.as_deref(), t);
                    let mut y = Vec::new();
                    if with_impulse {
                        y = budget::filled(n, 0.0, "the impulse response")?;
                        impulse_from_band(n, sonar.k0, &re, &im, &mut y);
                    }
                    check_finite(i, &re, &im, &y, sonar)?;
                    Ok((re, im, y, count, shaded))
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
        n_shaded: budget::with_capacity(records, what)?,
    };
    for (re, im, y, c, shaded) in per_pose.into_iter().flatten() {
        out.spectrum_re.extend_from_slice(&re);
        out.spectrum_im.extend_from_slice(&im);
        out.impulse.extend_from_slice(&y);
        out.n_leaves.push(c);
        out.n_shaded.push(shaded);
    }
    Ok(out)
}

/// Shade each receiver's terms (docs/model.md §10): a leaf heard by receiver `k` is
/// multiplied by `tau^(m_out + m_back)`, `m_out` the leaf disks crossed by the open segment
/// from the emitter at `origin` to it, `m_back` those crossed by the one from the receiver,
/// and is dropped when a branch blocks either (with `branches_block`). The rays from the
/// emitter are cast once for the leaves any receiver hears; each receiver casts its own (its
/// rays share its position). Returns, per receiver, how many of its leaves were dimmed or
/// silenced.
fn shade_heard(
    scene: &Scene,
    sh: Shading,
    origin: crate::math::vec3::V3,
    rxs: &[PlacedReceiver],
    ids: &[Vec<u32>],
    terms: &mut [Vec<LeafTerm>],
) -> Vec<u64> {
    let target = |&i: &u32| Target::Leaf {
        point: scene.centers.get(i as usize),
        leaf: i,
    };
    let mut heard: Vec<u32> = ids.iter().flatten().copied().collect();
    heard.sort_unstable();
    heard.dedup();
    let targets: Vec<Target> = heard.iter().map(target).collect();
    let out = cast(scene, origin, &targets, sh.branches_block);
    rxs.iter()
        .zip(ids.iter().zip(terms.iter_mut()))
        .map(|(rx, (ids, terms))| {
            let targets: Vec<Target> = ids.iter().map(target).collect();
            let back = cast(scene, rx.position, &targets, sh.branches_block);
            let mut shaded = 0u64;
            let mut silenced = Vec::with_capacity(terms.len());
            for ((t, i), b) in terms.iter_mut().zip(ids).zip(&back) {
                let o = out[heard.binary_search(i).expect("a heard leaf")];
                let f = two_way_shading_factor(
                    sh.leaf_transmission,
                    o.crossings,
                    b.crossings,
                    o.blocked || b.blocked,
                );
                if f != 1.0 {
                    shaded += 1;
                    t.amp *= f;
                }
                silenced.push(f == 0.0);
            }
            // (a silenced leaf adds nothing: left out of the sum)
            let mut gone = silenced.into_iter();
            terms.retain(|_| !gone.next().expect("one flag a term"));
            shaded
        })
        .collect()
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
            Ok(terms.iter().flatten().fold(0.0f64, |a, t| a.max(t.range)))
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
