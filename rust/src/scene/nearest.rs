//! Clearance: the distance from points to the nearest leaf disk or branch cylinder, found on
//! the scene's BVHs by a nearest-first walk that skips every node whose box is farther than
//! the best distance so far. The walk takes any primitive whose BVH boxes hold it and a
//! distance function (`physics::distance`): leaves and branches each have their own BVH.

use crate::error::{invalid, Result};
use crate::math::vec3::{is_finite3, V3};
use crate::physics::distance::{point_box_distance, point_cylinder_distance, point_disk_distance};
use crate::scene::{Scene, MAX_COORDINATE};
use obvhs::bvh2::Bvh2;
use rayon::prelude::*;

/// The nearest primitive to a point: its distance (m), its index (the caller's, for leaves
/// and branches) and whether it is a branch. Among primitives at the same distance, the
/// smallest index, and a leaf before a branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    pub distance: f64,
    pub index: usize,
    pub branch: bool,
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

/// Push the two children of an inner node (the first at BVH position `first`) with their
/// boxes' distances from `p`, the nearer on top so that it is visited first.
#[inline(always)]
fn push_children(bvh: &Bvh2, p: V3, first: u32, stack: &mut Vec<(u32, f64)>) {
    let (a, b) = (first, first + 1);
    let (la, ha) = node_box(bvh, a);
    let (lb, hb) = node_box(bvh, b);
    let (da, db) = (point_box_distance(p, la, ha), point_box_distance(p, lb, hb));
    if da <= db {
        stack.push((b, db));
        stack.push((a, da));
    } else {
        stack.push((a, da));
        stack.push((b, db));
    }
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
                        branch: false,
                    });
                }
            }
        } else {
            push_children(bvh, p, node.first_index, &mut stack);
        }
    }
    best
}

/// The smaller of `bound` and the distance from `p` to the nearest primitive of `bvh`
/// (`distance(i)` for the primitive at BVH position `i`): the walk of [`nearest_in`] started
/// with `bound` as its best, so that it skips every node farther than that by `slack`.
pub fn nearest_below(
    bvh: &Bvh2,
    p: V3,
    slack: f64,
    bound: f64,
    distance: impl Fn(usize) -> f64,
) -> f64 {
    if bvh.nodes.is_empty() {
        return bound;
    }
    let mut best = bound;
    let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
    let (lo, hi) = node_box(bvh, 0);
    stack.push((0, point_box_distance(p, lo, hi)));
    while let Some((ni, lb)) = stack.pop() {
        if lb > best + slack {
            continue;
        }
        let node = &bvh.nodes[ni as usize];
        if node.is_leaf() {
            let first = node.first_index as usize;
            for i in first..first + node.prim_count as usize {
                best = best.min(distance(i));
            }
        } else {
            push_children(bvh, p, node.first_index, &mut stack);
        }
    }
    best
}

/// Relative slack of the walk's skipping test, in units of the coordinates' magnitude: the
/// rounding of a distance is a few ulps of the coordinates (about 1e-16), far below it.
const SLACK: f64 = 1e-9;

impl Scene {
    /// The nearest leaf disk or branch cylinder to each point (distance in m, the caller's
    /// index, which of the two), points in parallel. Exactly the minimum of
    /// `physics::distance::point_disk_distance` over every leaf and of
    /// `point_cylinder_distance` over every branch (ties to the smallest index, leaves before
    /// branches), for any number of threads. Points must be finite and within
    /// [`MAX_COORDINATE`] of the origin (as leaves are).
    pub fn clearance(&self, points: &[V3]) -> Result<Vec<Nearest>> {
        check_points(points)?;
        let bvh = &self.bvh;
        let br = &self.branches;
        let (scale, wood_scale) = (extent(bvh), extent(&br.bvh));
        let distance_of = |p: V3| {
            let size = p.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
            let at = |i: usize| bvh.primitive_indices[i] as usize;
            let leaf = nearest_in(
                bvh,
                p,
                SLACK * (scale + size),
                |i| {
                    let s = at(i);
                    point_disk_distance(p, self.centers.get(s), self.normals.get(s), self.radii[s])
                },
                |i| self.ids[at(i)] as usize,
            );
            let seg = |i: usize| br.bvh.primitive_indices[i] as usize;
            let wood = nearest_in(
                &br.bvh,
                p,
                SLACK * (wood_scale + size),
                |i| {
                    let j = seg(i);
                    point_cylinder_distance(p, br.starts[j], br.axes[j], br.lengths[j], br.radii[j])
                },
                seg,
            )
            .map(|w| Nearest { branch: true, ..w });
            match (leaf, wood) {
                (Some(l), Some(w)) => {
                    if w.distance < l.distance {
                        w
                    } else {
                        l
                    }
                }
                (Some(n), None) | (None, Some(n)) => n,
                (None, None) => unreachable!("a scene has at least one leaf or branch"),
            }
        };
        Ok(points.par_iter().map(|&p| distance_of(p)).collect())
    }

