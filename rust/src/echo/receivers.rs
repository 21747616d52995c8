//! Terms per receiver (docs/model.md §5a): one pass over a pose's candidates that tests each
//! leaf from the emitter once and from every receiver, and makes each counting leaf's term for
//! each receiver that hears it.
//!
//! A scatterer's term for a receiver takes from the geometry only what [`heard_amplitude`]
//! and [`Heard::range`] give (the same for any scatterer) and its incidence from the bisector
//! of the two directions ([`bisector_incidence`] for a leaf's normal); so the term of any
//! other kind of scatterer is made per receiver by the same two calls.
use crate::echo::term::LeafTerm;
use crate::echo::term_pool::take_terms;
use crate::error::{Error, Result};
use crate::lobe::candidates::Candidates;
use crate::lobe::receivers_block::{emitter_lanes, heard_lanes, EmitterLanes, HeardLanes};
use crate::lobe::CB;
use crate::lobe::{classify_heard, emitter_side, Heard, HeardDecision, PlacedReceiver};
use crate::physics::amplitude::bistatic_echo_amplitude;
use crate::physics::bistatic::{bisector_incidence, delay_range};
use crate::scene::Scene;
use crate::sonar::{Sonar, TooClose};
use multiversion::multiversion;
use rayon::prelude::*;

/// Candidates per parallel task of the pass.
const HEARD_CHUNK: usize = 512;

/// The amplitude `g S_tx S_rx / (r_tx r_rx)` (or `g S_tx S_rx`) of a scatterer heard by a
/// receiver, before the scatterer's own factor.
#[inline(always)]
pub fn heard_amplitude(sonar: &Sonar, h: &Heard) -> f64 {
    let p = &sonar.params;
    bistatic_echo_amplitude(p.gain, h.gain, h.tx.range, h.rx.range, p.spreading)
}

/// The term of stored leaf `i` heard as `h`: the bistatic amplitude, the delay range, the
/// incidence from the bisector, the radius powers.
#[inline]
pub fn heard_leaf_term(sonar: &Sonar, scene: &Scene, i: u32, h: &Heard) -> LeafTerm {
    let i = i as usize;
    let (beta, cos_beta, sin_beta) = bisector_incidence(h.tx.dir, h.rx.dir, scene.normals.get(i));
    LeafTerm {
        amp: heard_amplitude(sonar, h),
        range: h.range(),
        beta,
        cos_beta,
        sin_beta,
        radius: scene.radii[i],
        radius_pow_b: scene.radius_pow_b[i],
        radius_pow_p: scene.radius_pow_p[i],
    }
}

/// A too-close leaf: (caller's index, range, the receiver or None for the emitter).
type Near = (usize, f64, Option<usize>);

/// The earlier of two too-close leaves: the smaller caller index, the emitter before the
/// receivers, then the receivers in order.
fn first_near(a: Option<Near>, b: Near) -> Option<Near> {
    match a {
        Some(x) if (x.0, x.2.map_or(0, |r| r + 1)) <= (b.0, b.2.map_or(0, |r| r + 1)) => Some(x),
        _ => Some(b),
    }
}

/// One task's share: per receiver the stored indices and terms of its counting leaves, in
/// candidate order; the first too-close leaf.
struct Part {
    ids: Vec<Vec<u32>>,
    terms: Vec<Vec<LeafTerm>>,
    near: Option<Near>,
}

