//! Leaves as disks (centre, unit normal, radius) and the obvhs BVH over their centres, built
//! once and reused for every pose.

use crate::error::{invalid, Result};
use crate::leaf_model::{PAPER_BP, PAPER_PP};
use crate::pose::{dot, V3};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Coordinates beyond this (m) are refused: the BVH stores f32 boxes.
pub const MAX_COORDINATE: f64 = 1e15;

pub struct Scene {
    pub centers: Vec<V3>,
    pub normals: Vec<V3>,
    pub radii: Vec<f64>,
    /// `a^-0.9065` and `a^0.3523` of every radius (the paper model's `c^p = k^p a^p`).
    pub radius_pow_b: Vec<f64>,
    pub radius_pow_p: Vec<f64>,
    pub bvh: Bvh2,
    /// Wall time of the BVH build.
    pub build_time: Duration,
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
        let bvh = build_bvh2(&boxes, BvhBuildParams::fast_build(), &mut core);
        let build_time = start.elapsed();
        let radius_pow_b = radii.par_iter().map(|a| a.powf(PAPER_BP)).collect();
        let radius_pow_p = radii.par_iter().map(|a| a.powf(PAPER_PP)).collect();
        Ok(Scene {
            centers,
            normals,
            radii,
            radius_pow_b,
            radius_pow_p,
            bvh,
            build_time,
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
