//! Which branch pieces count for receivers at their own places (docs/model.md §9, "Heard by a
//! receiver of its own"): each segment is cut once for all receivers, by the rule of
//! [`max_piece_length`] at its nearest distance from the emitter or any receiver; each piece
//! lit from the emitter is referred, per receiver, to the point of its centre's cross-section
//! that makes `r_tx + r_rx` least ([`bistatic_piece_sight`]), and goes through the receivers'
//! exact lobe test ([`classify_heard`]) there.
use crate::error::{Error, Result};
use crate::lobe::receivers::{classify_heard, emitter_side, Heard, HeardDecision, PlacedReceiver};
use crate::math::vec3::V3;
use crate::physics::bistatic::{bistatic_piece_sight, BistaticSight};
use crate::physics::branch::{
    distance_to_segment, max_piece_length, piece_count, piece_sight, PieceSight,
};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{Sonar, TooClose};
use rayon::prelude::*;

use super::pieces::{block_box, check_pieces, visit_spans, MAX_PIECES};
use crate::lobe::bound::BoxTest;
use crate::lobe::receivers_bound::test_box_heard;

/// One counting branch piece for one receiver: its segment, the reference point of its echo,
/// the emitter's and the receiver's views there, its length and radius, the tilt of its axis
/// from the bisector's broadside, and `cos(beta/2)` of the bistatic angle `beta`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeardPiece {
    pub segment: u32,
    pub reference: V3,
    pub heard: Heard,
    pub length: f64,
    pub radius: f64,
    pub cos_gamma: f64,
    pub sin_gamma: f64,
    pub cos_half_bistatic: f64,
}

/// A too-close piece: its segment, the distance, the receiver (None: the emitter).
type Close = (usize, f64, Option<usize>);

/// Segments per parallel task.
const SEGMENT_CHUNK: usize = 256;

/// The smallest Gaussian width (rad) of the emitter's and the receivers' patterns.
fn narrowest_sigma(sonar: &Sonar, rxs: &[PlacedReceiver]) -> f64 {
    let e = &sonar.params.emitter;
    rxs.iter().fold(e.sigma_x.min(e.sigma_y), |s, r| {
        s.min(r.beam.sigma_x).min(r.beam.sigma_y)
    })
}

/// Half the largest distance of a receiver from the emitter (m): a delay range
/// `(r_tx + r_rx)/2` is at least `r_tx` less this.
fn half_offset(pose: &Pose, rxs: &[PlacedReceiver]) -> f64 {
    rxs.iter().fold(0.0f64, |m, rx| {
        let o = crate::math::vec3::sub(rx.position, pose.position);
        m.max(0.5 * crate::math::vec3::norm(o))
    })
}

/// How segment `i` is cut for the pose and receivers: the distances of its surface from the
/// emitter and from the emitter or the nearest receiver, and its number of pieces; None where
/// it lies beyond the reach.
fn cut_heard(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    rxs: &[PlacedReceiver],
    i: usize,
) -> Option<(f64, f64, usize)> {
    let br = &scene.branches;
    let (a, b, radius) = (br.starts[i], br.ends[i], br.radii[i]);
    let sp = &sonar.params;
    let near_tx = distance_to_segment(pose.position, a, b) - radius;
    let near = rxs.iter().fold(near_tx, |m, rx| {
        m.min(distance_to_segment(rx.position, a, b) - radius)
    });
    if near_tx - half_offset(pose, rxs) > sonar.max_reach() {
        return None;
    }
    let k_max = sonar.wavenumbers[sonar.wavenumbers.len() - 1];
    let max_len = max_piece_length(
        near.max(sp.min_range),
        k_max,
        narrowest_sigma(sonar, rxs),
        sp.branch_piece_scale,
    );
    Some((near_tx, near, piece_count(br.lengths[i], max_len)))
}

