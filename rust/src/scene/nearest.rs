//! Clearance: the distance from points to the nearest leaf disk, found on the scene's BVH by
//! a nearest-first walk that skips every node whose box is farther than the best distance
//! so far. The walk takes any primitive whose BVH boxes hold it and a distance function
//! (`physics::distance`), so further primitives (branch cylinders, bark triangles) reuse it.

use crate::error::{invalid, Result};
use crate::math::vec3::{is_finite3, V3};
use crate::physics::distance::{point_box_distance, point_disk_distance};
use crate::scene::{Scene, MAX_COORDINATE};
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

/// The nearest primitive to a point: its distance (m) and its index (the caller's, for
/// leaves). Among primitives at the same distance, the smallest index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    pub distance: f64,
    pub index: usize,
}

/// A node's box as f64 corners.
#[inline(always)]
fn node_box(bvh: &Bvh2, ni: u32) -> (V3, V3) {
    let a = bvh.nodes[ni as usize].aabb();
    (
        [a.min.x as f64, a.min.y as f64, a.min.z as f64],
        [a.max.x as f64, a.max.y as f64, a.max.z as f64],
    )
}

/// The largest absolute coordinate of the root box (0 for an empty BVH).
fn extent(bvh: &Bvh2) -> f64 {
    if bvh.nodes.is_empty() {
        return 0.0;
    }
    let (lo, hi) = node_box(bvh, 0);
    lo.iter().chain(&hi).fold(0.0, |m: f64, x| m.max(x.abs()))
}

/// The nearest primitive to `p` among those of `bvh`, where `distance(i)` is the distance to
/// the primitive at BVH position `i` (`primitive_indices`), `id(i)` its index for ties and
/// for the result, and every primitive lies inside the boxes of the nodes above it. None for
/// an empty BVH.
///
/// A node is skipped only when its box is farther than the best distance so far by more than
/// `slack` (m): the distances in floating point may differ from the box's bound by rounding,
/// and the slack (far above it) keeps the result that of testing every primitive.
pub fn nearest_in(
    bvh: &Bvh2,
    p: V3,
    slack: f64,
    distance: impl Fn(usize) -> f64,
    id: impl Fn(usize) -> usize,
) -> Option<Nearest> {
    if bvh.nodes.is_empty() {
        return None;
    }
    let mut best: Option<Nearest> = None;
    let far = |best: &Option<Nearest>, lb: f64| best.is_some_and(|b| lb > b.distance + slack);
    let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
    let (lo, hi) = node_box(bvh, 0);
    stack.push((0, point_box_distance(p, lo, hi)));
    while let Some((ni, lb)) = stack.pop() {
        if far(&best, lb) {
            continue;
        }
        let node = &bvh.nodes[ni as usize];
        if node.is_leaf() {
            let first = node.first_index as usize;
            for i in first..first + node.prim_count as usize {
                let (d, k) = (distance(i), id(i));
                let better = match best {
                    None => true,
                    Some(b) => d < b.distance || (d == b.distance && k < b.index),
                };
                if better {
                    best = Some(Nearest {
                        distance: d,
                        index: k,
                    });
                }
            }
        } else {
            let (a, b) = (node.first_index, node.first_index + 1);
            let (la, ha) = node_box(bvh, a);
            let (lb_, hb) = node_box(bvh, b);
            let (da, db) = (
                point_box_distance(p, la, ha),
                point_box_distance(p, lb_, hb),
            );
            // the nearer child on top, visited first
            if da <= db {
                stack.push((b, db));
                stack.push((a, da));
            } else {
                stack.push((a, da));
                stack.push((b, db));
            }
        }
    }
    best
}

/// Relative slack of the walk's skipping test, in units of the coordinates' magnitude: the
/// rounding of a distance is a few ulps of the coordinates (about 1e-16), far below it.
const SLACK: f64 = 1e-9;

