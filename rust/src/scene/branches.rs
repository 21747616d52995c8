//! Branches as straight cylinder segments (start, end, radius), validated, with what every pose
//! needs of them once: unit axes, lengths, bounding spheres, and which segments meet at a
//! shared end point (the joints of one skeleton).
use crate::budget;
use crate::error::{invalid, Result};
use crate::math::vec3::{dot, V3};
use crate::physics::distance::point_box_distance;
use crate::scene::bvh::segment_box;
use crate::scene::leaves::MAX_COORDINATE;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::BvhBuildParams;
use std::collections::HashMap;
use std::time::Duration;

/// Cylinder segments in the caller's order (`i` is the caller's index everywhere).
#[derive(Clone, Default)]
pub struct Branches {
    pub starts: Vec<V3>,
    pub ends: Vec<V3>,
    pub radii: Vec<f64>,
    /// `|end - start|` and the unit axis `(end - start) / length`.
    pub lengths: Vec<f64>,
    pub axes: Vec<V3>,
    /// Bounding spheres: the midpoint and `length / 2 + radius`.
    pub mids: Vec<V3>,
    pub bound_radii: Vec<f64>,
    /// Segments joined to segment `i` (sharing an end point, bit for bit):
    /// `joined[joined_at[i]..joined_at[i + 1]]`, ascending.
    pub joined: Vec<u32>,
    pub joined_at: Vec<u32>,
    /// The smallest radius and its first segment.
    pub smallest: (usize, f64),
    /// A BVH over the segments' boxes (caller's order: `primitive_indices` are segment
    /// indices), for clearance.
    pub bvh: Bvh2,
}

impl std::fmt::Debug for Branches {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // (the BVH is derived from the segments)
        f.debug_struct("Branches")
            .field("starts", &self.starts)
            .field("ends", &self.ends)
            .field("radii", &self.radii)
            .finish_non_exhaustive()
    }
}

impl Branches {
    /// Validate and prepare segments: equal lengths, finite coordinates within
    /// [`MAX_COORDINATE`], finite radii > 0, distinct end points. Messages name the first
    /// offending segment.
    pub fn new(starts: Vec<V3>, ends: Vec<V3>, radii: Vec<f64>) -> Result<Branches> {
        let n = starts.len();
        if ends.len() != n || radii.len() != n {
            return invalid(format!(
                "branch arrays differ in length: {} starts, {} ends, {} radii",
                n,
                ends.len(),
                radii.len()
            ));
        }
        if n > u32::MAX as usize - 1 {
            return invalid("at most 2^32 - 2 branch segments are supported");
        }
        budget::check(
            n as f64 * budget::BYTES_PER_SEGMENT,
            || format!("a scene of {n} branch segments"),
            "split the branches into several scenes",
        )?;
        for (name, pts) in [("start", &starts), ("end", &ends)] {
            for (i, c) in pts.iter().enumerate() {
                if !c.iter().all(|x| x.is_finite()) {
                    return invalid(format!("branch {i} has a non-finite {name} {c:?}"));
                }
                if c.iter().any(|x| x.abs() > MAX_COORDINATE) {
                    return invalid(format!(
                        "branch {i} has a {name} coordinate beyond {MAX_COORDINATE:e} m: {c:?}"
                    ));
                }
            }
        }
        for (i, &a) in radii.iter().enumerate() {
            if !(a.is_finite() && a > 0.0) {
                return invalid(format!("branch {i} radius must be finite and > 0, got {a}"));
            }
        }
        let mut lengths = Vec::with_capacity(n);
        let mut axes = Vec::with_capacity(n);
        let mut mids = Vec::with_capacity(n);
        let mut bound_radii = Vec::with_capacity(n);
        for i in 0..n {
            let (a, b) = (starts[i], ends[i]);
            let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let l = dot(d, d).sqrt();
            if !(l > 0.0 && l.is_finite()) {
                return invalid(format!(
                    "branch {i} has zero length (start {a:?} equals end {b:?})"
                ));
            }
            lengths.push(l);
            axes.push([d[0] / l, d[1] / l, d[2] / l]);
            mids.push([a[0] + 0.5 * d[0], a[1] + 0.5 * d[1], a[2] + 0.5 * d[2]]);
            bound_radii.push(0.5 * l + radii[i]);
        }
        let (joined, joined_at) = joints(&starts, &ends)?;
        let boxes: Vec<_> = (0..n)
            .map(|i| segment_box(starts[i], ends[i], radii[i]))
            .collect();
        let bvh = if n == 0 {
            Bvh2::default()
        } else {
            build_bvh2(
                &boxes,
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            )
        };
        let smallest = radii
            .iter()
            .copied()
            .enumerate()
            .fold(
                (0, f64::INFINITY),
                |acc, (i, a)| if a < acc.1 { (i, a) } else { acc },
            );
        Ok(Branches {
            starts,
            ends,
            radii,
            lengths,
            axes,
            mids,
            bound_radii,
            joined,
            joined_at,
            smallest,
            bvh,
        })
    }