/// Per receiver, the pieces of segment `i` that count, appended to `out[j]`; the first
/// too-close one (segment, distance, the receiver or None for the emitter) into `too_close`.
fn segment_pieces_heard(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    rxs: &[PlacedReceiver],
    i: usize,
    out: &mut [Vec<HeardPiece>],
    too_close: &mut Option<Close>,
) -> Result<()> {
    let Some((near_tx, near, n)) = cut_heard(scene, sonar, pose, rxs, i) else {
        return Ok(());
    };
    if n > MAX_PIECES {
        return Err(Error::InvalidInput(format!(
            "branch {i} would need {n} pieces at {near:.3e} m from the sonar or a receiver (at \
             most {MAX_PIECES}, with branch_piece_scale = {}); raise min_range_m or \
             branch_piece_scale, or keep the sonar farther from it",
            sonar.params.branch_piece_scale
        )));
    }
    let br = &scene.branches;
    let (a, b, radius) = (br.starts[i], br.ends[i], br.radii[i]);
    let sp = &sonar.params;
    let half_offset = half_offset(pose, rxs);
    let length = br.lengths[i];
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let (u, piece_len) = (br.axes[i], length / n as f64);
    let mut note_close = |r: f64, who: Option<usize>| {
        if too_close.is_none() {
            *too_close = Some((i, r, who));
        }
    };
    // Spans of pieces whose box lies beyond the reach or outside every receiver's lobe hold no
    // piece that counts or is too close: skipped whole (the pieces that count are the same),
    // the whole segment first.
    let span_out = |k0: usize, k1: usize| {
        let (lo, hi, s0, s1) = block_box(a, d, n, k0, k1, radius);
        let near_tx = distance_to_segment(pose.position, s0, s1) - radius;
        if near_tx - half_offset > sonar.max_reach() {
            return true;
        }
        let near = rxs.iter().fold(near_tx, |m, rx| {
            m.min(distance_to_segment(rx.position, s0, s1) - radius)
        });
        near >= sp.min_range && test_box_heard(sonar, pose, rxs, lo, hi) == BoxTest::Outside
    };
    visit_spans(0, n, &span_out, &mut |k| {
        let t = (2 * k + 1) as f64 / (2 * n) as f64;
        let c = [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
        match piece_sight(pose.position, c, u, radius, piece_len) {
            PieceSight::Inside => {
                note_close(near_tx.min(0.0), None);
                return;
            }
            PieceSight::EndOn => return,
            PieceSight::Lit { .. } => {}
        }
        for (j, rx) in rxs.iter().enumerate() {
            let sight = bistatic_piece_sight(pose.position, rx.position, c, u, radius, piece_len);
            let BistaticSight::Lit {
                reference,
                cos_gamma,
                sin_gamma,
                cos_half_bistatic,
            } = sight
            else {
                if sight == BistaticSight::Inside {
                    note_close(0.0, Some(j));
                }
                continue;
            };
            let tx = match emitter_side(sonar, pose, reference) {
                Ok(tx) => tx,
                Err(r) => {
                    note_close(r, None);
                    continue;
                }
            };
            match classify_heard(sonar, pose, rx, reference, &tx) {
                HeardDecision::In(heard) => out[j].push(HeardPiece {
                    segment: i as u32,
                    reference,
                    heard,
                    length: piece_len,
                    radius,
                    cos_gamma,
                    sin_gamma,
                    cos_half_bistatic,
                }),
                HeardDecision::TooClose(r) => note_close(r, Some(j)),
                HeardDecision::Out => {}
            }
        }
    });
    Ok(())
}

/// Per receiver of `rxs`, the counting branch pieces of one pose, by segment (the caller's
/// order) and along each segment from its start. A piece closer than `min_range` to the
/// emitter or a receiver (or a pose or receiver inside a branch) is an error naming the
/// segment, or is left out with `too_close = "skip"`. Segments go in parallel chunks in
/// order, so the result does not depend on the number of threads. `pose_index` only labels
/// errors.
pub fn branch_members_heard(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    rxs: &[PlacedReceiver],
) -> Result<Vec<Vec<HeardPiece>>> {
    let n = scene.branches.len();
    let mut out: Vec<Vec<HeardPiece>> = (0..rxs.len()).map(|_| Vec::new()).collect();
    if n == 0 {
        return Ok(out);
    }

    // (the segments a piece of which may lie within the reach; see `segment_pieces_heard`)
    let near = scene
        .branches
        .within(pose.position, sonar.max_reach() + half_offset(pose, rxs));
    let bound: f64 = near
        .par_iter()
        .map(|&i| cut_heard(scene, sonar, pose, rxs, i as usize).map_or(0.0, |(_, _, n)| n as f64))
        .sum();
    check_pieces(bound * rxs.len() as f64, sonar, pose_index)?;
    type Part = (Vec<Vec<HeardPiece>>, Option<Close>);
    let parts: Vec<Result<Part>> = near
        .par_chunks(SEGMENT_CHUNK)
        .map(|c| {
            let mut mine: Vec<Vec<HeardPiece>> = (0..rxs.len()).map(|_| Vec::new()).collect();
            let mut close = None;
            for &i in c {
                segment_pieces_heard(scene, sonar, pose, rxs, i as usize, &mut mine, &mut close)?;
            }
            Ok((mine, close))
        })
        .collect();
    for part in parts {
        let (mine, close) = part?;
        if let (Some((branch, range, who)), TooClose::Error) = (close, sonar.params.too_close) {
            let (pose, min_range) = (pose_index, sonar.params.min_range);
            return Err(match who {
                None => Error::BranchTooClose {
                    pose,
                    branch,
                    range,
                    min_range,
                },
                Some(receiver) => Error::BranchTooCloseToReceiver {
                    pose,
                    receiver,
                    branch,
                    range,
                    min_range,
                },
            });
        }
        for (o, m) in out.iter_mut().zip(mine) {
            o.extend(m);
        }
    }
    Ok(out)
}
