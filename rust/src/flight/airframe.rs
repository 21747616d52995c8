//! A quadrotor's physical parameters and controller gains, validated, with the rotor mixer
//! and its inverse (docs/model.md §8).

use crate::error::{invalid, Result};
use crate::math::vec3::V3;

/// Gains of the SE(3) controller: position `k_x` (N/m), velocity `k_v` (N s/m) per world
/// axis; attitude `k_r` (N m/rad) and angular rate `k_omega` (N m s/rad) per body axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gains {
    pub k_x: V3,
    pub k_v: V3,
    pub k_r: V3,
    pub k_omega: V3,
}

/// Rotor placement: `X` puts the rotors at 45, 135, 225 and 315 degrees from body x,
/// `Plus` at 0, 90, 180 and 270 degrees.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Configuration {
    X,
    Plus,
}

/// The vehicle as the caller describes it: mass (kg), diagonal inertia (kg m²), arm length
/// (m), rotor coefficients `k_f` (N/(rad/s)²) and `k_m` (N m/(rad/s)²), motor time constant
/// (s), rotor speed range (rad/s), linear body drag (N s/m), gravity (m/s²), the controller
/// gains and whether the drag at the reference velocity is fed forward.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirframeParams {
    pub mass: f64,
    pub inertia: V3,
    pub arm_length: f64,
    pub k_f: f64,
    pub k_m: f64,
    pub motor_time_constant: f64,
    pub omega_min: f64,
    pub omega_max: f64,
    pub drag: V3,
    pub configuration: Configuration,
    pub gravity: f64,
    pub gains: Gains,
    pub drag_feedforward: bool,
}

/// [`AirframeParams`] checked, with the rotor mixer: `mixer` maps rotor thrusts `k_f ω_i²`
/// (N) to the total thrust and body moments `(f, Mx, My, Mz)`; `mixer_inv` is its inverse.
#[derive(Clone, Debug, PartialEq)]
pub struct Airframe {
    params: AirframeParams,
    pub mixer: [[f64; 4]; 4],
    pub mixer_inv: [[f64; 4]; 4],
}

impl std::ops::Deref for Airframe {
    type Target = AirframeParams;
    fn deref(&self) -> &AirframeParams {
        &self.params
    }
}

fn positive(x: f64, name: &str) -> Result<f64> {
    if x > 0.0 && x.is_finite() {
        Ok(x)
    } else {
        invalid(format!("{name} must be finite and > 0, got {x}"))
    }
}

fn positive3(v: V3, name: &str) -> Result<V3> {
    for x in v {
        positive(x, name)?;
    }
    Ok(v)
}

