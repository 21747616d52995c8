//! Shading (docs/model.md §10): for each counting scatterer, how many leaf disks the open segment
//! from the sonar to it crosses, and whether a branch cylinder blocks it.
//!
//! The rays of one pose share their origin, so they are cast through a light buffer
//! ([`buffer`]) around the sonar: the occluders that can reach the rays (leaves found by the
//! BVH, branch segments by their bounding balls; [`occluders`]) are mapped to the cells of the
//! target directions they cover (a leaf by its disk's box, a segment by balls along it), and
//! each target in those cells is tested exactly ([`crossing`]). Occluders go in parallel, in
//! the BVH's order (near in space, so near in direction: the targets they reach are in cache);
//! each worker thread counts crossings into its own array and the arrays are added, integer
//! sums, so the result does not depend on the order or the number of threads.

pub mod buffer;
pub mod crossing;
pub mod occluders;
mod runs;
mod sweep;

use crate::math::vec3::{dot, V3};
use crate::scene::Scene;
use buffer::Buffer;
use crossing::Cylinder;
use occluders::{occluding_leaves, occluding_segments, Cone};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use sweep::{leaf_chunk, Rays, Work};

/// A scatterer whose ray is cast: its point (a leaf's centre, a branch piece's reference
/// point) and what it is, so that it is never its own occluder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// A leaf, by stored index.
    Leaf { point: V3, leaf: u32 },
    /// A branch piece of segment `segment`: its own segment and the segments joined to it never
    /// block it.
    Piece { point: V3, segment: u32 },
}

impl Target {
    #[inline(always)]
    fn point(&self) -> V3 {
        match *self {
            Target::Leaf { point, .. } | Target::Piece { point, .. } => point,
        }
    }
}

/// What lies on a target's ray: the leaf disks it crosses, and whether a branch blocks it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sight {
    pub crossings: u32,
    pub blocked: bool,
}

/// Occluders per parallel task.
const OCCLUDER_CHUNK: usize = 512;

/// The sight of every target from `origin`: the leaf disks of the scene its ray crosses (any
/// leaf but itself), and, with `branches_block`, whether a branch cylinder blocks it (any but a
/// piece's own segment and those joined to it).
pub fn cast(scene: &Scene, origin: V3, targets: &[Target], branches_block: bool) -> Vec<Sight> {
    if rayon::current_thread_index().is_none() {
        return rayon::scope(|_| cast(scene, origin, targets, branches_block));
    }
    let n = targets.len();
    if n == 0 {
        return Vec::new();
    }
    let w: Vec<V3> = targets
        .par_iter()
        .map(|t| {
            let p = t.point();
            [p[0] - origin[0], p[1] - origin[1], p[2] - origin[2]]
        })
        .collect();
    let r: Vec<f64> = w.par_iter().map(|w| dot(*w, *w).sqrt()).collect();
    let cone = Cone::around(&w, &r);
    let (leaves, segments) = rayon::join(
        || occluding_leaves(scene, origin, &cone),
        || {
            if branches_block {
                occluding_segments(scene, origin, &cone)
            } else {
                Vec::new()
            }
        },
    );
    let buf = Buffer::new(
        &w,
        2.0 * typical_angular_radius(scene, origin, &leaves, &segments),
    );
    let rays = rays_in_order(targets, &buf, &w, &r);
    let blocked: Vec<AtomicBool> = (0..n).map(|_| AtomicBool::new(false)).collect();
    let all = buf.n_cells();
    let crossings = count_crossings(n, leaves.par_chunks(OCCLUDER_CHUNK), |chunk, work| {
        leaf_chunk(scene, origin, &buf, &rays, chunk, work)
    });
    segments.par_chunks(OCCLUDER_CHUNK / 8).for_each(|chunk| {
        let mut cells: Vec<(usize, usize)> = Vec::new();
        for &j in chunk {
            let br = &scene.branches;
            let (s, u, len, a) = (
                br.starts[j as usize],
                br.axes[j as usize],
                br.lengths[j as usize],
                br.radii[j as usize],
            );
            let sv = [s[0] - origin[0], s[1] - origin[1], s[2] - origin[2]];
            let cyl = Cylinder::new(sv, u, len, a);
            // Balls along the segment, each about as long as a cell is wide at its distance
            // (a long segment's one ball would cover cells its thin body never reaches).
            cells.clear();
            let mut everywhere = false;
            let m = br.mids[j as usize];
            let dist = ((m[0] - origin[0]).powi(2)
                + (m[1] - origin[1]).powi(2)
                + (m[2] - origin[2]).powi(2))
            .sqrt();
            let step = (2.0 * a).max(buf.cell_width() * dist);
            let k = ((len / step).ceil() as usize).clamp(1, 4096);
            let half = 0.5 * len / k as f64;
            let rho = (half * half + a * a).sqrt();
            for q in 0..k {
                let t = (2 * q + 1) as f64 * half;
                let v = [sv[0] + t * u[0], sv[1] + t * u[1], sv[2] + t * u[2]];
                if !buf.ball_cells(v, rho, |c0, c1| cells.push((c0, c1))) {
                    everywhere = true;
                    break;
                }
            }
            if everywhere {
                cells.clear();
                cells.push((0, all));
            } else {
                cells.sort_unstable();
                cells.dedup();
            }
            for &(c0, c1) in &cells {
                let (lo, hi) = (buf.start[c0] as usize, buf.start[c1] as usize);
                for (pos, &segment) in rays.segment.iter().enumerate().take(hi).skip(lo) {
                    if blocked[pos].load(Ordering::Relaxed)
                        || segment == j
                        || (segment != u32::MAX
                            && br.joined_to(segment as usize).binary_search(&j).is_ok())
                    {
                        continue;
                    }
                    if cyl.crossed_by(rays.w(pos)) {
                        blocked[pos].store(true, Ordering::Relaxed);
                    }
                }
            }
        }
    });
    buf.slot
        .par_iter()
        .map(|&pos| Sight {
            crossings: crossings[pos as usize],
            blocked: blocked[pos as usize].load(Ordering::Relaxed),
        })
        .collect()
}

