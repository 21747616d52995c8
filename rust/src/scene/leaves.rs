//! Leaves as disks (centre, unit normal, radius), validated and stored in the BVH's
//! depth-first order, with the BVH built once and reused for every pose.
use crate::budget;
use crate::error::{invalid, Result};
use crate::math::vec3::{dot, MAX_NORM, MIN_NORM, V3};
use crate::physics::leaf::{PAPER_BP, PAPER_PP};
use crate::scene::bvh::dfs_order;
use crate::scene::bvh::point_box;
use crate::scene::bvh::subtree_ranges;
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
        if !(a > 0.0 && a <= MAX_COORDINATE) {
            return invalid(format!(
                "leaf {i} radius must be > 0 and at most {MAX_COORDINATE:e} m, got {a}"
            ));
        }
    }
    Ok(())
}

impl Scene {
    /// Build a scene. Normals must already be unit vectors (see [`normalized`]).
    pub fn new(centers: Vec<V3>, normals: Vec<V3>, radii: Vec<f64>) -> Result<Scene> {
        budget::check(
            centers.len() as f64 * budget::BYTES_PER_LEAF,
            || format!("a scene of {} leaves", centers.len()),
            "split the leaves into several scenes",
        )?;
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

/// `n / |n|` for each normal, with `|n| = sqrt(nx^2 + ny^2 + nz^2)`; a normal whose length is
/// outside [`MIN_NORM`, `MAX_NORM`] (zero, or too short or long to normalise in f64 without
/// losing precision) is an error.
pub fn normalized(normals: &[V3]) -> Result<Vec<V3>> {
    normals
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let l = dot(*n, *n).sqrt();
            if !(MIN_NORM..=MAX_NORM).contains(&l) {
                return invalid(format!(
                    "leaf {i} normal {n:?} has length {l:e}, outside [{MIN_NORM:e}, {MAX_NORM:e}]: \
                     too short or long to normalise in f64"
                ));
            }
            Ok([n[0] / l, n[1] / l, n[2] / l])
        })
        .collect()
}
