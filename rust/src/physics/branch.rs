//! Branch scattering (docs/model.md §9): physical optics (Kirchhoff) of a rigid finite circular
//! cylinder and its near-field factor, the point of a piece's near surface that its echo is
//! referred to, and the rule that cuts a segment into pieces short enough to be in their own
//! far field, with the mean Fresnel lag of a piece's near-field phase.
//!
//! With the leaves' normalisation (a scatterer contributes `L exp(-j psi) / k` per unit gain),
//! a piece of length `l`, radius `a`, tilted by `gamma` from broadside has
//! `L = k f`, `f = (l/2) sqrt(k a cos(gamma) / pi) sinc(k l sin(gamma))` (real and signed:
//! the sinc's sign is a phase of pi) and `psi = -pi/4`, referred to the point of its near
//! surface line at its centre.

use crate::math::vec3::{dot, V3};
use std::f64::consts::{FRAC_PI_4, PI};

/// The phase constant of a cylinder's specular echo: `exp(-j psi) = exp(j pi/4)` (the disk's
/// `-pi/2` halved: the stationary phase is two-dimensional on a plate, one-dimensional round a
/// cylinder).
pub const CYLINDER_PSI: f64 = -FRAC_PI_4;

/// `sin(x) / x`, with its limit 1 at `x = 0`.
#[inline]
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        x.sin() / x
    }
}

/// The physical-optics cylinder at wavenumber `k` (rad/m): the signed backscattering amplitude
/// `f = (l/2) sqrt(k a cos(gamma) / pi) sinc(k l sin(gamma))` (m) of a rigid piece of length
/// `length` and radius `radius`, tilted by `gamma` from broadside (given by its cosine and
/// sine), so that the echo's factor is `f exp(j pi/4)` (`L = k f`, `psi = -pi/4`). At
/// broadside `|f| = (l/2) sqrt(k a / pi)`, and `4 pi f^2 = k a l^2 cos(gamma) sinc^2` is the
/// backscattering cross-section of Knott et al. (*Radar Cross Section*, 2nd ed., 2004).
#[inline]
pub fn cylinder_po(k: f64, radius: f64, length: f64, cos_gamma: f64, sin_gamma: f64) -> f64 {
    0.5 * length * (k * radius * cos_gamma / PI).sqrt() * sinc(k * length * sin_gamma)
}

/// The near-field factor of a cylinder's echo (docs/model.md §9),
/// `D = (1 + a / (r cos(beta/2) cos(gamma)))^(-1/2)`: round the circumference the sonar's
/// spherical wave adds the path `a^2 phi^2 / (2 r)` each way to the plane wave's
/// `a phi^2 cos(gamma) / 2`, which narrows the stationary phase and shrinks the echo (the
/// divergence of the echo off a convex surface; 1 far away, whatever the frequency). `range`
/// is the reference point's (the harmonic mean of the two ranges for a receiver of its own,
/// `cos_half_beta` its bistatic angle's; 1 heard at the emitter). Written as
/// `sqrt(x / (x + a))`, `x = r cos(beta/2) cos(gamma)`, as the NumPy reference writes it: 0,
/// not a division by zero, at `cos(gamma) = 0`.
#[inline]
pub fn divergence(radius: f64, range: f64, cos_half_beta: f64, cos_gamma: f64) -> f64 {
    let x = range * cos_half_beta * cos_gamma;
    (x / (x + radius)).sqrt()
}

/// A piece as a sonar at `p` sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PieceSight {
    /// The lit side: the point of the near surface line at the piece's centre (its echo's
    /// reference), and `cos(gamma)`, `sin(gamma)` of the tilt from broadside as seen from that
    /// point (`sin(gamma)` is the slope of the near surface line's range).
    Lit {
        reference: V3,
        cos_gamma: f64,
        sin_gamma: f64,
    },
    /// The sonar lies within the radius of the axis line, beyond the piece's ends: only the
    /// flat end is lit, which the model leaves out.
    EndOn,
    /// The sonar lies inside the piece.
    Inside,
}

/// The range (m) by which a piece's echo lags its reference point: the mean, over the piece,
/// of the quadratic (Fresnel) term of the one-way path to its near surface line,
/// `x^2 cos^2(gamma) / (2 r)` for `x` in `[-l/2, l/2]`: `l^2 cos^2(gamma) / (24 r)`. Without
/// it a piece at the rule's length errs by a third of its largest quadratic phase; with it,
/// by the phase's spread, about `0.04 (k l^2 / (4 r))^2` of its amplitude.
#[inline]
pub fn fresnel_lag(length: f64, cos_gamma: f64, range: f64) -> f64 {
    length * length * cos_gamma * cos_gamma / (24.0 * range)
}

/// How a sonar at `p` sees the piece with centre `c` (on the axis), unit axis `u`, radius `a`
/// and length `length`. The reference point is `c - (a / rho) w`, where `w` is the part of
/// `c - p` perpendicular to the axis and `rho = |w|`: the surface point nearest the sonar in
/// the cross-section through the centre. The NumPy reference performs the same operations in
/// the same order.
#[inline]
pub fn piece_sight(p: V3, c: V3, u: V3, a: f64, length: f64) -> PieceSight {
    let v = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    let s = dot(v, u);
    let w = [v[0] - s * u[0], v[1] - s * u[1], v[2] - s * u[2]];
    let rho = dot(w, w).sqrt();
    if !(rho > a) {
        return if s.abs() <= 0.5 * length {
            PieceSight::Inside
        } else {
            PieceSight::EndOn
        };
    }
    let f = a / rho;
    // the tilt as seen from the reference point: the slope of the near surface line's range
    // there, so that adjacent pieces' edges meet in phase
    let h = rho - a;
    let rr = (s * s + h * h).sqrt();
    PieceSight::Lit {
        reference: [c[0] - f * w[0], c[1] - f * w[1], c[2] - f * w[2]],
        cos_gamma: h / rr,
        sin_gamma: s.abs() / rr,
    }
}

