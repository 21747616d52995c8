//! The geometric SE(3) tracking controller of T. Lee, M. Leok, N. H. McClamroch, "Geometric
//! tracking control of a quadrotor UAV on SE(3)", IEEE CDC 2010, rewritten for z up, with
//! feed-forward body rates and accelerations from the reference (docs/model.md §8). The
//! arithmetic follows `batecho.flight.controller.se3_control` and `desired_attitude`.

use super::airframe::Airframe;
use super::dynamics::{rotation, v3, StateVec, ANGULAR_VELOCITY, POSITION, VELOCITY};
use super::rigid::{from_columns, half_vee_of_transpose_difference, mul_vec, tmul, Mat3};
use crate::math::vec3::{cross, dot, norm, V3};

/// One sample of a reference by differential flatness: position (m), velocity (m/s) and
/// acceleration (m/s²) in the world frame, yaw (rad), and the nominal attitude's body
/// angular velocity (rad/s) and acceleration (rad/s²).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reference {
    pub position: V3,
    pub velocity: V3,
    pub acceleration: V3,
    pub yaw: f64,
    pub omega: V3,
    pub domega: V3,
}

/// Lee et al.'s desired attitude: body z along the thrust vector `f` (world z if `f` is
/// nearly zero), body x the heading `(cos yaw, sin yaw, 0)` projected onto the plane normal
/// to it.
#[inline(always)]
pub fn desired_attitude(f: V3, yaw: f64) -> Mat3 {
    let n = norm(f);
    let b3 = if n > 1e-12 {
        [f[0] / n, f[1] / n, f[2] / n]
    } else {
        [0.0, 0.0, 1.0]
    };
    let (s, c) = yaw.sin_cos();
    let b2 = cross(b3, [c, s, 0.0]);
    let n2 = norm(b2);
    let b2 = [b2[0] / n2, b2[1] / n2, b2[2] / n2];
    from_columns(cross(b2, b3), b2, b3)
}

/// The controller's total thrust (N) and body moments (N m) for state `y` tracking `r`.
#[inline(always)]
pub fn se3_control(a: &Airframe, y: &StateVec, r: &Reference) -> (f64, V3) {
    let g = &a.gains;
    let rot = rotation(y);
    let om = v3(y, ANGULAR_VELOCITY);
    let p = v3(y, POSITION);
    let v = v3(y, VELOCITY);
    let j = a.inertia;
    let mut f = [0.0; 3];
    for i in 0..3 {
        let ex = p[i] - r.position[i];
        let ev = v[i] - r.velocity[i];
        let feed = a.mass * (r.acceleration[i] + if i == 2 { a.gravity } else { 0.0 });
        f[i] = -g.k_x[i] * ex - g.k_v[i] * ev + feed;
    }
    if a.drag_feedforward {
        let body = super::rigid::tmul_vec(&rot, r.velocity);
        let d = mul_vec(
            &rot,
            [
                a.drag[0] * body[0],
                a.drag[1] * body[1],
                a.drag[2] * body[2],
            ],
        );
        for i in 0..3 {
            f[i] += d[i];
        }
    }
    let thrust = dot(f, [rot[0][2], rot[1][2], rot[2][2]]);
    let rd = desired_attitude(f, r.yaw);
    let rtrd = tmul(&rot, &rd);
    let e_r = half_vee_of_transpose_difference(&rtrd);
    let omd = mul_vec(&rtrd, r.omega);
    let e_om = [om[0] - omd[0], om[1] - omd[1], om[2] - omd[2]];
    let jom = [j[0] * om[0], j[1] * om[1], j[2] * om[2]];
    let gyro = cross(om, jom);
    let c = cross(om, omd);
    let rdom = mul_vec(&rtrd, r.domega);
    let mut m = [0.0; 3];
    for i in 0..3 {
        m[i] = -g.k_r[i] * e_r[i] - g.k_omega[i] * e_om[i] + gyro[i] - j[i] * (c[i] - rdom[i]);
    }
    (thrust, m)
}

/// The rotor speed commands (rad/s) of the controller for state `y` tracking `r`.
#[inline(always)]
pub fn rotor_commands(a: &Airframe, y: &StateVec, r: &Reference) -> [f64; 4] {
    let (f, m) = se3_control(a, y, r);
    a.rotor_speeds_for(f, m)
}
