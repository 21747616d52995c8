//! The counting leaves of a pose ([`members`]) and the range of the farthest one: the exact
//! test over the candidates in parallel chunks.
use crate::error::{Error, Result};
use crate::lobe::block::classify_block;
use crate::lobe::block::CB;
use crate::lobe::candidates::Candidates;
use crate::lobe::rule::classify;
use crate::lobe::rule::Decision;
use crate::lobe::walk::candidates;
use crate::physics::leaf::incidence;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{Sonar, TooClose};
use multiversion::multiversion;
use rayon::prelude::*;

/// One counting leaf: its index, range, two-way gain and incidence angle `beta` in [0, pi/2].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Member {
    pub index: u32,
    pub range: f64,
    pub gain: f64,
    pub beta: f64,
    /// `cos(beta) = |e . n|` and `sin(beta) = |e x n|`, straight from the geometry (well
    /// conditioned at normal and grazing incidence, where `cos(atan2(...))` is not).
    pub cos_beta: f64,
    pub sin_beta: f64,
}

/// How the candidates are found; the result is the same either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Search {
    Bvh,
    BruteForce,
}

/// Candidates per parallel task of the exact test.
const CLASSIFY_CHUNK: usize = 2048;

/// Per chunk of candidates: the counting leaves, and the first too-close leaf (index, range).
type Part = (Vec<Member>, Option<(usize, f64)>);

/// The error for a pose's too-close leaves `near` (caller's index, range): the smallest index
/// (the first of equals) when the sonar refuses them, else none.
pub(crate) fn refuse_too_close(
    sonar: &Sonar,
    pose_index: usize,
    near: impl Iterator<Item = (usize, f64)>,
) -> Result<()> {
    if sonar.params.too_close == TooClose::Error {
        if let Some((leaf, range)) = near.min_by_key(|&(l, _)| l) {
            return Err(Error::TooClose {
                pose: pose_index,
                leaf,
                range,
                min_range: sonar.params.min_range,
            });
        }
    }
    Ok(())
}

/// The libm decision for a leaf on the detectable boundary (see [`classify_block`]), exactly
/// as the reference makes it.
pub(crate) fn classify_member(scene: &Scene, sonar: &Sonar, pose: &Pose, i: u32) -> Option<Member> {
    match classify(sonar, pose, scene.centers.get(i as usize)) {
        Decision::In(v) => {
            let (beta, cos_beta, sin_beta) = incidence(v.dir, scene.normals.get(i as usize));
            Some(Member {
                index: i,
                range: v.range,
                gain: v.gain,
                beta,
                cos_beta,
                sin_beta,
            })
        }
        _ => None,
    }
}

/// The positions in `cands` (ascending) of the candidates within the sonar's ranges
/// (`min_range <= r <= range_limit`, `r > 0`, `r` as [`classify`] computes it), and their
/// stored indices: a superset of the counting leaves, found without the lobe test, for a pass
/// that needs their places before it tests the lobe (shading's rays).
pub fn ranged_positions(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    cands: &Candidates,
) -> (Vec<u32>, Vec<u32>) {
    let n = cands.len();
    let (lo, hi) = (sonar.params.min_range, sonar.range_limit);
    let parts: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(CLASSIFY_CHUNK))
        .into_par_iter()
        .map(|c| {
            let span = c * CLASSIFY_CHUNK..n.min((c + 1) * CLASSIFY_CHUNK);
            let mut at = Vec::with_capacity(span.len());
            let mut ids = Vec::with_capacity(span.len());
            let mut pos = span.start;
            let mut blocks = cands.blocks(span);
            while let Some((block, _)) = blocks.next_block() {
                for (k, &i) in block.iter().enumerate() {
                    let r = leaf_range(scene, pose, i);
                    if r > 0.0 && r >= lo && r <= hi {
                        at.push((pos + k) as u32);
                        ids.push(i);
                    }
                }
                pos += block.len();
            }
            (at, ids)
        })
        .collect();
    let (at, ids): (Vec<Vec<u32>>, Vec<Vec<u32>>) = parts.into_iter().unzip();
    (at.concat(), ids.concat())
}

/// The range (m) of stored leaf `i` from the pose, exactly as [`classify`] computes it.
#[inline(always)]
fn leaf_range(scene: &Scene, pose: &Pose, i: u32) -> f64 {
    let (c, p) = (scene.centers.get(i as usize), pose.position);
    let dx = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt()
}

/// Pass 1 of the exact test, cheap: the range of every candidate (the same operations as
/// [`classify`]). Candidates within `[min_range, range_limit]` go to `near`; the smallest index
/// of a too-close leaf (the caller's index, with its range) is kept in `too_close`.
#[inline(always)]
pub(crate) fn near_candidates(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    chunk: &[u32],
    near: &mut Vec<(u32, f64)>,
    too_close: &mut Option<(usize, f64)>,
) {
    let sp = &sonar.params;
    for &i in chunk {
        let r = leaf_range(scene, pose, i);
        if !(r >= sp.min_range) {
            let id = scene.ids[i as usize] as usize;
            if too_close.is_none_or(|(j, _)| id < j) {
                *too_close = Some((id, r));
            }
        } else if r <= sonar.range_limit {
            near.push((i, r));
        }
    }
}

