//! Distances from a point to the scene's solid primitives (docs/model.md §6, clearance): the
//! leaf disk here; further primitives (branch cylinders, bark triangles) add their own.
//!
//! Each distance is written with plain IEEE operations (no fused multiply-add, no libm), in
//! the order of `batecho.reference.point_disk_distance`, so that the NumPy reference and this
//! core give the same bits on every platform.

use crate::math::vec3::{dot, V3};

/// Euclidean distance (m) from `p` to the disk of centre `c`, unit normal `n` and radius `a`
/// (the closed set `{x : (x - c) . n = 0, |x - c| <= a}`).
///
/// With `d = p - c`, the height above the disk's plane `h = d . n` and the in-plane part
/// `q = d - h n` of length `rho`: the nearest point of the disk is `c + q` when `rho <= a`
/// (distance `|h|`), else the rim point `c + a q / rho` (distance `sqrt(h^2 + (rho - a)^2)`).
#[inline]
pub fn point_disk_distance(p: V3, c: V3, n: V3, a: f64) -> f64 {
    let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    let h = dot(d, n);
    let q = [d[0] - h * n[0], d[1] - h * n[1], d[2] - h * n[2]];
    let rho = dot(q, q).sqrt();
    if rho <= a {
        h.abs()
    } else {
        let t = rho - a;
        (h * h + t * t).sqrt()
    }
}

/// A lower bound (m) on the distance from `p` to anything inside the box `[lo, hi]`: the
/// distance to the box, zero inside it.
#[inline]
pub fn point_box_distance(p: V3, lo: V3, hi: V3) -> f64 {
    let mut s = 0.0;
    for k in 0..3 {
        let e = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
        s += e * e;
    }
    s.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: V3 = [0.0, 0.0, 1.0];

    #[test]
    fn a_point_on_the_disk_is_at_distance_zero() {
        assert_eq!(point_disk_distance([0.3, -0.2, 0.0], [0.0; 3], N, 0.5), 0.0);
        assert_eq!(point_disk_distance([0.0; 3], [0.0; 3], N, 0.5), 0.0);
    }

    #[test]
    fn a_point_on_the_axis_is_at_its_height() {
        assert_eq!(point_disk_distance([0.0, 0.0, -2.5], [0.0; 3], N, 0.1), 2.5);
    }

    #[test]
    fn a_point_in_the_plane_beyond_the_rim_is_at_its_distance_from_the_rim() {
        assert_eq!(point_disk_distance([3.0, 0.0, 0.0], [0.0; 3], N, 1.0), 2.0);
        assert_eq!(point_disk_distance([0.0, -1.0, 0.0], [0.0; 3], N, 1.0), 0.0);
    }

    #[test]
    fn a_point_off_the_plane_beyond_the_rim_goes_to_the_rim() {
        // rim point (1, 0, 0); the point (4, 0, 4) is 5 m from it
        assert_eq!(point_disk_distance([4.0, 0.0, 4.0], [0.0; 3], N, 1.0), 5.0);
    }

    #[test]
    fn the_box_distance_is_zero_inside_and_euclidean_outside() {
        let (lo, hi) = ([0.0; 3], [1.0; 3]);
        assert_eq!(point_box_distance([0.5, 0.5, 0.5], lo, hi), 0.0);
        assert_eq!(point_box_distance([4.0, 5.0, 0.5], lo, hi), 5.0);
    }
}