    /// The smallest clearance of a set of points, or `upper` (m, >= 0, may be infinite) if
    /// every point is farther than that from every leaf and branch: exactly
    /// `min(upper, min over points of clearance)`. The points are walked in turn, each walk
    /// skipping what lies beyond the smallest distance found so far.
    pub fn min_clearance(&self, points: &[V3], upper: f64) -> Result<f64> {
        check_points(points)?;
        if upper.is_nan() || upper < 0.0 {
            return invalid(format!("upper must be >= 0 (m), got {upper}"));
        }
        let (bvh, br) = (&self.bvh, &self.branches);
        let (scale, wood_scale) = (extent(bvh), extent(&br.bvh));
        let mut best = upper;
        for &p in points {
            let size = p.iter().fold(0.0, |m: f64, x| m.max(x.abs()));
            best = nearest_below(bvh, p, SLACK * (scale + size), best, |i| {
                let s = bvh.primitive_indices[i] as usize;
                point_disk_distance(p, self.centers.get(s), self.normals.get(s), self.radii[s])
            });
            best = nearest_below(&br.bvh, p, SLACK * (wood_scale + size), best, |i| {
                let j = br.bvh.primitive_indices[i] as usize;
                point_cylinder_distance(p, br.starts[j], br.axes[j], br.lengths[j], br.radii[j])
            });
        }
        Ok(best)
    }
}

/// Points must be finite and within [`MAX_COORDINATE`] of the origin (as leaves are).
fn check_points(points: &[V3]) -> Result<()> {
    let bad = |p: &V3| !is_finite3(*p) || p.iter().any(|x| x.abs() > MAX_COORDINATE);
    if let Some(i) = points.iter().position(bad) {
        return invalid(format!(
            "point {i} is {:?}; clearance needs finite points within {MAX_COORDINATE:e} m",
            points[i]
        ));
    }
    Ok(())
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
            branch: false,
        };
        for i in 0..c.len() {
            let d = point_disk_distance(p, c[i], n[i], r[i]);
            if d < best.distance {
                best = Nearest {
                    distance: d,
                    index: i,
                    branch: false,
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
    fn the_smallest_clearance_of_a_set_is_the_least_of_the_points_clearances_or_the_bound() {
        let (s, _, _, _) = scene(3000, 4);
        let mut u = uniforms(12);
        for k in 0..20 {
            let pts: Vec<V3> = (0..1 + k * 3)
                .map(|_| [8.0 * u() - 4.0, 8.0 * u() - 4.0, 8.0 * u() - 4.0])
                .collect();
            let least = s
                .clearance(&pts)
                .unwrap()
                .iter()
                .fold(f64::INFINITY, |m, n| m.min(n.distance));
            for upper in [0.0, 0.05, 0.3, 1.0, f64::INFINITY] {
                assert_eq!(s.min_clearance(&pts, upper).unwrap(), least.min(upper));
            }
        }
        assert!(s.min_clearance(&[[0.0; 3]], -1.0).is_err());
        assert!(s.min_clearance(&[[f64::NAN, 0.0, 0.0]], 1.0).is_err());
    }

    #[test]
    fn with_branches_the_walk_finds_the_nearest_of_a_test_of_every_leaf_and_branch() {
        let (_, c, n, r) = scene(800, 5);
        let mut u = uniforms(11);
        let k = 300;
        let starts: Vec<V3> = (0..k)
            .map(|_| [4.0 * u() - 2.0, 4.0 * u() - 2.0, 4.0 * u() - 2.0])
            .collect();
        let ends: Vec<V3> = starts
            .iter()
            .map(|a| [a[0] + u() - 0.5, a[1] + u() - 0.5, a[2] + 2.0 * u()])
            .collect();
        let radii: Vec<f64> = (0..k).map(|_| 0.005 + 0.1 * u()).collect();
        let br = crate::scene::Branches::new(starts.clone(), ends, radii.clone()).unwrap();
        let s = Scene::with_branches(c.clone(), n.clone(), r.clone(), br.clone()).unwrap();
        let mut pts: Vec<V3> = (0..400)
            .map(|_| [6.0 * u() - 3.0, 6.0 * u() - 3.0, 6.0 * u() - 3.0])
            .collect();
        pts.push(starts[7]); // on a branch's end cap centre
        let got = s.clearance(&pts).unwrap();
        for (p, g) in pts.iter().zip(&got) {
            let leaf = brute(*p, &c, &n, &r);
            let mut wood = Nearest {
                distance: f64::INFINITY,
                index: 0,
                branch: true,
            };
            for (j, &rj) in radii.iter().enumerate() {
                let d = point_cylinder_distance(*p, br.starts[j], br.axes[j], br.lengths[j], rj);
                if d < wood.distance {
                    wood = Nearest {
                        distance: d,
                        index: j,
                        branch: true,
                    };
                }
            }
            let want = if wood.distance < leaf.distance {
                wood
            } else {
                leaf
            };
            assert_eq!(*g, want, "point {p:?}");
        }
        assert_eq!(got[400].distance, 0.0);
        assert!(got.iter().any(|g| g.branch) && got.iter().any(|g| !g.branch));
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