impl Scene {
    /// The nearest leaf disk to each point (distance in m, the caller's leaf index), points in
    /// parallel. Exactly the minimum of `physics::distance::point_disk_distance` over every
    /// leaf (ties to the smallest index), for any number of threads. Points must be finite and
    /// within [`MAX_COORDINATE`] of the origin (as leaves are).
    pub fn clearance(&self, points: &[V3]) -> Result<Vec<Nearest>> {
        let bad = |p: &V3| !is_finite3(*p) || p.iter().any(|x| x.abs() > MAX_COORDINATE);
        if let Some(i) = points.iter().position(bad) {
            return invalid(format!(
                "point {i} is {:?}; clearance needs finite points within {MAX_COORDINATE:e} m",
                points[i]
            ));
        }
        let bvh = &self.bvh;
        let scale = extent(bvh);
        let distance_of = |p: V3| {
            let slack = SLACK * (scale + p.iter().fold(0.0, |m: f64, x| m.max(x.abs())));
            let at = |i: usize| bvh.primitive_indices[i] as usize;
            nearest_in(
                bvh,
                p,
                slack,
                |i| {
                    let s = at(i);
                    point_disk_distance(p, self.centers.get(s), self.normals.get(s), self.radii[s])
                },
                |i| self.ids[at(i)] as usize,
            )
            .expect("a scene has at least one leaf")
        };
        Ok(points.par_iter().map(|&p| distance_of(p)).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::uniforms;

    /// `n` leaves in a 4 m cube with random normals and radii 1-5 cm, and a few coincident.
    fn scene(n: usize, seed: u64) -> (Scene, Vec<V3>, Vec<V3>, Vec<f64>) {
        let mut u = uniforms(seed);
        let mut c: Vec<V3> = (0..n)
            .map(|_| [4.0 * u() - 2.0, 4.0 * u() - 2.0, 4.0 * u() - 2.0])
            .collect();
        let nv: Vec<V3> = (0..n)
            .map(|_| {
                let v = [u() - 0.5, u() - 0.5, u() - 0.5];
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                [v[0] / l, v[1] / l, v[2] / l]
            })
            .collect();
        let r: Vec<f64> = (0..n).map(|_| 0.01 + 0.04 * u()).collect();
        for k in (0..n).step_by(17).skip(1) {
            c[k] = c[k - 1];
        }
        let s = Scene::new(c.clone(), nv.clone(), r.clone()).unwrap();
        (s, c, nv, r)
    }

    fn brute(p: V3, c: &[V3], n: &[V3], r: &[f64]) -> Nearest {
        let mut best = Nearest {
            distance: f64::INFINITY,
            index: 0,
        };
        for i in 0..c.len() {
            let d = point_disk_distance(p, c[i], n[i], r[i]);
            if d < best.distance {
                best = Nearest {
                    distance: d,
                    index: i,
                };
            }
        }
        best
    }

    #[test]
    fn the_bvh_walk_finds_the_nearest_leaf_of_a_test_of_every_leaf() {
        let (s, c, n, r) = scene(5000, 3);
        let mut u = uniforms(9);
        let mut pts: Vec<V3> = (0..400)
            .map(|_| [8.0 * u() - 4.0, 8.0 * u() - 4.0, 8.0 * u() - 4.0])
            .collect();
        // on leaves: at a centre, and on a rim
        pts.push(c[10]);
        let e = crate::math::vec3::cross(n[20], [1.0, 0.0, 0.0]);
        let l = crate::math::vec3::norm(e);
        pts.push([
            c[20][0] + r[20] * e[0] / l,
            c[20][1] + r[20] * e[1] / l,
            c[20][2] + r[20] * e[2] / l,
        ]);
        let got = s.clearance(&pts).unwrap();
        for (p, g) in pts.iter().zip(&got) {
            assert_eq!(*g, brute(*p, &c, &n, &r), "point {p:?}");
        }
        assert_eq!(got[400].distance, 0.0);
    }

    #[test]
    fn a_non_finite_point_is_refused_by_index() {
        let (s, ..) = scene(10, 1);
        let e = s.clearance(&[[0.0; 3], [f64::NAN, 0.0, 0.0]]).unwrap_err();
        assert!(e.to_string().contains("point 1"), "{e}");
        let e = s.clearance(&[[1e300, 0.0, 0.0]]).unwrap_err();
        assert!(e.to_string().contains("point 0"), "{e}");
    }
}
