//! Which branch pieces count for a pose (docs/model.md §9): each segment near the lobe is cut
//! into pieces by the rule of [`max_piece_length`] at its nearest distance, and each piece goes
//! through the leaves' exact lobe test at its reference point (the near surface at its centre).
use crate::budget;
use crate::error::{short, Error, Result};
use crate::lobe::bound::{test_box, AngularBound, BoxTest};
use crate::lobe::rule::{classify, Decision};
use crate::math::vec3::V3;
use crate::physics::branch::{
    distance_to_segment, max_piece_length, piece_count, piece_sight, PieceSight,
};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{Sonar, TooClose};
use rayon::prelude::*;

/// One counting branch piece: its segment, the reference point of its echo, the range and
/// two-way gain there, its length and radius, and the tilt of its axis from broadside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PieceMember {
    pub segment: u32,
    pub reference: V3,
    pub range: f64,
    pub gain: f64,
    pub length: f64,
    pub radius: f64,
    pub cos_gamma: f64,
    pub sin_gamma: f64,
}

/// The most pieces one segment may be cut into for one pose (a segment that needs more lies
/// closer to the sonar than the model can treat).
pub const MAX_PIECES: usize = 1 << 20;

/// Segments per parallel task.
const SEGMENT_CHUNK: usize = 256;

/// Spans of at most this many pieces are tested piece by piece (longer spans are halved).
pub const PIECE_BLOCK: usize = 16;

/// Visit the pieces `k0..k1` of a segment in order, skipping spans that `span_out` rules out
/// (a conservative test: a span it rules out holds no piece that counts): the span is tested
/// as one box, and if it is not ruled out it is halved down to [`PIECE_BLOCK`] pieces, whose
/// pieces are visited one by one. A segment mostly outside the lobe costs a few tests per
/// span it crosses, not one per block of pieces.
pub fn visit_spans(
    k0: usize,
    k1: usize,
    span_out: &impl Fn(usize, usize) -> bool,
    piece: &mut impl FnMut(usize),
) {
    if k0 >= k1 || span_out(k0, k1) {
        return;
    }
    if k1 - k0 <= PIECE_BLOCK {
        (k0..k1).for_each(piece);
        return;
    }
    let mid = k0 + (k1 - k0) / 2;
    visit_spans(k0, mid, span_out, piece);
    visit_spans(mid, k1, span_out, piece);
}

/// The box (lo, hi) round the span `[k0, k1)` of a segment from `a` along `d` cut into `n`
/// pieces of radius `radius`: it holds every point within `radius` of the span's axis, so every
/// piece's reference point, with a margin for rounding. Also the span's ends.
pub fn block_box(a: V3, d: V3, n: usize, k0: usize, k1: usize, radius: f64) -> (V3, V3, V3, V3) {
    let (t0, t1) = (k0 as f64 / n as f64, k1 as f64 / n as f64);
    let s0: V3 = std::array::from_fn(|j| a[j] + t0 * d[j]);
    let s1: V3 = std::array::from_fn(|j| a[j] + t1 * d[j]);
    let pad = radius * (1.0 + 1e-9) + 1e-12 * (1.0 + s0[0].abs().max(s1[0].abs()));
    let lo: V3 = std::array::from_fn(|j| s0[j].min(s1[j]) - pad);
    let hi: V3 = std::array::from_fn(|j| s0[j].max(s1[j]) + pad);
    (lo, hi, s0, s1)
}

/// How segment `i` is cut for the pose: the distance of its surface and its number of pieces
/// (the rule of [`max_piece_length`] at that distance), or None where no piece of it can count
/// or be too close (beyond the reach or, with `lobe`, its box outside the lobe).
fn cut(scene: &Scene, sonar: &Sonar, pose: &Pose, i: usize, lobe: bool) -> Option<(f64, usize)> {
    let br = &scene.branches;
    let (a, b, radius) = (br.starts[i], br.ends[i], br.radii[i]);
    let p = pose.position;
    let sp = &sonar.params;
    let near = distance_to_segment(p, a, b) - radius;
    if near > sonar.max_reach() {
        return None;
    }
    if lobe && near >= sp.min_range {
        // (the lobe's conservative box test on the segment's box)
        let lo: V3 = std::array::from_fn(|d| a[d].min(b[d]) - radius);
        let hi: V3 = std::array::from_fn(|d| a[d].max(b[d]) + radius);
        let bound = AngularBound::new(sonar, pose);
        if test_box(sonar, pose, bound.as_ref(), lo, hi) == BoxTest::Outside {
            return None;
        }
    }
    let k_max = sonar.wavenumbers[sonar.wavenumbers.len() - 1];
    let max_len = max_piece_length(
        near.max(sp.min_range),
        k_max,
        sonar.narrowest_sigma(),
        sp.branch_piece_scale,
    );
    Some((near, piece_count(br.lengths[i], max_len)))
}

