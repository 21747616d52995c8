//! A counting leaf as the kernels take it ([`LeafTerm`]): its amplitude, range, incidence and
//! radius powers.

use crate::lobe::Member;
use crate::physics::amplitude::echo_amplitude;
use crate::scene::Scene;
use crate::sonar::Sonar;

/// Per-leaf quantities the kernels need, in SI units.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct LeafTerm {
    /// `g G / r^2` (or `g G` without spreading).
    pub amp: f64,
    pub range: f64,
    pub beta: f64,
    /// `cos(beta)`, `sin(beta)` from the geometry (see [`Member`]).
    pub cos_beta: f64,
    pub sin_beta: f64,
    pub radius: f64,
    /// `radius^-0.9065`, `radius^0.3523` (paper model).
    pub radius_pow_b: f64,
    pub radius_pow_p: f64,
}

impl LeafTerm {
    /// A term from its amplitude, range (m), incidence angle (rad) and radius (m); the derived
    /// fields are computed.
    pub fn new(amp: f64, range: f64, beta: f64, radius: f64) -> Self {
        LeafTerm {
            amp,
            range,
            beta,
            cos_beta: beta.cos(),
            sin_beta: beta.sin(),
            radius,
            radius_pow_b: radius.powf(crate::physics::leaf::PAPER_BP),
            radius_pow_p: radius.powf(crate::physics::leaf::PAPER_PP),
        }
    }
}

/// A leaf's amplitude `g G / r^2` from its two-way gain `G` and range `r` (m); `g G` with
/// spreading off.
#[inline(always)]
pub fn leaf_amp(sonar: &Sonar, gain: f64, range: f64) -> f64 {
    let p = &sonar.params;
    echo_amplitude(p.gain, gain, range, p.spreading)
}

/// The term of a counting leaf: its amplitude, range, incidence and radius powers.
pub fn leaf_term(sonar: &Sonar, scene: &Scene, m: &Member) -> LeafTerm {
    let i = m.index as usize;
    LeafTerm {
        amp: leaf_amp(sonar, m.gain, m.range),
        range: m.range,
        beta: m.beta,
        cos_beta: m.cos_beta,
        sin_beta: m.sin_beta,
        radius: scene.radii[i],
        radius_pow_b: scene.radius_pow_b[i],
        radius_pow_p: scene.radius_pow_p[i],
    }
}