/// The exact test of the candidates at positions `span` for every receiver, [`CB`] at a time:
/// the emitter's side once per block, each receiver's lanes, libm where a lane is near a
/// boundary ([`classify_heard`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn heard_chunk(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
    span: std::ops::Range<usize>,
) -> Part {
    let len = span.len();
    let mut part = Part {
        ids: (0..rxs.len()).map(|_| Vec::with_capacity(len)).collect(),
        terms: (0..rxs.len()).map(|_| Vec::with_capacity(len)).collect(),
        near: None,
    };
    let sp = &sonar.params;
    let (mut em, mut hl) = (EmitterLanes::default(), HeardLanes::default());
    let mut blocks = cands.blocks(span);
    while let Some((block, consecutive)) = blocks.next_block() {
        let n = block.len();
        emitter_lanes(scene, sonar, pose, block, consecutive, &mut em);
        let mut tx_ok = [true; CB];
        for (k, &i) in block.iter().enumerate() {
            if !(em.r[k] >= sp.min_range) {
                tx_ok[k] = false;
                part.near = first_near(part.near, (scene.ids[i as usize] as usize, em.r[k], None));
            }
        }
        for (j, rx) in rxs.iter().enumerate() {
            heard_lanes(sonar, pose, rx, &em, n, &mut hl);
            for (k, &i) in block.iter().enumerate() {
                if !tx_ok[k] {
                    continue;
                }
                if !(hl.r_rx[k] >= sp.min_range) {
                    let id = scene.ids[i as usize] as usize;
                    part.near = first_near(part.near, (id, hl.r_rx[k], Some(j)));
                    continue;
                }
                let t = match hl.verdict[k] {
                    0 => continue,
                    1 => {
                        let (r_tx, r_rx) = (em.r[k], hl.r_rx[k]);
                        let at = i as usize;
                        LeafTerm {
                            amp: bistatic_echo_amplitude(
                                sp.gain,
                                hl.gain[k],
                                r_tx,
                                r_rx,
                                sp.spreading,
                            ),
                            range: delay_range(r_tx, r_rx),
                            beta: hl.beta[k],
                            cos_beta: hl.cos_beta[k],
                            sin_beta: hl.sin_beta[k],
                            radius: scene.radii[at],
                            radius_pow_b: scene.radius_pow_b[at],
                            radius_pow_p: scene.radius_pow_p[at],
                        }
                    }
                    _ => {
                        // near the lobe's boundary: the libm decision
                        let center = scene.centers.get(i as usize);
                        let Ok(tx) = emitter_side(sonar, pose, center) else {
                            continue;
                        };
                        match classify_heard(sonar, pose, rx, center, &tx) {
                            HeardDecision::In(h) => heard_leaf_term(sonar, scene, i, &h),
                            _ => continue,
                        }
                    }
                };
                part.ids[j].push(i);
                part.terms[j].push(t);
            }
        }
    }
    part
}

/// The terms of the counting leaves of one pose for each receiver of `rxs` (stored-index
/// order within each), from the pose's candidates. Candidates are tested in parallel chunks
/// of fixed length, in order, so the result does not depend on the number of threads. A leaf
/// closer than `min_range` to the emitter or a receiver is an error naming the smallest
/// caller index (unless `too_close` skips it). `pose_index` only labels errors. The lists may
/// go back to [`crate::echo::term_pool::give_terms`] when done with.
pub fn heard_terms(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
) -> Result<Vec<Vec<LeafTerm>>> {
    Ok(heard_pass(scene, sonar, pose, pose_index, rxs, cands)?.1)
}

/// The counting leaves (stored indices, ascending) of one pose for each receiver of `rxs`;
/// the same test and errors as [`heard_terms`].
pub fn heard_members(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
) -> Result<Vec<Vec<u32>>> {
    let mut out = heard_pass(scene, sonar, pose, pose_index, rxs, cands)?.0;
    for ids in &mut out {
        ids.sort_unstable();
    }
    Ok(out)
}

/// Per receiver, the counting leaves' stored indices and terms.
type Heard2 = (Vec<Vec<u32>>, Vec<Vec<LeafTerm>>);

fn heard_pass(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
) -> Result<Heard2> {
    let n = cands.len();
    let parts: Vec<Part> = (0..n.div_ceil(HEARD_CHUNK))
        .into_par_iter()
        .map(|c| {
            let span = c * HEARD_CHUNK..n.min((c + 1) * HEARD_CHUNK);
            heard_chunk(scene, sonar, pose, rxs, cands, span)
        })
        .collect();
    if sonar.params.too_close == TooClose::Error {
        let near = parts.iter().filter_map(|p| p.near).fold(None, first_near);
        if let Some((leaf, range, who)) = near {
            let min_range = sonar.params.min_range;
            return Err(match who {
                None => Error::TooClose {
                    pose: pose_index,
                    leaf,
                    range,
                    min_range,
                },
                Some(receiver) => Error::TooCloseToReceiver {
                    pose: pose_index,
                    receiver,
                    leaf,
                    range,
                    min_range,
                },
            });
        }
    }
    let total = |k: usize| parts.iter().map(|p| p.ids[k].len()).sum::<usize>();
    let mut ids: Vec<Vec<u32>> = (0..rxs.len())
        .map(|k| Vec::with_capacity(total(k)))
        .collect();
    let mut terms: Vec<Vec<LeafTerm>> = (0..rxs.len()).map(|k| take_terms(total(k))).collect();
    for part in parts {
        for (k, (i, t)) in part.ids.into_iter().zip(part.terms).enumerate() {
            ids[k].extend(i);
            terms[k].extend(t);
        }
    }
    Ok((ids, terms))
}
