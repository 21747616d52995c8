//! Echoes for receivers at their own places (docs/model.md §5a, §9, §10): per pose, one lobe
//! query for all receivers (the union of their lobes), one pass over the candidates that makes
//! every receiver's terms, the branch pieces each receiver hears, with shading their factors
//! (one cast from the emitter, one from each receiver), then each receiver's band spectrum
//! (leaves and wood) and impulse response.
use crate::budget;
use crate::echo::impulse::impulse_from_band;
use crate::echo::receivers::{heard_pass, heard_terms};
use crate::echo::spectrum::sum_terms;
use crate::echo::term_pool::give_terms;
use crate::echo::LeafTerm;
use crate::echo::{heard_branch_term, BranchTerm};
use crate::error::Result;
use crate::fast::{fast_sum_terms, FastPlan, FastSonar};
use crate::interrupt::Interrupt;
use crate::lobe::HeardPiece;
use crate::lobe::{
    branch_members_heard, candidates_heard, place_receivers, PlacedReceiver, Search,
};
use crate::physics::pose::Pose;
use crate::physics::shading::two_way_shading_factor;
use crate::scene::Scene;
use crate::shade::{cast, Target};
use crate::simulate::scatter::wood_spectrum;
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

/// One receiver's echo of one pose: the windowed band spectrum, the impulse response (empty
/// when not asked for), the counting leaves, the wood's share of the spectrum (empty without
/// branches), the counting branch pieces and the counting leaves shading dims or silences.
struct HeardEcho {
    re: Vec<f64>,
    im: Vec<f64>,
    y: Vec<f64>,
    n_leaves: u64,
    wood_re: Vec<f64>,
    wood_im: Vec<f64>,
    n_pieces: u64,
    n_shaded: u64,
}

/// Echoes of every pose for every receiver of `sonar` (which has some), poses in parallel:
/// spectra `(p, R, M)`, impulses `(p, R, n)`, counts `(p, R)`; with branches the wood's
/// spectra `(p, R, M)` and the counting pieces `(p, R)`; the shaded leaves `(p, R)`. `plan` is
/// that of each part's share of `tol`.
pub fn simulate_heard(
    scene: &Scene,
    sonar: &FastSonar,
    poses: &[Pose],
    with_impulse: bool,
    (search, method): (Search, Method),
    plan: Option<Arc<FastPlan>>,
    stop: &Interrupt,
) -> Result<Echoes> {
    let m = sonar.n_bins();
    let n = sonar.params.n_samples;
    let r = sonar.params.receivers.len();
    let wood = !scene.branches.is_empty();
    let per_pose: Vec<Vec<HeardEcho>> = poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            stop.check()?;
            let rxs = place_receivers(sonar, pose);
            let cands = candidates_heard(scene, sonar, pose, &rxs, search);
            let (ids, mut terms) = heard_pass(scene, sonar, pose, i, &rxs, &cands)?;
            let counts: Vec<u64> = terms.iter().map(|t| t.len() as u64).collect();
            let pieces = branch_members_heard(scene, sonar, pose, i, &rxs)?;
            let mut wood_terms: Vec<Vec<BranchTerm>> = pieces
                .iter()
                .map(|pc| pc.iter().map(|p| heard_branch_term(sonar, p)).collect())
                .collect();
            let shaded = match sonar.params.shading {
                Some(sh) => {
                    let sight = Sight {
                        scene,
                        sh,
                        rxs: &rxs,
                    };
                    sight.shade(pose.position, &ids, &mut terms, &pieces, &mut wood_terms)
                }
                None => vec![0; rxs.len()],
            };
            // The receivers' sums side by side: each is the same whatever runs beside it (its
            // chunks are fixed), and one's serial steps (the transforms) overlap the other's
            // spreading.
            let n_pieces: Vec<u64> = pieces.iter().map(|pc| pc.len() as u64).collect();
            terms
                .into_par_iter()
                .zip(wood_terms)
                .zip(counts.into_par_iter().zip(n_pieces).zip(shaded))
                .map(|((t, wt), ((n_leaves, n_pieces), n_shaded))| {
                    let (mut re, mut im) = receiver_spectrum(sonar, method, plan.as_deref(), &t);
                    give_terms(t);
                    let (mut wood_re, mut wood_im) = (Vec::new(), Vec::new());
                    if wood {
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
                        n_pieces,
                        n_shaded,
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
        n_shaded: budget::with_capacity(records, what)?,
    };
    for e in per_pose.into_iter().flatten() {
        out.spectrum_re.extend_from_slice(&e.re);
        out.spectrum_im.extend_from_slice(&e.im);
        out.impulse.extend_from_slice(&e.y);
        out.n_leaves.push(e.n_leaves);
        out.wood_re.extend_from_slice(&e.wood_re);
        out.wood_im.extend_from_slice(&e.wood_im);
        out.n_pieces.push(e.n_pieces);
        out.n_shaded.push(e.n_shaded);
    }
    Ok(out)
}

/// What shading needs of one pose: the scene, the shading and the placed receivers.
struct Sight<'a> {
    scene: &'a Scene,
    sh: Shading,
    rxs: &'a [PlacedReceiver<'a>],
}

