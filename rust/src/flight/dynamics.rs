//! The quadrotor's equations of motion and one RK4 step (docs/model.md §8):
//!
//! ```text
//! p' = v
//! m v' = −m g e3 + f R e3 − R D Rᵀ (v − wind)
//! R' = R hat(W)
//! J W' = M − W × J W
//! ω_i' = (ω_cmd,i − ω_i) / τ_m
//! ```
//!
//! The arithmetic follows `batecho.flight.vehicle.Quadrotor._deriv` and its RK4 loop
//! operation for operation, so the two agree to rounding.

use super::airframe::Airframe;
use super::rigid::{mul_hat, mul_vec, polar_factor, tmul_vec, Mat3};
use crate::math::vec3::{cross, V3};

/// The state as 22 numbers: position (world, m), velocity (world, m/s), the rotation body →
/// world row-major, angular velocity (body, rad/s), rotor speeds (rad/s); the layout of
/// `QuadState.vector()` in Python.
pub type StateVec = [f64; 22];

/// Where each part of a [`StateVec`] starts.
pub const POSITION: usize = 0;
pub const VELOCITY: usize = 3;
pub const ROTATION: usize = 6;
pub const ANGULAR_VELOCITY: usize = 15;
pub const ROTOR_SPEEDS: usize = 18;

#[inline(always)]
pub fn v3(y: &StateVec, at: usize) -> V3 {
    [y[at], y[at + 1], y[at + 2]]
}

#[inline(always)]
pub fn rotation(y: &StateVec) -> Mat3 {
    let r = ROTATION;
    [
        [y[r], y[r + 1], y[r + 2]],
        [y[r + 3], y[r + 4], y[r + 5]],
        [y[r + 6], y[r + 7], y[r + 8]],
    ]
}

#[inline(always)]
pub fn rotors(y: &StateVec) -> [f64; 4] {
    let r = ROTOR_SPEEDS;
    [y[r], y[r + 1], y[r + 2], y[r + 3]]
}

/// The state's time derivative under rotor speed commands `w_cmd` (already clipped to the
/// rotors' range) and the wind velocity `wind` (world, m/s).
#[inline(always)]
pub fn derivative(a: &Airframe, y: &StateVec, w_cmd: &[f64; 4], wind: V3) -> StateVec {
    let r = rotation(y);
    let v = v3(y, VELOCITY);
    let om = v3(y, ANGULAR_VELOCITY);
    let w = rotors(y);
    let u = a.thrust_and_moments(&w);
    let j = a.inertia;
    let rel = [v[0] - wind[0], v[1] - wind[1], v[2] - wind[2]];
    let body = tmul_vec(&r, rel);
    let drag = mul_vec(
        &r,
        [
            a.drag[0] * body[0],
            a.drag[1] * body[1],
            a.drag[2] * body[2],
        ],
    );
    let mut dv = [0.0; 3];
    for i in 0..3 {
        dv[i] = (u[0] * r[i][2] - drag[i]) / a.mass;
    }
    dv[2] -= a.gravity;
    let dr = mul_hat(&r, om);
    let jom = [j[0] * om[0], j[1] * om[1], j[2] * om[2]];
    let gyro = cross(om, jom);
    let mut out = [0.0; 22];
    out[POSITION..POSITION + 3].copy_from_slice(&v);
    out[VELOCITY..VELOCITY + 3].copy_from_slice(&dv);
    for i in 0..3 {
        out[ROTATION + 3 * i..ROTATION + 3 * i + 3].copy_from_slice(&dr[i]);
        out[ANGULAR_VELOCITY + i] = (u[1 + i] - gyro[i]) / j[i];
    }
    for i in 0..4 {
        out[ROTOR_SPEEDS + i] = (w_cmd[i] - w[i]) / a.motor_time_constant;
    }
    out
}

#[inline(always)]
fn axpy(y: &StateVec, h: f64, k: &StateVec) -> StateVec {
    let mut out = [0.0; 22];
    for i in 0..22 {
        out[i] = y[i] + h * k[i];
    }
    out
}

/// One classical RK4 step of length `h` with the commands and wind held over it, then the
/// rotation re-orthonormalised (its polar factor). `None` if the step leaves the state
/// non-finite or the rotation singular.
#[inline]
pub fn rk4_step(
    a: &Airframe,
    y: &StateVec,
    h: f64,
    w_cmd: &[f64; 4],
    wind: V3,
) -> Option<StateVec> {
    let k1 = derivative(a, y, w_cmd, wind);
    let k2 = derivative(a, &axpy(y, 0.5 * h, &k1), w_cmd, wind);
    let k3 = derivative(a, &axpy(y, 0.5 * h, &k2), w_cmd, wind);
    let k4 = derivative(a, &axpy(y, h, &k3), w_cmd, wind);
    let h6 = h / 6.0;
    let mut out = [0.0; 22];
    for i in 0..22 {
        out[i] = y[i] + h6 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    let r = polar_factor(&rotation(&out))?;
    for i in 0..3 {
        out[ROTATION + 3 * i..ROTATION + 3 * i + 3].copy_from_slice(&r[i]);
    }
    out.iter().all(|x| x.is_finite()).then_some(out)
}
