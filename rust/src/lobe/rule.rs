//! The exact per-leaf lobe test (docs/model.md §3) in f64, as the reference performs it.
use crate::math::vec3::{dot, sub, V3};
use crate::physics::pose::Pose;
use crate::sonar::{LobeRule, Sonar};

/// A leaf seen from a pose: range (m), unit direction, azimuth and elevation (rad), two-way gain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafView {
    pub range: f64,
    pub dir: V3,
    pub az: f64,
    pub el: f64,
    pub gain: f64,
}

/// The exact per-leaf decision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Decision {
    Out,
    /// Closer than `min_range` (or at the pose itself); carries the range.
    TooClose(f64),
    In(LeafView),
}

/// The exact f64 test of docs/model.md §3 for one leaf centre. The reference implementation
/// (`batecho.reference`) performs the same operations in the same order.
#[inline]
pub fn classify(sonar: &Sonar, pose: &Pose, center: V3) -> Decision {
    let dx = sub(center, pose.position);
    let r = dot(dx, dx).sqrt();
    if !(r >= sonar.params.min_range) {
        return Decision::TooClose(r);
    }
    if r > sonar.range_limit {
        return Decision::Out;
    }
    let e = [dx[0] / r, dx[1] / r, dx[2] / r];
    let ed = dot(e, pose.forward);
    let el_ = dot(e, pose.left);
    let eu = dot(e, pose.up);
    if let LobeRule::Cone { .. } = sonar.params.lobe {
        if ed < sonar.cos_half_angle {
            return Decision::Out;
        }
    }
    let az = el_.atan2(ed);
    let el = eu.atan2((ed * ed + el_ * el_).sqrt());
    let gain = sonar.two_way_gain(az, el);
    if let LobeRule::Detectable { .. } = sonar.params.lobe {
        if !(r <= (sonar.reach_sq_per_gain * gain).sqrt()) {
            return Decision::Out;
        }
    }
    Decision::In(LeafView {
        range: r,
        dir: e,
        az,
        el,
        gain,
    })
}