    pub fn len(&self) -> usize {
        self.radii.len()
    }

    pub fn is_empty(&self) -> bool {
        self.radii.is_empty()
    }

    /// The segments joined to segment `i` (ascending).
    #[inline]
    pub fn joined_to(&self, i: usize) -> &[u32] {
        &self.joined[self.joined_at[i] as usize..self.joined_at[i + 1] as usize]
    }

    /// The segments (ascending) whose BVH box comes within `reach` (m) of `p`: every segment
    /// whose surface does (`distance_to_segment - radius <= reach`), found on the BVH, since a
    /// box holds its cylinder. The distances are compared with a slack of 1e-9 of the reach
    /// and the coordinates (far above their rounding), so the list never misses one.
    pub fn within(&self, p: V3, reach: f64) -> Vec<u32> {
        let bvh = &self.bvh;
        let mut out = Vec::new();
        if bvh.nodes.is_empty() || !(reach >= 0.0) {
            return out;
        }
        let scale = p.iter().fold(reach, |m, x| m.max(x.abs()));
        let limit = reach + 1e-9 * (1.0 + scale);
        let node_near = |ni: usize| {
            let a = bvh.nodes[ni].aabb();
            let lo = [a.min.x as f64, a.min.y as f64, a.min.z as f64];
            let hi = [a.max.x as f64, a.max.y as f64, a.max.z as f64];
            point_box_distance(p, lo, hi) <= limit
        };
        let mut stack = vec![0usize];
        while let Some(ni) = stack.pop() {
            if !node_near(ni) {
                continue;
            }
            let node = &bvh.nodes[ni];
            if node.is_leaf() {
                let first = node.first_index as usize;
                out.extend(&bvh.primitive_indices[first..first + node.prim_count as usize]);
            } else {
                let c = node.first_index as usize;
                stack.extend([c, c + 1]);
            }
        }
        out.sort_unstable();
        out
    }
}