/// The exact test for a chunk of candidates, eight at a time ([`classify_block`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn classify_many(scene: &Scene, sonar: &Sonar, pose: &Pose, chunk: &[u32]) -> Part {
    let mut out = Vec::with_capacity(chunk.len());
    let mut too_close = None;
    let mut near: Vec<(u32, f64)> = Vec::with_capacity(chunk.len());
    near_candidates(scene, sonar, pose, chunk, &mut near, &mut too_close);
    for block in near.chunks(CB) {
        let v = classify_block(scene, sonar, pose, block);
        for (k, &(i, r)) in block.iter().enumerate() {
            out.extend(v.member(k, i, r, scene, sonar, pose));
        }
    }
    (out, too_close)
}

/// The counting leaves for one pose, sorted by stored index (the scene's BVH order; map with
/// `scene.ids` to the caller's indices). `pose_index` only labels errors. The exact test runs
/// on the candidates in parallel chunks (in index order, so the result does not depend on the
/// number of threads).
pub fn members(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    search: Search,
) -> Result<Vec<Member>> {
    members_of(
        scene,
        sonar,
        pose,
        pose_index,
        candidates(scene, sonar, pose, search).to_vec(),
    )
}

/// [`members`] from the pose's candidates (any order; they are sorted here).
pub fn members_of(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    mut candidates: Vec<u32>,
) -> Result<Vec<Member>> {
    if !candidates.is_sorted() {
        candidates.par_sort_unstable();
    }
    let classify_chunk = |chunk: &[u32]| -> Part { classify_many(scene, sonar, pose, chunk) };
    let parts: Vec<Part> = if candidates.len() <= CLASSIFY_CHUNK {
        vec![classify_chunk(&candidates)]
    } else {
        candidates
            .par_chunks(CLASSIFY_CHUNK)
            .map(classify_chunk)
            .collect()
    };
    refuse_too_close(sonar, pose_index, parts.iter().filter_map(|p| p.1))?;
    let mut out = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
    for (m, _) in parts {
        out.extend(m);
    }
    Ok(out)
}

/// The range (m) of the farthest counting leaf of one pose (0 where none counts): the largest
/// range among [`members`], and the same error where a leaf is too close, without testing
/// every candidate. The candidates' ranges first (in parallel; a range, not the lobe test),
/// then the exact test for those in range slices from the farthest down, each slice twice as
/// wide as the last (1/64 of the span of ranges first), until a slice holds a counting leaf:
/// every farther leaf was tested and does not count, so that slice's farthest member is the
/// pose's. In a full lobe the first slice decides, so `n_samples = "auto"` costs far less than
/// a whole lobe query per pose.
pub fn farthest_member_range(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    search: Search,
) -> Result<f64> {
    let sp = &sonar.params;
    let ids = candidates(scene, sonar, pose, search).to_vec();
    let ranges: Vec<f64> = ids
        .par_iter()
        .with_min_len(CLASSIFY_CHUNK)
        .map(|&i| leaf_range(scene, pose, i))
        .collect();
    if sp.too_close == TooClose::Error && ranges.par_iter().any(|&r| !(r >= sp.min_range)) {
        // (the error exactly as `members` reports it)
        return members_of(scene, sonar, pose, pose_index, ids).map(|m| farthest_of(&m));
    }
    let can_count = |r: f64| r >= sp.min_range && r <= sonar.range_limit;
    let span = ranges
        .par_iter()
        .with_min_len(CLASSIFY_CHUNK)
        .filter(|&&r| can_count(r))
        .map(|&r| (r, r))
        .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)));
    let Some((lo, hi)) = span else {
        return Ok(0.0);
    };
    let (mut top, mut width) = (f64::INFINITY, (hi - lo) / 64.0);
    loop {
        // the slice [bottom, top); the last one reaches down to `lo`
        let bottom = if hi - width > lo {
            hi - width
        } else {
            f64::NEG_INFINITY
        };
        let slice: Vec<u32> = ids
            .par_iter()
            .zip(&ranges)
            .with_min_len(CLASSIFY_CHUNK)
            .filter(|&(_, &r)| r >= bottom && r < top && can_count(r))
            .map(|(&i, _)| i)
            .collect();
        let far = slice
            .par_chunks(CLASSIFY_CHUNK)
            .map(|c| farthest_of(&classify_many(scene, sonar, pose, c).0))
            .reduce(|| 0.0, f64::max);
        if far > 0.0 || bottom == f64::NEG_INFINITY {
            return Ok(far);
        }
        (top, width) = (bottom, 2.0 * width);
    }
}

/// The largest range among `members` (0 for none).
fn farthest_of(members: &[Member]) -> f64 {
    members.iter().fold(0.0f64, |a, mb| a.max(mb.range))
}