/// The pieces of segment `i` that count, appended to `out`; the first too-close one (segment,
/// distance of its surface) into `too_close`.
fn segment_pieces(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    i: usize,
    out: &mut Vec<PieceMember>,
    too_close: &mut Option<(usize, f64)>,
) -> Result<()> {
    let Some((near, n)) = cut(scene, sonar, pose, i, true) else {
        return Ok(());
    };
    if n > MAX_PIECES {
        return Err(Error::InvalidInput(format!(
            "branch {i} would need {n} pieces at {near:.3e} m from the sonar (at most \
             {MAX_PIECES}, with branch_piece_scale = {}); raise min_range_m or \
             branch_piece_scale, or keep the sonar farther from it",
            sonar.params.branch_piece_scale
        )));
    }
    let br = &scene.branches;
    let (a, b, radius) = (br.starts[i], br.ends[i], br.radii[i]);
    let p = pose.position;
    let sp = &sonar.params;
    let length = br.lengths[i];
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let (u, piece_len) = (br.axes[i], length / n as f64);
    let mut note_close = |r: f64| {
        if too_close.is_none() {
            *too_close = Some((i, r));
        }
    };
    let bound = AngularBound::new(sonar, pose);
    // Spans of pieces whose box lies beyond the reach or outside the lobe hold no piece that
    // counts or is too close: skipped whole (the pieces that count are the same).
    let span_out = |k0: usize, k1: usize| {
        let (lo, hi, s0, s1) = block_box(a, d, n, k0, k1, radius);
        let near = distance_to_segment(p, s0, s1) - radius;
        near > sonar.max_reach()
            || (near >= sp.min_range
                && test_box(sonar, pose, bound.as_ref(), lo, hi) == BoxTest::Outside)
    };
    visit_spans(0, n, &span_out, &mut |k| {
        let t = (2 * k + 1) as f64 / (2 * n) as f64;
        let c = [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]];
        match piece_sight(p, c, u, radius, piece_len) {
            PieceSight::Lit {
                reference,
                cos_gamma,
                sin_gamma,
            } => match classify(sonar, pose, reference) {
                Decision::In(v) => out.push(PieceMember {
                    segment: i as u32,
                    reference,
                    range: v.range,
                    gain: v.gain,
                    length: piece_len,
                    radius,
                    cos_gamma,
                    sin_gamma,
                }),
                Decision::TooClose(r) => note_close(r),
                Decision::Out => {}
            },
            PieceSight::EndOn => {}
            PieceSight::Inside => note_close(near.min(0.0)),
        }
    });
    Ok(())
}

/// `TooLarge` where `bound` pieces (an upper bound on a pose's counting pieces, counted before
/// any is made) would not fit the memory limit on every thread: each may become a member, a
/// term and a shading target.
pub(crate) fn check_pieces(bound: f64, sonar: &Sonar, pose_index: usize) -> Result<()> {
    let threads = rayon::current_num_threads();
    budget::check(
        bound * budget::BYTES_PER_PIECE * threads as f64,
        || {
            format!(
                "pose {pose_index}: its branches cut into up to {} pieces \
                 (branch_piece_scale = {}, min_range_m = {}) on each of {threads} threads",
                short(bound.round()),
                short(sonar.params.branch_piece_scale),
                short(sonar.params.min_range),
            )
        },
        "raise branch_piece_scale or min_range_m (pieces are as short as a near branch or a \
         narrow beam needs), or leave the nearest branches out",
    )
}

/// The counting branch pieces of one pose, by segment (the caller's order) and along each
/// segment from its start. `pose_index` only labels errors. A piece closer than `min_range`
/// (or a pose inside a branch) is an error naming the segment, or is left out with
/// `too_close = "skip"`. Segments go in parallel chunks in order, so the result does not
/// depend on the number of threads.
pub fn branch_members(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
) -> Result<Vec<PieceMember>> {
    let n = scene.branches.len();
    if n == 0 {
        return Ok(Vec::new());
    }
    // (the segments a piece of which may lie within the reach; see `segment_pieces`)
    let near = scene.branches.within(pose.position, sonar.max_reach());
    // (every segment within the reach, without the lobe's box test: a cheap upper bound)
    let bound: f64 = near
        .par_iter()
        .map(|&i| cut(scene, sonar, pose, i as usize, false).map_or(0.0, |(_, n)| n as f64))
        .sum();
    check_pieces(bound, sonar, pose_index)?;
    type Part = (Vec<PieceMember>, Option<(usize, f64)>);
    let parts: Vec<Result<Part>> = near
        .par_chunks(SEGMENT_CHUNK)
        .map(|c| {
            let (mut out, mut close) = (Vec::new(), None);
            for &i in c {
                segment_pieces(scene, sonar, pose, i as usize, &mut out, &mut close)?;
            }
            Ok((out, close))
        })
        .collect();
    let mut out = Vec::new();
    for part in parts {
        let (mine, close) = part?;
        if let (Some((branch, range)), TooClose::Error) = (close, sonar.params.too_close) {
            return Err(Error::BranchTooClose {
                pose: pose_index,
                branch,
                range,
                min_range: sonar.params.min_range,
            });
        }
        out.extend(mine);
    }
    Ok(out)
}