/// For each segment, the other segments that share one of its end points exactly, as CSR
/// lists (ascending).
fn joints(starts: &[V3], ends: &[V3]) -> Result<(Vec<u32>, Vec<u32>)> {
    let key = |v: V3| v.map(f64::to_bits);
    let mut at: HashMap<[u64; 3], Vec<u32>> = HashMap::new();
    for (i, (s, e)) in starts.iter().zip(ends).enumerate() {
        at.entry(key(*s)).or_default().push(i as u32);
        if key(*e) != key(*s) {
            at.entry(key(*e)).or_default().push(i as u32);
        }
    }
    // (segments sharing one end point are all joined: k of them make k (k - 1) entries,
    // which many segments from one point would make more than memory holds)
    let joints: f64 = at
        .values()
        .map(|v| v.len() as f64 * (v.len() as f64 - 1.0))
        .sum();
    let crowded = at.values().map(Vec::len).max().unwrap_or(0);
    budget::check(
        joints * budget::BYTES_PER_JOINT,
        || {
            format!(
                "joining {} branch segments at their shared end points ({crowded} share one)",
                starts.len()
            )
        },
        "share each end point among fewer segments",
    )?;
    if joints >= u32::MAX as f64 {
        return invalid(format!(
            "branch segments share end points too often: {joints:e} joints (at most 2^32 - 1; \
             {crowded} segments share one point)"
        ));
    }
    let mut joined = Vec::new();
    let mut joined_at = Vec::with_capacity(starts.len() + 1);
    joined_at.push(0u32);
    for (i, (s, e)) in starts.iter().zip(ends).enumerate() {
        let mut mine: Vec<u32> = at[&key(*s)]
            .iter()
            .chain(&at[&key(*e)])
            .copied()
            .filter(|&j| j as usize != i)
            .collect();
        mine.sort_unstable();
        mine.dedup();
        joined.extend(mine);
        joined_at.push(joined.len() as u32);
    }
    Ok((joined, joined_at))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_sharing_an_end_point_are_joined() {
        let b = Branches::new(
            vec![
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [5.0, 0.0, 0.0],
            ],
            vec![
                [0.0, 0.0, 1.0],
                [0.0, 0.0, 2.0],
                [1.0, 0.0, 1.5],
                [6.0, 0.0, 0.0],
            ],
            vec![0.1, 0.08, 0.03, 0.01],
        )
        .unwrap();
        assert_eq!(b.joined_to(0), &[1, 2]);
        assert_eq!(b.joined_to(1), &[0, 2]);
        assert_eq!(b.joined_to(2), &[0, 1]);
        assert!(b.joined_to(3).is_empty());
        assert_eq!(b.smallest, (3, 0.01));
        assert_eq!(b.lengths[0], 1.0);
        assert_eq!(b.bound_radii[0], 0.6);
    }

    #[test]
    fn bad_segments_are_refused_by_index() {
        let e = Branches::new(vec![[0.0; 3]], vec![[0.0; 3]], vec![0.1]).unwrap_err();
        assert!(e.to_string().contains("branch 0 has zero length"), "{e}");
        let e = Branches::new(
            vec![[0.0; 3], [0.0; 3]],
            vec![[1.0; 3], [1.0; 3]],
            vec![0.1, -1.0],
        )
        .unwrap_err();
        assert!(e.to_string().contains("branch 1 radius"), "{e}");
        let e = Branches::new(vec![[0.0, f64::NAN, 0.0]], vec![[1.0; 3]], vec![0.1]).unwrap_err();
        assert!(e.to_string().contains("non-finite start"), "{e}");
    }

    #[test]
    fn within_holds_every_segment_whose_surface_is_within_the_reach() {
        use crate::physics::branch::distance_to_segment;
        // a deterministic scatter of segments (a small linear congruential generator)
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut starts, mut ends, mut radii) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..3000 {
            let a = [20.0 * next(), 20.0 * next(), 8.0 * next()];
            let d = [next() - 0.5, next() - 0.5, 2.0 * next()];
            starts.push(a);
            ends.push([a[0] + d[0], a[1] + d[1], a[2] + d[2]]);
            radii.push(0.005 + 0.2 * next());
        }
        let b = Branches::new(starts, ends, radii).unwrap();
        for q in 0..40 {
            let p = [20.0 * next(), 20.0 * next(), 8.0 * next()];
            let reach = 0.5 * q as f64 / 4.0;
            let got = b.within(p, reach);
            assert!(got.windows(2).all(|w| w[0] < w[1]), "ascending, no repeats");
            for i in 0..b.len() {
                let near = distance_to_segment(p, b.starts[i], b.ends[i]) - b.radii[i];
                if near <= reach {
                    assert!(got.binary_search(&(i as u32)).is_ok(), "segment {i} missed");
                }
            }
            // (and it is a pruning: far fewer than all once the reach is small)
            if reach < 1.0 {
                assert!(got.len() < b.len() / 4, "{} of {}", got.len(), b.len());
            }
        }
    }
}
