//! The sonar beampattern: a 2-D Gaussian in (azimuth, elevation), docs/model.md §2.

use crate::error::{invalid, Result};
use std::f64::consts::PI;

/// Gaussian width (radians) for a full -3 dB beamwidth (radians):
/// `sigma = (BW/2) / sqrt(2 * (-ln 0.7079))`.
pub fn sigma_from_beamwidth(beamwidth: f64) -> f64 {
    (beamwidth / 2.0) / (2.0 * -(0.7079f64.ln())).sqrt()
}

/// The horseshoe-bat beamwidth fit of Ming et al. (degrees), `f_khz` in kHz.
pub fn horseshoe_bat_beamwidth_deg(f_khz: f64) -> f64 {
    0.011333 * f_khz * f_khz * f_khz - 2.3219 * f_khz * f_khz + 156.15 * f_khz - 3402.7
}

/// One-way pattern `S = amp * exp(-(a daz^2 + 2b daz del + c del^2))`, angles in radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaussianBeam {
    pub amplitude: f64,
    pub sigma_x: f64,
    pub sigma_y: f64,
    pub rotation: f64,
    pub az0: f64,
    pub el0: f64,
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

/// The narrowest Gaussian width (rad) a beam may have: `1 / (2 sigma^2)` stays far from
/// overflow, and no sonar is within orders of magnitude of it.
pub const MIN_SIGMA: f64 = 1e-8;

impl GaussianBeam {
    /// A beam from its widths (radians), the rotation `theta` of the ellipse (radians), the
    /// beam centre (radians) and the peak amplitude `A1`.
    pub fn new(
        amplitude: f64,
        sigma_x: f64,
        sigma_y: f64,
        rotation: f64,
        az0: f64,
        el0: f64,
    ) -> Result<Self> {
        for (name, v) in [
            ("amplitude", amplitude),
            ("sigma_x", sigma_x),
            ("sigma_y", sigma_y),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!("beam {name} must be finite and > 0, got {v}"));
            }
        }
        for (name, v) in [("sigma_x", sigma_x), ("sigma_y", sigma_y)] {
            if v < MIN_SIGMA {
                return invalid(format!(
                    "beam {name} must be at least {MIN_SIGMA:e} rad (a narrower Gaussian's \
                     exponent overflows), got {v:e}"
                ));
            }
        }
        for (name, v) in [("rotation", rotation), ("az0", az0), ("el0", el0)] {
            if !v.is_finite() {
                return invalid(format!("beam {name} must be finite, got {v}"));
            }
        }
        if az0.abs() > PI || el0.abs() > PI / 2.0 {
            return invalid("beam centre must have |az0| <= 180 deg and |el0| <= 90 deg");
        }
        let (st, ct) = (rotation.sin(), rotation.cos());
        let s2t = (2.0 * rotation).sin();
        let a = ct * ct / (2.0 * sigma_x * sigma_x) + st * st / (2.0 * sigma_y * sigma_y);
        let b = -s2t / (4.0 * sigma_x * sigma_x) + s2t / (4.0 * sigma_y * sigma_y);
        let c = st * st / (2.0 * sigma_x * sigma_x) + ct * ct / (2.0 * sigma_y * sigma_y);
        Ok(GaussianBeam {
            amplitude,
            sigma_x,
            sigma_y,
            rotation,
            az0,
            el0,
            a,
            b,
            c,
        })
    }

    /// A circular beam of the given full -3 dB beamwidth (radians), centred on the axis.
    pub fn circular(beamwidth: f64) -> Result<Self> {
        if !(beamwidth.is_finite() && beamwidth > 0.0 && beamwidth < PI) {
            return invalid(format!(
                "beamwidth must be in (0, 180) degrees, got {} deg",
                beamwidth.to_degrees()
            ));
        }
        let s = sigma_from_beamwidth(beamwidth);
        GaussianBeam::new(1.0, s, s, 0.0, 0.0, 0.0)
    }

    /// Azimuth offset from the beam centre, wrapped to [-pi, pi].
    #[inline(always)]
    pub fn delta_az(&self, az: f64) -> f64 {
        let mut daz = az - self.az0;
        if daz > PI {
            daz -= 2.0 * PI;
        }
        if daz < -PI {
            daz += 2.0 * PI;
        }
        daz
    }

    /// The quadratic form `a daz^2 + 2b daz del + c del^2` (radians).
    #[inline(always)]
    pub fn quad(&self, daz: f64, del: f64) -> f64 {
        self.a * daz * daz + 2.0 * self.b * daz * del + self.c * del * del
    }

    /// One-way gain at (az, el), radians.
    #[inline(always)]
    pub fn gain(&self, az: f64, el: f64) -> f64 {
        let daz = self.delta_az(az);
        let del = el - self.el0;
        self.amplitude * (-self.quad(daz, del)).exp()
    }

    /// A lower bound of the quadratic form over the rectangle `daz in [a0, a1]`, `del in [e0, e1]`.
    pub fn quad_min_over_rect(&self, a0: f64, a1: f64, e0: f64, e1: f64) -> f64 {
        if a0 <= 0.0 && 0.0 <= a1 && e0 <= 0.0 && 0.0 <= e1 {
            return 0.0;
        }
        // Minimum of a positive-definite quadratic over a rectangle not containing its minimum
        // lies on an edge; minimise along each edge (a 1-D quadratic, clamped).
        let q = |x: f64, y: f64| self.quad(x, y);
        let mut best = f64::INFINITY;
        for &x in &[a0, a1] {
            // q(x, y) = c y^2 + 2 b x y + a x^2 -> y* = -b x / c
            let y = (-self.b * x / self.c).clamp(e0, e1);
            best = best.min(q(x, y));
        }
        for &y in &[e0, e1] {
            let x = (-self.b * y / self.a).clamp(a0, a1);
            best = best.min(q(x, y));
        }
        best.max(0.0)
    }
}
