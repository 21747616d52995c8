//! Leaves as disks (centre, unit normal, radius) and the obvhs BVH over their centres, built
//! once and reused for every pose.

pub mod obj;

use crate::error::{invalid, Result};
use crate::physics::leaf::{PAPER_BP, PAPER_PP};
use crate::physics::pose::{dot, V3};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Coordinates beyond this (m) are refused: the BVH stores f32 boxes.
pub const MAX_COORDINATE: f64 = 1e15;

/// Leaves are stored in the BVH's primitive order (so that a traversal reads them nearly
/// sequentially); `ids[i]` is the caller's index of stored leaf `i`. Every index that reaches
/// the user (members, errors) is mapped back through `ids`.
pub struct Scene {
    pub ids: Vec<u32>,
    pub centers: Xyz,
    pub normals: Xyz,
    pub radii: Vec<f64>,
    /// `a^-0.9065` and `a^0.3523` of every radius (the paper model's `c^p = k^p a^p`).
    pub radius_pow_b: Vec<f64>,
    pub radius_pow_p: Vec<f64>,
    pub bvh: Bvh2,
    /// Per BVH node, the range `[lo, hi)` of stored leaves below it, when every subtree's
    /// leaves are contiguous in storage (empty otherwise): a traversal takes a subtree that
    /// lies wholly inside the lobe as one range.
    pub node_ranges: Vec<(u32, u32)>,
    /// Wall time of the BVH build.
    pub build_time: Duration,
    /// The smallest radius and the stored index of its first leaf (checked against the band's
    /// lowest frequency by every simulation; found once here).
    pub smallest: (usize, f64),
}

/// 3-vectors stored as three coordinate arrays, so that a run of stored leaves loads as whole
/// vectors (`[f64; 3]` rows would have to be transposed per block first).
pub struct Xyz {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
}

impl Xyz {
    /// The rows `v[ids[0]], v[ids[1]], ...`.
    fn gather(v: &[V3], ids: &[u32]) -> Xyz {
        let coord = |d: usize| ids.iter().map(|&i| v[i as usize][d]).collect();
        Xyz {
            x: coord(0),
            y: coord(1),
            z: coord(2),
        }
    }

    /// Vector `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> V3 {
        [self.x[i], self.y[i], self.z[i]]
    }

    pub fn len(&self) -> usize {
        self.x.len()
    }

    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }
}

/// The f32 box that surely contains the f64 point (rounded outward), widened by `half` on
/// every side. (The leaf's own radius: zero-extent boxes make the builder's surface-area
/// heuristic degenerate, quadratic for colinear leaves; the box still holds the centre, so
/// the query stays conservative.)
fn point_box(c: V3, half: f64) -> Aabb {
    let down = |x: f64| {
        let f = x as f32;
        if f as f64 > x {
            f.next_down()
        } else {
            f
        }
    };
    let up = |x: f64| {
        let f = x as f32;
        if (f as f64) < x {
            f.next_up()
        } else {
            f
        }
    };
    Aabb::new(
        Vec3A::new(down(c[0] - half), down(c[1] - half), down(c[2] - half)),
        Vec3A::new(up(c[0] + half), up(c[1] + half), up(c[2] + half)),
    )
}

/// Validate leaf arrays: equal lengths, at least one leaf, finite coordinates, unit normals
/// (to 1e-6), positive finite radii. Messages name the first offending leaf.
pub fn validate_leaves(centers: &[V3], normals: &[V3], radii: &[f64]) -> Result<()> {
    let n = centers.len();
    if normals.len() != n || radii.len() != n {
        return invalid(format!(
            "leaf arrays differ in length: {} centers, {} normals, {} radii",
            n,
            normals.len(),
            radii.len()
        ));
    }
    if n == 0 {
        return invalid("a scene needs at least one leaf; got 0");
    }
    if n > u32::MAX as usize {
        return invalid("at most 2^32 - 1 leaves are supported");
    }
    for (i, c) in centers.iter().enumerate() {
        if !c.iter().all(|x| x.is_finite()) {
            return invalid(format!("leaf {i} has a non-finite center {c:?}"));
        }
        if c.iter().any(|x| x.abs() > MAX_COORDINATE) {
            return invalid(format!(
                "leaf {i} has a center coordinate beyond {MAX_COORDINATE:e} m: {c:?}"
            ));
        }
    }
    for (i, nv) in normals.iter().enumerate() {
        let l2 = dot(*nv, *nv);
        if !l2.is_finite() || (l2 - 1.0).abs() > 1e-6 {
            return invalid(format!(
                "leaf {i} normal {nv:?} is not a finite unit vector"
            ));
        }
    }
    for (i, &a) in radii.iter().enumerate() {
        if !(a.is_finite() && a > 0.0) {
            return invalid(format!("leaf {i} radius must be finite and > 0, got {a}"));
        }
    }
    Ok(())
}

