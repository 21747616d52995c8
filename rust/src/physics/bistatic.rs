//! Bistatic geometry (docs/model.md §5a): a receiver at its own place in the sonar's frame, the
//! echo's delay range `(r_tx + r_rx) / 2`, the lobe rule's range `sqrt(r_tx r_rx)`, and the
//! incidence angle from the bisector of the two directions. With the receiver at the emitter
//! each reduces to the monostatic quantity (`r`, `r`, `angle(e, n)`).

use crate::math::vec3::{norm, V3};
use crate::physics::leaf::incidence;
use crate::physics::pose::Pose;
use std::f64::consts::FRAC_PI_2;

/// Below this `|e_tx + e_rx| = 2 cos(gamma / 2)` (a bistatic angle `gamma` within about 1e-4
/// rad of 180 degrees) a leaf is forward scattering, taken at grazing incidence: the
/// bisector's direction, rounding over `|b|`, would be uncertain by 1e-12 rad at most.
pub const FORWARD_SCATTER_B: f64 = 1e-4;

/// The world position of a point at `offset = (forward, left, up)` (m) in the pose's frame:
/// `p + (o_f d + o_l l + o_u u)`, componentwise in that order (a zero offset gives `p`).
#[inline]
pub fn place(pose: &Pose, offset: V3) -> V3 {
    let (d, l, u) = (pose.forward, pose.left, pose.up);
    std::array::from_fn(|i| {
        pose.position[i] + (offset[0] * d[i] + offset[1] * l[i] + offset[2] * u[i])
    })
}

/// The range whose round trip is the bistatic path: `(r_tx + r_rx) / 2` (m). The phase,
/// delay and absorption of an echo act over `2` times this; it is `r` when `r_tx = r_rx = r`.
#[inline(always)]
pub fn delay_range(r_tx: f64, r_rx: f64) -> f64 {
    (r_tx + r_rx) / 2.0
}

/// The range the lobe rule compares with the reach `sqrt(K G)`: the geometric mean
/// `sqrt(r_tx r_rx)`, so that `r_tx r_rx <= K G` (exactly `r` when `r_tx = r_rx = r`: the
/// square root of a rounded square is the number itself).
#[inline(always)]
pub fn lobe_range(r_tx: f64, r_rx: f64) -> f64 {
    (r_tx * r_rx).sqrt()
}

/// The incidence angle of a leaf of unit normal `n` seen from an emitter in the unit
/// direction `e_tx` and a receiver in `e_rx` (both from the source to the leaf), with its
/// cosine and sine: [`incidence`] of the bisector `b = (e_tx + e_rx) / |e_tx + e_rx|`, the
/// normal of the specular facet between the two. It is an approximation for small bistatic
/// angles, exact at zero (`e_tx = e_rx`). A leaf on or next to the segment between emitter
/// and receiver (`|e_tx + e_rx| <` [`FORWARD_SCATTER_B`], forward scattering) has no specular
/// direction: `b` has no limit there, and rounding would decide it. It is taken at grazing
/// incidence (`beta = pi/2`, `cos = 0`, `sin = 1`), which both leaf models make silent or
/// nearly so.
#[inline]
pub fn bisector_incidence(e_tx: V3, e_rx: V3, n: V3) -> (f64, f64, f64) {
    let b = [e_tx[0] + e_rx[0], e_tx[1] + e_rx[1], e_tx[2] + e_rx[2]];
    let nb = norm(b);
    if !(nb >= FORWARD_SCATTER_B) {
        return (FRAC_PI_2, 0.0, 1.0);
    }
    incidence([b[0] / nb, b[1] / nb, b[2] / nb], n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_receiver_at_the_emitter_gives_the_monostatic_quantities() {
        let pose = Pose::new([1.0, -2.0, 3.0], [0.3, 1.0, 0.1], [0.0, 0.0, 1.0]).unwrap();
        assert_eq!(place(&pose, [0.0; 3]), pose.position);
        let mut u = crate::test_util::uniforms(5);
        for _ in 0..10_000 {
            let r = 10f64.powf(4.0 * u() - 2.0);
            assert_eq!(delay_range(r, r), r);
            assert_eq!(lobe_range(r, r), r);
        }
        let e = [0.6, 0.0, 0.8];
        let n = [0.0, 0.6, 0.8];
        let (b, c, s) = bisector_incidence(e, e, n);
        let (b0, c0, s0) = incidence(e, n);
        assert!((b - b0).abs() < 1e-15 && (c - c0).abs() < 1e-15 && (s - s0).abs() < 1e-15);
    }

    #[test]
    fn a_leaf_between_emitter_and_receiver_is_at_grazing_incidence() {
        let (b, c, s) = bisector_incidence([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        assert_eq!((b, c, s), (FRAC_PI_2, 0.0, 1.0));
    }

    #[test]
    fn a_leaf_next_to_the_segment_is_forward_scattering() {
        // directions opposite up to rounding: b is noise, not a direction
        let e = [0.6, 0.0, 0.8];
        let almost = [-0.6 + 1e-16, 1e-17, -0.8];
        let (b, c, s) = bisector_incidence(e, almost, [0.0, 0.6, 0.8]);
        assert_eq!((b, c, s), (FRAC_PI_2, 0.0, 1.0));
        // a bistatic angle of 179.9 degrees still has a bisector
        let g = 179.9f64.to_radians();
        let (b, _, _) =
            bisector_incidence([1.0, 0.0, 0.0], [g.cos(), g.sin(), 0.0], [0.0, 1.0, 0.0]);
        assert!((b - (FRAC_PI_2 - g / 2.0)).abs() < 1e-12, "{b}");
    }

    #[test]
    fn the_bisector_halves_the_bistatic_angle() {
        // emitter along x, receiver along y: the bisector is at 45 degrees to both
        let (b, _, _) = bisector_incidence([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]);
        assert!((b - std::f64::consts::FRAC_PI_4).abs() < 1e-15);
    }
}