/// The crossings of `n` targets by position, counted by `count(chunk, work)` over the
/// `chunks` in parallel: each worker thread counts into its own [`Work`] (made on its first
/// chunk), and the threads' counts are added at the end; integer sums, so the counts are the
/// same for any number of threads and any split of the work.
fn count_crossings<'a>(
    n: usize,
    chunks: impl ParallelIterator<Item = &'a [u32]>,
    count: impl Fn(&[u32], &mut Work) + Sync,
) -> Vec<u32> {
    let slots: Vec<Mutex<Option<Work>>> = (0..rayon::current_num_threads())
        .map(|_| Mutex::new(None))
        .collect();
    chunks.for_each(|chunk| {
        // (a thread of the pool locks only its own slot, and `count` makes no rayon call, so
        // the thread cannot take up another chunk while it holds the lock)
        let i = rayon::current_thread_index().unwrap_or(0) % slots.len();
        let mut slot = slots[i].lock().unwrap_or_else(|e| e.into_inner());
        count(chunk, slot.get_or_insert_with(|| Work::new(n)));
    });
    let mut total: Vec<u32> = Vec::new();
    for slot in slots {
        let Some(work) = slot.into_inner().unwrap_or_else(|e| e.into_inner()) else {
            continue;
        };
        if total.is_empty() {
            total = work.crossings;
        } else {
            total
                .iter_mut()
                .zip(&work.crossings)
                .for_each(|(x, y)| *x += y);
        }
    }
    total.resize(n.max(total.len()), 0);
    total
}

/// The targets' rays in the buffer's order, padded as [`Rays::inert`] pads them: each target
/// in turn put at its place (its slot), so that the reads run in order.
fn rays_in_order(targets: &[Target], buf: &Buffer, w: &[V3], r: &[f64]) -> Rays {
    let n = targets.len();
    let mut rays = Rays::inert(n);
    for (i, t) in targets.iter().enumerate() {
        let p = buf.slot[i] as usize;
        (rays.x[p], rays.y[p], rays.z[p], rays.range[p]) = (w[i][0], w[i][1], w[i][2], r[i]);
        (rays.leaf[p], rays.segment[p]) = match *t {
            Target::Leaf { leaf, .. } => (leaf, u32::MAX),
            Target::Piece { segment, .. } => (u32::MAX, segment),
        };
    }
    rays
}

/// The median angular radius (rad) of a sample of the occluders seen from `origin`: leaves'
/// radii over their distances, else segments' (0 without occluders).
fn typical_angular_radius(scene: &Scene, origin: V3, leaves: &[u32], segments: &[u32]) -> f64 {
    const SAMPLE: usize = 65;
    let dist = |c: V3| {
        let v = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
        dot(v, v).sqrt()
    };
    let mut a: Vec<f64> = if !leaves.is_empty() {
        let step = leaves.len().div_ceil(SAMPLE);
        leaves
            .iter()
            .step_by(step)
            .map(|&j| scene.radii[j as usize] / dist(scene.centers.get(j as usize)))
            .collect()
    } else {
        let br = &scene.branches;
        let step = segments.len().div_ceil(SAMPLE).max(1);
        segments
            .iter()
            .step_by(step)
            .map(|&j| br.radii[j as usize] / dist(br.mids[j as usize]))
            .collect()
    };
    a.retain(|x| x.is_finite());
    if a.is_empty() {
        return 0.0;
    }
    a.sort_unstable_by(f64::total_cmp);
    a[a.len() / 2]
}

#[cfg(test)]
mod tests;