impl Scene {
    /// Build a scene. Normals must already be unit vectors (see [`normalized`]).
    pub fn new(centers: Vec<V3>, normals: Vec<V3>, radii: Vec<f64>) -> Result<Scene> {
        validate_leaves(&centers, &normals, &radii)?;
        let start = Instant::now();
        let boxes: Vec<Aabb> = centers
            .iter()
            .zip(&radii)
            .map(|(&c, &a)| point_box(c, a))
            .collect();
        let mut core = Duration::default();
        let mut bvh = build_bvh2(&boxes, BvhBuildParams::fast_build(), &mut core);
        // Store the leaves in the order a depth-first traversal meets them (so that every
        // subtree's leaves are one contiguous range and a traversal reads them in order); the
        // leaf nodes are renumbered to index storage directly.
        let n = centers.len();
        let (ids, node_ranges) = match dfs_order(&mut bvh, n) {
            Some(ids) => {
                let ranges = subtree_ranges(&bvh);
                (ids, ranges)
            }
            None => ((0..n as u32).collect(), Vec::new()),
        };
        let (centers, normals) = (Xyz::gather(&centers, &ids), Xyz::gather(&normals, &ids));
        let radii: Vec<f64> = ids.iter().map(|&i| radii[i as usize]).collect();
        let build_time = start.elapsed();
        let radius_pow_b = radii.par_iter().map(|a| a.powf(PAPER_BP)).collect();
        let radius_pow_p = radii.par_iter().map(|a| a.powf(PAPER_PP)).collect();
        let smallest = radii
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |acc, (i, a)| if a < acc.1 { (i, a) } else { acc },
            );
        Ok(Scene {
            ids,
            centers,
            normals,
            radii,
            radius_pow_b,
            radius_pow_p,
            bvh,
            node_ranges,
            build_time,
            smallest,
        })
    }

    pub fn len(&self) -> usize {
        self.centers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.centers.is_empty()
    }

    pub fn min_radius(&self) -> f64 {
        self.radii.iter().copied().fold(f64::INFINITY, f64::min)
    }
}

/// Renumber the BVH's leaves in depth-first order (first child first, as the lobe traversal
/// visits them): returns the primitives in that order and sets `primitive_indices` to the
/// identity. None (BVH untouched) unless every primitive appears exactly once.
fn dfs_order(bvh: &mut Bvh2, n: usize) -> Option<Vec<u32>> {
    if bvh.nodes.is_empty() || bvh.primitive_indices.len() != n {
        return None;
    }
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut new_first: Vec<(usize, u32)> = Vec::new();
    let mut stack = vec![0u32];
    while let Some(ni) = stack.pop() {
        let node = &bvh.nodes[ni as usize];
        if node.is_leaf() {
            new_first.push((ni as usize, order.len() as u32));
            let first = node.first_index as usize;
            for &p in bvh
                .primitive_indices
                .get(first..first + node.prim_count as usize)?
            {
                if (p as usize) >= n || std::mem::replace(&mut seen[p as usize], true) {
                    return None;
                }
                order.push(p);
            }
        } else {
            stack.push(node.first_index + 1);
            stack.push(node.first_index);
        }
    }
    if order.len() != n {
        return None;
    }
    for (ni, first) in new_first {
        bvh.nodes[ni].first_index = first;
    }
    bvh.primitive_indices = (0..n as u32).collect();
    Some(order)
}

/// Per node, the range of primitive positions below it, if every subtree's positions are
/// contiguous (else empty).
fn subtree_ranges(bvh: &Bvh2) -> Vec<(u32, u32)> {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return Vec::new();
    }
    let mut out = vec![(u32::MAX, 0u32); nodes.len()];
    let mut count = vec![0u64; nodes.len()];
    // Post-order over an explicit stack: (node, children done).
    let mut stack = vec![(0u32, false)];
    while let Some((ni, done)) = stack.pop() {
        let node = &nodes[ni as usize];
        if node.is_leaf() {
            let lo = node.first_index;
            out[ni as usize] = (lo, lo + node.prim_count);
            count[ni as usize] = node.prim_count as u64;
        } else if !done {
            stack.push((ni, true));
            stack.push((node.first_index, false));
            stack.push((node.first_index + 1, false));
        } else {
            let (a, b) = (node.first_index as usize, node.first_index as usize + 1);
            let lo = out[a].0.min(out[b].0);
            let hi = out[a].1.max(out[b].1);
            count[ni as usize] = count[a] + count[b];
            if (hi - lo) as u64 != count[ni as usize] {
                return Vec::new();
            }
            out[ni as usize] = (lo, hi);
        }
    }
    out
}

/// `n / |n|` for each normal, with `|n| = sqrt(nx^2 + ny^2 + nz^2)`; zero or non-finite normals
/// are an error.
pub fn normalized(normals: &[V3]) -> Result<Vec<V3>> {
    normals
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let l = dot(*n, *n).sqrt();
            if !(l > 0.0 && l.is_finite()) {
                return invalid(format!("leaf {i} normal {n:?} is zero or not finite"));
            }
            Ok([n[0] / l, n[1] / l, n[2] / l])
        })
        .collect()
}
