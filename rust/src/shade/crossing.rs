//! The exact crossing tests of shading (docs/model.md §10), with every vector relative to the
//! sonar: the open segment from the sonar to a scatterer at `w` (`t w`, `0 < t < 1`) against a
//! leaf disk and a branch cylinder. The NumPy reference performs the same operations in the same
//! order, so that both decide every ray alike, on a disk's rim included.
use crate::math::vec3::{dot, V3};

/// A leaf disk as the tests take it: centre `v` relative to the sonar, unit normal `n`, and
/// `n . v` and `a^2`.
#[derive(Clone, Copy, Debug)]
pub struct Disk {
    pub v: V3,
    pub n: V3,
    pub nv: f64,
    pub a2: f64,
}

impl Disk {
    #[inline(always)]
    pub fn new(v: V3, n: V3, radius: f64) -> Disk {
        Disk {
            v,
            n,
            nv: dot(n, v),
            a2: radius * radius,
        }
    }

    /// Whether the open segment `t w`, `0 < t < 1`, meets the disk's plane at one point inside
    /// its radius or on its rim: `d = n . w != 0`, `t = (n . v) / d` in (0, 1), and
    /// `|t w - v|^2 <= a^2`. A segment parallel to the plane (lying in it included) does not
    /// cross it.
    #[inline(always)]
    pub fn crossed_by(&self, w: V3) -> bool {
        let d = dot(self.n, w);
        if d == 0.0 {
            return false;
        }
        let t = self.nv / d;
        if !(t > 0.0 && t < 1.0) {
            return false;
        }
        let q = [
            t * w[0] - self.v[0],
            t * w[1] - self.v[1],
            t * w[2] - self.v[2],
        ];
        dot(q, q) <= self.a2
    }
}

/// A branch cylinder as the tests take it: its start `s` relative to the sonar, unit axis `u`,
/// length, and the parts of `s` along (`s . u`) and across (`e0 = s - (s . u) u`) the axis,
/// with `e0 . e0 - a^2`.
#[derive(Clone, Copy, Debug)]
pub struct Cylinder {
    pub u: V3,
    pub length: f64,
    pub su: f64,
    pub e0: V3,
    pub c: f64,
}

impl Cylinder {
    #[inline(always)]
    pub fn new(s: V3, u: V3, length: f64, radius: f64) -> Cylinder {
        let su = dot(s, u);
        let e0 = [s[0] - su * u[0], s[1] - su * u[1], s[2] - su * u[2]];
        Cylinder {
            u,
            length,
            su,
            e0,
            c: dot(e0, e0) - radius * radius,
        }
    }

    /// Whether the open segment `t w`, `0 < t < 1`, passes through the cylinder's interior:
    /// some `t` in (0, 1) where the point's distance from the axis is below the radius and its
    /// axial coordinate `t (w . u) - s . u` lies strictly between 0 and the length. A segment
    /// that only touches the surface does not.
    #[inline(always)]
    pub fn crossed_by(&self, w: V3) -> bool {
        let u = self.u;
        let sw = dot(w, u);
        let e1 = [w[0] - sw * u[0], w[1] - sw * u[1], w[2] - sw * u[2]];
        // |t e1 - e0|^2 < a^2: qa t^2 - 2 qb t + c < 0
        let qa = dot(e1, e1);
        let qb = dot(self.e0, e1);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        if qa == 0.0 {
            if !(self.c < 0.0) {
                return false;
            }
        } else {
            let disc = qb * qb - qa * self.c;
            if !(disc > 0.0) {
                return false;
            }
            let root = disc.sqrt();
            lo = lo.max((qb - root) / qa);
            hi = hi.min((qb + root) / qa);
        }
        // 0 < t sw - s.u < length
        if sw == 0.0 {
            let s = -self.su;
            if !(s > 0.0 && s < self.length) {
                return false;
            }
        } else {
            let (t0, t1) = (self.su / sw, (self.su + self.length) / sw);
            let (a, b) = if sw > 0.0 { (t0, t1) } else { (t1, t0) };
            lo = lo.max(a);
            hi = hi.min(b);
        }
        lo < hi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_disk_across_the_ray_is_crossed_and_one_behind_the_target_is_not() {
        let disk = Disk::new([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.1);
        assert!(disk.crossed_by([2.0, 0.0, 0.0]));
        assert!(disk.crossed_by([2.0, 0.19, 0.0]));
        assert!(!disk.crossed_by([2.0, 0.21, 0.0]));
        assert!(!disk.crossed_by([0.5, 0.0, 0.0]));
        // the target in the disk's plane: t = 1 is not in the open segment
        assert!(!disk.crossed_by([1.0, 0.05, 0.0]));
        // a ray lying in the plane of an edge-on disk
        let edge_on = Disk::new([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], 0.1);
        assert!(!edge_on.crossed_by([2.0, 0.0, 0.0]));
    }

    #[test]
    fn a_ray_on_the_rim_counts_as_crossing() {
        // t = 0.5 exactly, the hit at distance 0.25 from the centre, radius 0.25
        let disk = Disk::new([1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.25);
        assert!(disk.crossed_by([2.0, 0.5, 0.0]));
        assert!(!disk.crossed_by([2.0, 0.5000001, 0.0]));
    }

    #[test]
    fn a_trunk_across_the_ray_blocks_and_a_ray_past_its_end_does_not() {
        // a vertical trunk at x = 2 from z = -1 to z = 3, radius 0.2
        let cyl = Cylinder::new([2.0, 0.0, -1.0], [0.0, 0.0, 1.0], 4.0, 0.2);
        assert!(cyl.crossed_by([4.0, 0.0, 0.0]));
        assert!(cyl.crossed_by([4.0, 0.3, 0.0]));
        assert!(!cyl.crossed_by([4.0, 0.5, 0.0]));
        assert!(!cyl.crossed_by([4.0, 0.0, 7.0]));
        assert!(!cyl.crossed_by([1.0, 0.0, 0.0]));
        // a ray along the axis, inside the radius
        let along = Cylinder::new([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 1.0, 0.1);
        assert!(along.crossed_by([0.0, 0.0, 3.0]));
        assert!(!along.crossed_by([0.0, 0.0, 0.5]));
        assert!(along.crossed_by([0.3, 0.0, 30.0]));
        assert!(!along.crossed_by([4.0, 0.0, 30.0]));
        // touching the surface is not passing through
        let side = Cylinder::new([1.0, 0.1, -1.0], [0.0, 0.0, 1.0], 2.0, 0.1);
        assert!(!side.crossed_by([2.0, 0.0, 0.0]));
    }
}