impl Sight<'_> {
    /// A leaf's ray target.
    fn leaf(&self, i: u32) -> Target {
        Target::Leaf {
            point: self.scene.centers.get(i as usize),
            leaf: i,
        }
    }

    /// Shade each receiver's terms (docs/model.md §10): a leaf or piece heard by receiver `k`
    /// is multiplied by `tau^(m_out + m_back)`, `m_out` the leaf disks crossed by the open
    /// segment from the emitter at `origin` to it (a piece: to its reference point for that
    /// receiver), `m_back` those crossed by the one from the receiver, and is dropped when a
    /// branch blocks either (with `branches_block`). The emitter's rays are cast once, for the
    /// leaves any receiver hears and every receiver's pieces; each receiver casts its own (its
    /// rays share its position). Returns, per receiver, how many of its leaves were dimmed or
    /// silenced.
    fn shade(
        &self,
        origin: crate::math::vec3::V3,
        ids: &[Vec<u32>],
        terms: &mut [Vec<LeafTerm>],
        pieces: &[Vec<HeardPiece>],
        wood: &mut [Vec<BranchTerm>],
    ) -> Vec<u64> {
        let piece = |p: &HeardPiece| Target::Piece {
            point: p.reference,
            segment: p.segment,
        };
        let mut heard: Vec<u32> = ids.iter().flatten().copied().collect();
        heard.sort_unstable();
        heard.dedup();
        let targets: Vec<Target> = heard
            .iter()
            .map(|&i| self.leaf(i))
            .chain(pieces.iter().flatten().map(piece))
            .collect();
        let out = cast(self.scene, origin, &targets, self.sh.branches_block);
        let (out_leaves, mut out_pieces) = out.split_at(heard.len());
        let factor = |o: crate::shade::Sight, b: crate::shade::Sight| {
            two_way_shading_factor(
                self.sh.leaf_transmission,
                o.crossings,
                b.crossings,
                o.blocked || b.blocked,
            )
        };
        let mut shaded_per_receiver = Vec::with_capacity(self.rxs.len());
        for (k, rx) in self.rxs.iter().enumerate() {
            let (ids, terms, pc, wt) = (&ids[k], &mut terms[k], &pieces[k], &mut wood[k]);
            let targets: Vec<Target> = ids
                .iter()
                .map(|&i| self.leaf(i))
                .chain(pc.iter().map(piece))
                .collect();
            let back = cast(self.scene, rx.position, &targets, self.sh.branches_block);
            let (back_leaves, back_pieces) = back.split_at(ids.len());
            let mut shaded = 0u64;
            let mut silenced = Vec::with_capacity(terms.len());
            for ((t, i), &b) in terms.iter_mut().zip(ids).zip(back_leaves) {
                let f = factor(out_leaves[heard.binary_search(i).expect("a heard leaf")], b);
                if f != 1.0 {
                    shaded += 1;
                    t.amp *= f;
                }
                silenced.push(f == 0.0);
            }
            // (a silenced leaf adds nothing: left out of the sum)
            let mut gone = silenced.into_iter();
            terms.retain(|_| !gone.next().expect("one flag a term"));
            let (mine, rest) = out_pieces.split_at(pc.len());
            out_pieces = rest;
            for ((t, &o), &b) in wt.iter_mut().zip(mine).zip(back_pieces) {
                t.amp *= factor(o, b);
            }
            wt.retain(|t| t.amp != 0.0);
            shaded_per_receiver.push(shaded);
        }
        shaded_per_receiver
    }
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
