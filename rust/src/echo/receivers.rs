//! Terms per receiver (docs/model.md §5a): one pass over a pose's candidates that tests each
//! leaf from the emitter once and from every receiver, and makes each counting leaf's term for
//! each receiver that hears it.
//!
//! A scatterer's term for a receiver takes from the geometry only what [`heard_amplitude`]
//! and [`Heard::range`] give (the same for any scatterer) and its incidence from the bisector
//! of the two directions ([`bisector_incidence`] for a leaf's normal); so the term of any
//! other kind of scatterer is made per receiver by the same two calls.
use crate::echo::term::LeafTerm;
use crate::error::{Error, Result};
use crate::lobe::candidates::Candidates;
use crate::lobe::{classify_heard, emitter_side, Heard, HeardDecision, PlacedReceiver};
use crate::physics::amplitude::bistatic_echo_amplitude;
use crate::physics::bistatic::bisector_incidence;
use crate::scene::Scene;
use crate::sonar::{Sonar, TooClose};
use rayon::prelude::*;

/// Candidates per parallel task of the pass.
const HEARD_CHUNK: usize = 2048;

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

/// One task's share: per receiver its items, in candidate order; the first too-close leaf.
struct Part<T> {
    terms: Vec<Vec<T>>,
    near: Option<Near>,
}

fn heard_chunk<T>(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
    span: std::ops::Range<usize>,
    make: &(impl Fn(u32, &Heard) -> T + Sync),
) -> Part<T> {
    let mut part = Part {
        terms: (0..rxs.len()).map(|_| Vec::new()).collect(),
        near: None,
    };
    let mut blocks = cands.blocks(span);
    while let Some((block, _)) = blocks.next_block() {
        for &i in block {
            let center = scene.centers.get(i as usize);
            let id = scene.ids[i as usize] as usize;
            let tx = match emitter_side(sonar, pose, center) {
                Ok(tx) => tx,
                Err(r) => {
                    part.near = first_near(part.near, (id, r, None));
                    continue;
                }
            };
            for (k, rx) in rxs.iter().enumerate() {
                match classify_heard(sonar, pose, rx, center, &tx) {
                    HeardDecision::In(h) => {
                        part.terms[k].push(make(i, &h));
                    }
                    HeardDecision::TooClose(r) => {
                        part.near = first_near(part.near, (id, r, Some(k)));
                    }
                    HeardDecision::Out => {}
                }
            }
        }
    }
    part
}

/// The terms of the counting leaves of one pose for each receiver of `rxs` (stored-index
/// order within each), from the pose's candidates. Candidates are tested in parallel chunks
/// of fixed length, in order, so the result does not depend on the number of threads. A leaf
/// closer than `min_range` to the emitter or a receiver is an error naming the smallest
/// caller index (unless `too_close` skips it). `pose_index` only labels errors.
pub fn heard_terms(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
) -> Result<Vec<Vec<LeafTerm>>> {
    let make = |i: u32, h: &Heard| heard_leaf_term(sonar, scene, i, h);
    heard_pass(scene, sonar, pose, pose_index, rxs, cands, &make)
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
    let mut out = heard_pass(
        scene,
        sonar,
        pose,
        pose_index,
        rxs,
        cands,
        &|i, _: &Heard| i,
    )?;
    for ids in &mut out {
        ids.sort_unstable();
    }
    Ok(out)
}

/// [`heard_terms`] with `make` turning each counting (leaf, receiver) into an item.
fn heard_pass<T: Send>(
    scene: &Scene,
    sonar: &Sonar,
    pose: &crate::physics::pose::Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
    cands: &Candidates,
    make: &(impl Fn(u32, &Heard) -> T + Sync),
) -> Result<Vec<Vec<T>>> {
    let n = cands.len();
    let parts: Vec<Part<T>> = (0..n.div_ceil(HEARD_CHUNK))
        .into_par_iter()
        .map(|c| {
            let span = c * HEARD_CHUNK..n.min((c + 1) * HEARD_CHUNK);
            heard_chunk(scene, sonar, pose, rxs, cands, span, make)
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
    let mut out: Vec<Vec<T>> = (0..rxs.len())
        .map(|k| Vec::with_capacity(parts.iter().map(|p| p.terms[k].len()).sum()))
        .collect();
    for part in parts {
        for (o, t) in out.iter_mut().zip(part.terms) {
            o.extend(t);
        }
    }
    Ok(out)
}