/// The default largest quadratic phase error across a piece, `k l^2 / (4 r)` at the band's top
/// wavenumber (rad): pi/512. The pieces' edges do not cancel exactly where a piece's linear
/// phase `k l sin(gamma)` is large (their factors are taken at the piece's centre), so the sum
/// converges only as the pieces shorten; at pi/512 halving them moves a trunk's echo by well
/// under 1 % (docs/model.md §9, `tests/test_branches.py`).
pub const PIECE_PHASE: f64 = PI / 512.0;

/// The largest share of the beam's Gaussian width `sigma` a piece may span: 1/32.
pub const PIECE_BEAM_SHARE: f64 = 1.0 / 32.0;

/// The longest piece (m) the rule allows at range `r` (m) for the band's top wavenumber `k_max`
/// (rad/m) and the beam's smallest Gaussian width `sigma` (rad), `scale` times
/// `min(sqrt(4 r PIECE_PHASE / k_max), PIECE_BEAM_SHARE sigma r)`: short enough that the
/// quadratic phase across it, `k l^2 / (4 r)`, stays below [`PIECE_PHASE`] (its own far field)
/// and that it sees one beam gain.
#[inline]
pub fn max_piece_length(r: f64, k_max: f64, sigma: f64, scale: f64) -> f64 {
    let far = (4.0 * r * PIECE_PHASE / k_max).sqrt();
    let beam = PIECE_BEAM_SHARE * sigma * r;
    scale * far.min(beam)
}

/// The distance (m) from `p` to the segment `a`-`b`: to its nearest point, the parameter of
/// the projection clamped to the segment.
#[inline]
pub fn distance_to_segment(p: V3, a: V3, b: V3) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let m = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let dd = dot(d, d);
    let t = if dd > 0.0 {
        (dot(m, d) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let q = [m[0] - t * d[0], m[1] - t * d[1], m[2] - t * d[2]];
    dot(q, q).sqrt()
}

/// The number of pieces of a segment of length `length` whose nearest point lies at `r`: at
/// least one, each no longer than `max_len`, as many as `ceil(length / max_len)`.
#[inline]
pub fn piece_count(length: f64, max_len: f64) -> usize {
    let n = (length / max_len).ceil();
    if n >= 1.0 {
        n as usize
    } else {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn at_broadside_the_amplitude_is_half_the_length_times_sqrt_ka_over_pi() {
        let (k, a, l) = (1300.0, 0.05, 0.3);
        let f = cylinder_po(k, a, l, 1.0, 0.0);
        assert!((f - 0.5 * l * (k * a / PI).sqrt()).abs() < 1e-15 * f);
    }

    #[test]
    fn the_cross_section_is_knotts_k_a_l2_cos_sinc2() {
        let (k, a, l) = (1200.0, 0.02, 0.1);
        for g in [0.0f64, 0.001, 0.01, 0.1, 0.7] {
            let f = cylinder_po(k, a, l, g.cos(), g.sin());
            let x = k * l * g.sin();
            let s = if x == 0.0 { 1.0 } else { x.sin() / x };
            let sigma = k * a * l * l * g.cos() * s * s;
            assert!((4.0 * PI * f * f - sigma).abs() <= 1e-13 * sigma.max(1e-30));
        }
    }

    #[test]
    fn the_reference_point_lies_on_the_surface_nearest_the_sonar() {
        let p = [0.0, 0.0, 0.0];
        let c = [2.0, 0.0, 0.5];
        let u = [0.0, 0.0, 1.0];
        match piece_sight(p, c, u, 0.1, 0.2) {
            PieceSight::Lit {
                reference,
                cos_gamma,
                sin_gamma,
            } => {
                assert!((reference[0] - 1.9).abs() < 1e-15);
                assert_eq!(reference[1], 0.0);
                assert_eq!(reference[2], 0.5);
                let rr = (1.9f64 * 1.9 + 0.25).sqrt();
                assert!((cos_gamma - 1.9 / rr).abs() < 1e-15);
                assert!((sin_gamma - 0.5 / rr).abs() < 1e-15);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            piece_sight(p, [0.0, 0.0, 1.0], u, 0.1, 0.2),
            PieceSight::EndOn
        );
        assert_eq!(
            piece_sight(p, [0.05, 0.0, 0.05], u, 0.1, 0.2),
            PieceSight::Inside
        );
    }

    #[test]
    fn pieces_at_the_rule_length_keep_the_phase_error_and_the_beam_share() {
        let (k, sigma) = (1478.0, 0.2);
        for r in [0.05, 0.5, 2.0, 9.0] {
            let l = max_piece_length(r, k, sigma, 1.0);
            assert!(k * l * l / (4.0 * r) <= PIECE_PHASE * (1.0 + 1e-12));
            assert!(l <= PIECE_BEAM_SHARE * sigma * r * (1.0 + 1e-12));
        }
        assert_eq!(piece_count(1.0, 0.3), 4);
        assert_eq!(piece_count(0.1, 0.3), 1);
        assert_eq!(
            distance_to_segment([0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            1.0
        );
        assert_eq!(
            distance_to_segment([3.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
            2.0
        );
    }
}