impl Airframe {
    /// The airframe of `p`, checked: positive masses, inertias, coefficients, time constant,
    /// gravity and gains; non-negative drag; `0 <= omega_min < omega_max` (which may be
    /// infinite) and enough `omega_max` to hover.
    pub fn new(p: AirframeParams) -> Result<Airframe> {
        positive(p.mass, "mass")?;
        positive3(p.inertia, "inertia")?;
        positive(p.arm_length, "arm_length")?;
        positive(p.k_f, "k_f")?;
        positive(p.k_m, "k_m")?;
        positive(p.motor_time_constant, "motor_time_constant")?;
        positive(p.gravity, "gravity")?;
        positive3(p.gains.k_x, "k_x")?;
        positive3(p.gains.k_v, "k_v")?;
        positive3(p.gains.k_r, "k_R")?;
        positive3(p.gains.k_omega, "k_Omega")?;
        if !p.drag.iter().all(|d| *d >= 0.0 && d.is_finite()) {
            return invalid(format!("drag must be finite and >= 0, got {:?}", p.drag));
        }
        if !(p.omega_min >= 0.0) || !p.omega_min.is_finite() {
            return invalid(format!(
                "omega_min must be finite and >= 0, got {}",
                p.omega_min
            ));
        }
        if !(p.omega_max > p.omega_min) {
            return invalid(format!(
                "omega_max ({}) must exceed omega_min ({})",
                p.omega_max, p.omega_min
            ));
        }
        let hover = (p.mass * p.gravity / (4.0 * p.k_f)).sqrt();
        if !(hover < p.omega_max) {
            return invalid(format!(
                "omega_max is too low to hover: it must exceed {hover:.6} rad/s"
            ));
        }
        let angles_deg: [f64; 4] = match p.configuration {
            Configuration::X => [45.0, 135.0, 225.0, 315.0],
            Configuration::Plus => [0.0, 90.0, 180.0, 270.0],
        };
        let spin = [1.0, -1.0, 1.0, -1.0];
        let mut mixer = [[0.0; 4]; 4];
        for i in 0..4 {
            let a = angles_deg[i].to_radians();
            let (x, y) = (p.arm_length * a.cos(), p.arm_length * a.sin());
            mixer[0][i] = 1.0;
            mixer[1][i] = y;
            mixer[2][i] = -x;
            mixer[3][i] = spin[i] * p.k_m / p.k_f;
        }
        let Some(mixer_inv) = inverse4(&mixer) else {
            return invalid("the rotor mixer is singular");
        };
        Ok(Airframe {
            params: p,
            mixer,
            mixer_inv,
        })
    }

    /// Rotor speed (rad/s) at which four rotors carry the weight.
    pub fn hover_rotor_speed(&self) -> f64 {
        (self.mass * self.gravity / (4.0 * self.k_f)).sqrt()
    }

    /// Total thrust (N) and body moments (N m) of the rotor speeds `w` (rad/s).
    #[inline(always)]
    pub fn thrust_and_moments(&self, w: &[f64; 4]) -> [f64; 4] {
        let t = [
            self.k_f * w[0] * w[0],
            self.k_f * w[1] * w[1],
            self.k_f * w[2] * w[2],
            self.k_f * w[3] * w[3],
        ];
        mat4_vec(&self.mixer, &t)
    }

    /// Rotor speeds (rad/s) for total thrust `f` (N) and body moments `m` (N m), each rotor's
    /// thrust clipped to `[k_f ω_min², k_f ω_max²]`.
    #[inline(always)]
    pub fn rotor_speeds_for(&self, f: f64, m: V3) -> [f64; 4] {
        let t = mat4_vec(&self.mixer_inv, &[f, m[0], m[1], m[2]]);
        let lo = self.k_f * self.omega_min * self.omega_min;
        let hi = self.k_f * self.omega_max * self.omega_max;
        let mut w = [0.0; 4];
        for i in 0..4 {
            w[i] = (t[i].max(lo).min(hi) / self.k_f).sqrt();
        }
        w
    }
}

#[inline(always)]
fn mat4_vec(m: &[[f64; 4]; 4], v: &[f64; 4]) -> [f64; 4] {
    let mut out = [0.0; 4];
    for (o, row) in out.iter_mut().zip(m) {
        *o = row[0] * v[0] + row[1] * v[1] + row[2] * v[2] + row[3] * v[3];
    }
    out
}

/// The inverse of a 4x4 matrix by Gauss-Jordan elimination with partial pivoting; `None` if
/// it is singular.
fn inverse4(m: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let mut a = *m;
    let mut inv = [[0.0; 4]; 4];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let scale = m.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    for col in 0..4 {
        let pivot = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[pivot][col].abs() > 1e-12 * scale) {
            return None;
        }
        a.swap(col, pivot);
        inv.swap(col, pivot);
        let d = a[col][col];
        for j in 0..4 {
            a[col][j] /= d;
            inv[col][j] /= d;
        }
        for i in 0..4 {
            if i != col {
                let f = a[i][col];
                for j in 0..4 {
                    a[i][j] -= f * a[col][j];
                    inv[i][j] -= f * inv[col][j];
                }
            }
        }
    }
    Some(inv)
}
