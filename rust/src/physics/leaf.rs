//! Leaf scattering (docs/model.md §4): the paper's fit and the physical-optics disk, scalar
//! and exact (libm). `c = k a`, `beta` the incidence angle in [0, pi/2] (0 faces the sonar).
//! Both return `(L, psi)`; a leaf contributes `L exp(-j psi) / k` per unit gain.

use crate::math::vec3::{cross, dot, norm, V3};
use std::f64::consts::{FRAC_PI_2, PI};

pub const PAPER_A2: f64 = 0.5003;
pub const PAPER_A0: f64 = 0.6867;
pub const PAPER_B1: f64 = 0.3999;
pub const PAPER_BP: f64 = -0.9065;
pub const PAPER_B0: f64 = 0.9979;
pub const PAPER_P1: f64 = 0.9824;
pub const PAPER_PP: f64 = 0.3523;
pub const PAPER_P0: f64 = -0.9459;
/// The authors' literal 1.57 (not pi/2) in the phase term.
pub const PAPER_BETA_REF: f64 = 1.57;
pub const PAPER_PSI0: f64 = -2.6343;

/// The paper's fit: `L = max(0, A(c) cos(B(c) beta))`, `psi = erf(P(c)(1.57 - beta)) - 2.6343`.
#[inline]
pub fn paper(c: f64, beta: f64) -> (f64, f64) {
    let a = PAPER_A2 * c * c + PAPER_A0;
    let b = PAPER_B1 * c.powf(PAPER_BP) + PAPER_B0;
    let l = (a * (b * beta).cos()).max(0.0);
    let p = PAPER_P1 * c.powf(PAPER_PP) + PAPER_P0;
    let psi = libm::erf(p * (PAPER_BETA_REF - beta)) + PAPER_PSI0;
    (l, psi)
}

/// `2 J1(x) / x`, with its limit 1 at x = 0.
#[inline]
pub fn jinc(x: f64) -> f64 {
    if x.abs() < 1e-3 {
        let x2 = x * x;
        1.0 - x2 / 8.0 + x2 * x2 / 192.0
    } else {
        2.0 * libm::j1(x) / x
    }
}

/// Physical optics (Kirchhoff) disk: `L = c^2/2 cos(beta) |2 J1(x)/x|`, `x = 2 c sin(beta)`,
/// `psi = -pi/2`, from `cos(beta)` and `sin(beta)` (taken from the geometry: accurate at
/// grazing incidence, where `cos` of a computed angle is not). At normal incidence the
/// scattering amplitude `L / k` is `k a^2 / 2`.
#[inline]
pub fn physical_optics(c: f64, cos_beta: f64, sin_beta: f64) -> (f64, f64) {
    let x = 2.0 * c * sin_beta;
    (c * c / 2.0 * cos_beta * jinc(x).abs(), -FRAC_PI_2)
}

/// Incidence angle between the unit direction `e` and the unit normal `n`, folded to [0, pi/2],
/// with its cosine `|e . n|` and sine `|e x n|`. The angle is `atan2(|e x n|, e . n)`, which
/// stays accurate at normal and grazing incidence.
#[inline]
pub fn incidence(e: V3, n: V3) -> (f64, f64, f64) {
    let s = norm(cross(e, n));
    let c = dot(e, n);
    let b = s.atan2(c);
    (b.min(PI - b), c.abs().min(1.0), s.min(1.0))
}
