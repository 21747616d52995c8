//! Sonar poses: a position and an orthonormal frame (forward `d`, up `u`, left `l = u × d`).

use crate::error::{invalid, Result};
use crate::math::vec3::{cross, dot, is_finite3, norm, V3};

/// One sonar pose. `d`, `u`, `l` are unit vectors, mutually orthogonal, right-handed
/// (`l = u × d`), so that azimuth is positive to the left and elevation positive up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    pub position: V3,
    pub forward: V3,
    pub up: V3,
    pub left: V3,
}

impl Pose {
    /// A pose from a position, a forward vector and an up hint (re-orthogonalised against
    /// forward). The arithmetic is the same, operation for operation, as `batecho.Poses`.
    pub fn new(position: V3, forward: V3, up: V3) -> Result<Pose> {
        if !is_finite3(position) || !is_finite3(forward) || !is_finite3(up) {
            return invalid("pose position, forward and up must be finite");
        }
        let nf = norm(forward);
        if !(nf > 0.0) || !nf.is_finite() {
            return invalid("pose forward vector has zero (or overflowing) length");
        }
        let d = [forward[0] / nf, forward[1] / nf, forward[2] / nf];
        let ud = dot(up, d);
        let uo = [up[0] - ud * d[0], up[1] - ud * d[1], up[2] - ud * d[2]];
        let nu = norm(uo);
        if !(nu > 1e-9 * norm(up)) || !nu.is_finite() {
            return invalid("pose up vector is parallel to forward (or zero)");
        }
        let u = [uo[0] / nu, uo[1] / nu, uo[2] / nu];
        Ok(Pose {
            position,
            forward: d,
            up: u,
            left: cross(u, d),
        })
    }

    /// A pose from an already orthonormal frame (as computed by `batecho.Poses`); checks it.
    pub fn from_frame(position: V3, forward: V3, up: V3, left: V3) -> Result<Pose> {
        if !is_finite3(position) || !is_finite3(forward) || !is_finite3(up) || !is_finite3(left) {
            return invalid("pose frame must be finite");
        }
        let tol = 1e-9;
        let unit = |v: V3| (dot(v, v) - 1.0).abs() < tol;
        if !unit(forward) || !unit(up) || !unit(left) {
            return invalid("pose frame vectors must be unit length");
        }
        if dot(forward, up).abs() > tol
            || dot(forward, left).abs() > tol
            || dot(up, left).abs() > tol
        {
            return invalid("pose frame vectors must be orthogonal");
        }
        let c = cross(up, forward);
        if dot(c, left) < 1.0 - tol {
            return invalid("pose frame must be right-handed with left = up x forward");
        }
        Ok(Pose {
            position,
            forward,
            up,
            left,
        })
    }
}
