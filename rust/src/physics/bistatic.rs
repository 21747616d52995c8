//! Bistatic geometry (docs/model.md §5a): a receiver at its own place in the sonar's frame, the
//! echo's delay range `(r_tx + r_rx) / 2`, the lobe rule's range `sqrt(r_tx r_rx)`, and the
//! incidence angle from the bisector of the two directions; a branch piece's reference point,
//! tilt and bistatic angle (§9). With the receiver at the emitter each reduces to the
//! monostatic quantity (`r`, `r`, `angle(e, n)`, the piece's near surface point).

use crate::math::vec3::{dot, norm, sub, V3};
use crate::physics::branch::{piece_sight, PieceSight};
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

/// A branch piece as an emitter and a receiver at their own places see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BistaticSight {
    /// Lit for both: the point of the piece's centre cross-section that makes `r_tx + r_rx`
    /// least (its echo's reference), `cos(gamma)`, `sin(gamma)` of the tilt of the axis from
    /// the broadside of the bisector of the two directions to that point, and `cos(beta/2)` of
    /// the bistatic angle `beta` there.
    Lit {
        reference: V3,
        cos_gamma: f64,
        sin_gamma: f64,
        cos_half_bistatic: f64,
    },
    /// No specular point lit for both (the receiver end-on, the bisector along the axis, or
    /// the two on opposite sides of the surface: forward scattering): silent.
    Dark,
    /// The receiver lies inside the piece.
    Inside,
}

/// How an emitter at `p_tx` and a receiver at `p_rx` see the piece with centre `c` (on the
/// axis), unit axis `u`, radius `a` and length `length` (the emitter sees it lit: the caller
/// checks [`piece_sight`] from `p_tx` first). With `b = e_tx + e_rx` the sum of the unit
/// directions from the two to `c` and `w` its part perpendicular to the axis, the reference
/// point is `c - a w/|w|`, where the surface normal lies along the bisector's cross-section
/// component (the stationary point of `r_tx + r_rx` round the circumference); the tilt and
/// the bistatic angle are those of the directions to that point, `cos(beta/2) = |b'|/2`. With
/// `p_rx = p_tx` it is [`piece_sight`]'s point and tilt, and `cos(beta/2) = 1`, to rounding.
#[inline]
pub fn bistatic_piece_sight(
    p_tx: V3,
    p_rx: V3,
    c: V3,
    u: V3,
    a: f64,
    length: f64,
) -> BistaticSight {
    match piece_sight(p_rx, c, u, a, length) {
        PieceSight::Inside => return BistaticSight::Inside,
        PieceSight::EndOn => return BistaticSight::Dark,
        PieceSight::Lit { .. } => {}
    }
    let unit = |v: V3| {
        let n = norm(v);
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let (e_tx, e_rx) = (unit(sub(c, p_tx)), unit(sub(c, p_rx)));
    let b = [e_tx[0] + e_rx[0], e_tx[1] + e_rx[1], e_tx[2] + e_rx[2]];
    if !(norm(b) >= FORWARD_SCATTER_B) {
        return BistaticSight::Dark;
    }
    let s = dot(b, u);
    let w = [b[0] - s * u[0], b[1] - s * u[1], b[2] - s * u[2]];
    let rho = norm(w);
    if !(rho > 0.0) {
        return BistaticSight::Dark;
    }
    let f = a / rho;
    let reference = [c[0] - f * w[0], c[1] - f * w[1], c[2] - f * w[2]];
    // both on the outer side of the surface at the reference point (normal -w/|w|)
    if !(dot(sub(reference, p_tx), w) > 0.0 && dot(sub(reference, p_rx), w) > 0.0) {
        return BistaticSight::Dark;
    }
    let (g_tx, g_rx) = (unit(sub(reference, p_tx)), unit(sub(reference, p_rx)));
    let bb = [g_tx[0] + g_rx[0], g_tx[1] + g_rx[1], g_tx[2] + g_rx[2]];
    let nb = norm(bb);
    let sb = dot(bb, u);
    let h = [bb[0] - sb * u[0], bb[1] - sb * u[1], bb[2] - sb * u[2]];
    BistaticSight::Lit {
        reference,
        cos_gamma: norm(h) / nb,
        sin_gamma: sb.abs() / nb,
        cos_half_bistatic: (0.5 * nb).min(1.0),
    }
}

/// The range of a piece's mean Fresnel lag heard by a receiver of its own: the harmonic mean
/// `2 r_tx r_rx / (r_tx + r_rx)` (m), so that `l^2 cos^2(gamma) / (24 r_h)` is the mean of the
/// two paths' lags (`r` when `r_tx = r_rx = r`).
#[inline(always)]
pub fn lag_range(r_tx: f64, r_rx: f64) -> f64 {
    2.0 * r_tx * r_rx / (r_tx + r_rx)
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

    #[test]
    fn a_receiver_at_the_emitter_sees_a_piece_as_the_emitter_does() {
        let (p, c, u) = ([0.0, 0.0, 0.0], [2.0, 0.3, 0.5], [0.6, 0.0, 0.8]);
        let PieceSight::Lit {
            reference,
            cos_gamma,
            sin_gamma,
        } = piece_sight(p, c, u, 0.05, 0.1)
        else {
            panic!("lit")
        };
        let BistaticSight::Lit {
            reference: r2,
            cos_gamma: c2,
            sin_gamma: s2,
            cos_half_bistatic,
        } = bistatic_piece_sight(p, p, c, u, 0.05, 0.1)
        else {
            panic!("lit")
        };
        for d in 0..3 {
            assert!((reference[d] - r2[d]).abs() < 1e-15);
        }
        assert!((cos_gamma - c2).abs() < 1e-15 && (sin_gamma - s2).abs() < 1e-15);
        assert!((cos_half_bistatic - 1.0).abs() < 1e-15);
    }

    #[test]
    fn a_piece_between_emitter_and_receiver_is_dark() {
        let u = [0.0, 0.0, 1.0];
        let sight = bistatic_piece_sight([0.0; 3], [4.0, 0.0, 0.0], [2.0, 0.0, 0.0], u, 0.05, 0.1);
        assert_eq!(sight, BistaticSight::Dark);
    }

    #[test]
    fn the_reference_point_faces_the_bisector() {
        // emitter and receiver symmetric about the x axis: the point nearest the origin side
        let u = [0.0, 0.0, 1.0];
        let BistaticSight::Lit {
            reference,
            cos_half_bistatic,
            ..
        } = bistatic_piece_sight(
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [2.0, 0.0, 0.0],
            u,
            0.1,
            0.1,
        )
        else {
            panic!("lit")
        };
        assert!((reference[0] - 1.9).abs() < 1e-15 && reference[1].abs() < 1e-15);
        let half = (1.9f64).atan2(1.0).sin(); // cos of half the angle 2 atan(1/1.9)
        assert!(
            (cos_half_bistatic - half).abs() < 1e-12,
            "{cos_half_bistatic} {half}"
        );
    }
}
