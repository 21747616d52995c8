//! The occluders that can cross some target's ray: the cone from the sonar round every target
//! ray, and the leaves (by the BVH) and branch segments whose bounding balls reach it.
use crate::math::vec3::{dot, V3};
use crate::scene::Scene;
use obvhs::aabb::Aabb;
use rayon::prelude::*;

/// Relative slack of the cone test, far beyond its rounding.
const SLACK: f64 = 1e-9;
/// Subtrees with at most this many leaves are taken whole, untested.
const SMALL_SUBTREE: u32 = 8;
/// Subtrees with fewer leaves than this are walked in one task.
const PAR_MIN_LEAVES: u32 = 8192;

/// The cone from the sonar round every target ray, cut at the farthest target.
#[derive(Clone, Copy, Debug)]
pub(super) struct Cone {
    axis: V3,
    cos_half: f64,
    sin_half: f64,
    reach: f64,
}

impl Cone {
    /// The cone round the rays `w` (relative to the sonar) of lengths `r` (> 0).
    pub(super) fn around(w: &[V3], r: &[f64]) -> Cone {
        // (the directions summed by fixed spans, the spans' sums in order: the same axis for
        // any number of threads)
        const SPAN: usize = 8192;
        let s = w
            .par_chunks(SPAN)
            .zip(r.par_chunks(SPAN))
            .map(|(w, r)| {
                let mut s = [0.0f64; 3];
                for (w, &r) in w.iter().zip(r) {
                    for d in 0..3 {
                        s[d] += w[d] / r;
                    }
                }
                s
            })
            .collect::<Vec<V3>>()
            .iter()
            .fold([0.0f64; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        let ns = dot(s, s).sqrt();
        let axis = if ns > 0.0 {
            s.map(|x| x / ns)
        } else {
            [1.0, 0.0, 0.0]
        };
        let (cos_half, reach) = w
            .par_iter()
            .zip(r)
            .map(|(w, &r)| (dot(*w, axis) / r, r))
            .reduce(|| (1.0f64, 0.0f64), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        // (widened past the rounding of the directions)
        let half = (cos_half.clamp(-1.0, 1.0).acos() + SLACK).min(std::f64::consts::PI);
        Cone {
            axis,
            cos_half: half.cos(),
            sin_half: half.sin(),
            reach: reach * (1.0 + SLACK),
        }
    }

    /// [`Cone::meets`] for the ball round a BVH node's box (absolute coordinates; the sonar at
    /// `origin`).
    #[inline(always)]
    pub(super) fn meets_box(&self, a: &Aabb, origin: V3) -> Option<bool> {
        let lo = [a.min.x as f64, a.min.y as f64, a.min.z as f64];
        let hi = [a.max.x as f64, a.max.y as f64, a.max.z as f64];
        let c: V3 = std::array::from_fn(|d| 0.5 * (lo[d] + hi[d]) - origin[d]);
        let h: V3 = std::array::from_fn(|d| 0.5 * (hi[d] - lo[d]));
        self.meets(c, dot(h, h).sqrt() * (1.0 + SLACK))
    }

    /// Whether a ball of centre `v` (relative to the sonar) and radius `rho` may hold a point
    /// of the cone: `Some(inside)` (`inside`: the whole ball is in it), None when it holds none.
    #[inline(always)]
    pub(super) fn meets(&self, v: V3, rho: f64) -> Option<bool> {
        let dist = dot(v, v).sqrt();
        if dist - rho > self.reach {
            return None;
        }
        if !(dist > rho) {
            return Some(false);
        }
        // the angle to the axis at most half + delta, sin(delta) = rho / dist
        let sd = rho / dist;
        let cd = (1.0 - sd * sd).max(0.0).sqrt();
        let cos_v = dot(v, self.axis) / dist;
        let wide = self.sin_half <= sd && self.cos_half < 0.0; // half + delta >= pi
        if !wide && cos_v < self.cos_half * cd - self.sin_half * sd - SLACK {
            return None;
        }
        // (half - delta, where positive)
        let inside = dist + rho < self.reach
            && sd < self.sin_half
            && self.cos_half > -1.0
            && cos_v > self.cos_half * cd + self.sin_half * sd + SLACK;
        Some(inside)
    }
}

/// The stored indices of the leaves whose boxes reach the cone from `origin`, in the BVH's
/// depth-first order (a superset of those whose disks can cross a target ray).
pub(super) fn occluding_leaves(scene: &Scene, origin: V3, cone: &Cone) -> Vec<u32> {
    if scene.bvh.nodes.is_empty() {
        return Vec::new();
    }
    let levels = if rayon::current_thread_index().is_some() {
        8
    } else {
        0
    };
    walk(scene, origin, cone, 0, false, levels)
}

/// The leaves below node `ni` (`inside`: an ancestor lay wholly inside the cone), with the
/// top `levels` levels split into parallel tasks whose lists are joined in order.
fn walk(scene: &Scene, origin: V3, cone: &Cone, ni: u32, inside: bool, levels: u32) -> Vec<u32> {
    let bvh = &scene.bvh;
    let in_order = !scene.node_ranges.is_empty();
    let mut out = Vec::new();
    let mut stack = vec![(ni, inside, levels)];
    while let Some((ni, inside, levels)) = stack.pop() {
        let node = &bvh.nodes[ni as usize];
        let range = scene.node_ranges.get(ni as usize).copied();
        let small = match range {
            Some((lo, hi)) => hi - lo <= SMALL_SUBTREE,
            None => false,
        };
        let mut whole = inside || small;
        if !whole {
            match cone.meets_box(node.aabb(), origin) {
                None => continue,
                Some(all) => whole = all,
            }
        }
        if let (true, true, Some((lo, hi))) = (whole, in_order, range) {
            out.extend(lo..hi);
        } else if node.is_leaf() {
            let (first, count) = (node.first_index, node.prim_count);
            if in_order {
                out.extend(first..first + count);
            } else {
                out.extend_from_slice(
                    &bvh.primitive_indices[first as usize..(first + count) as usize],
                );
            }
        } else {
            let (a, b) = (node.first_index, node.first_index + 1);
            let big = range.is_none_or(|(lo, hi)| hi - lo >= PAR_MIN_LEAVES);
            if levels > 0 && big {
                let (mut x, y) = rayon::join(
                    || walk(scene, origin, cone, a, whole, levels - 1),
                    || walk(scene, origin, cone, b, whole, levels - 1),
                );
                x.extend(y);
                out.extend(x);
            } else {
                stack.push((b, whole, 0));
                stack.push((a, whole, 0));
            }
        }
    }
    out
}

/// The branch segments whose bounding balls reach the cone from `origin`, ascending, found on
/// the segments' BVH: a node whose box's ball misses the cone holds no cylinder that a target
/// ray can pass through (a box holds its cylinders), so the list leaves out only segments that
/// can block nothing.
pub(super) fn occluding_segments(scene: &Scene, origin: V3, cone: &Cone) -> Vec<u32> {
    let br = &scene.branches;
    let bvh = &br.bvh;
    let mut out = Vec::new();
    if bvh.nodes.is_empty() {
        return out;
    }
    let mut stack = vec![(0usize, false)];
    while let Some((ni, inside)) = stack.pop() {
        let node = &bvh.nodes[ni];
        let mut whole = inside;
        if !whole {
            match cone.meets_box(node.aabb(), origin) {
                None => continue,
                Some(all) => whole = all,
            }
        }
        if node.is_leaf() {
            let first = node.first_index as usize;
            out.extend(
                bvh.primitive_indices[first..first + node.prim_count as usize]
                    .iter()
                    .filter(|&&i| {
                        let m = br.mids[i as usize];
                        let v = [m[0] - origin[0], m[1] - origin[1], m[2] - origin[2]];
                        cone.meets(v, br.bound_radii[i as usize] * (1.0 + SLACK))
                            .is_some()
                    }),
            );
        } else {
            let c = node.first_index as usize;
            stack.extend([(c + 1, whole), (c, whole)]);
        }
    }
    out.sort_unstable();
    out
}
