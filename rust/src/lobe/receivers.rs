//! The exact per-leaf test for receivers at their own places (docs/model.md §3 and §5a), in
//! f64 with libm, as the reference performs it: the emitter's side of a leaf once, then each
//! receiver's.
use crate::math::vec3::{dot, sub, V3};
use crate::physics::beam::GaussianBeam;
use crate::physics::bistatic::{delay_range, lobe_range, place};
use crate::physics::pose::Pose;
use crate::sonar::{LobeRule, Sonar};

/// A receiver placed for one pose: its world position and its pattern.
#[derive(Clone, Copy, Debug)]
pub struct PlacedReceiver<'a> {
    pub position: V3,
    pub beam: &'a GaussianBeam,
}

/// The sonar's receivers placed for `pose`, in their order.
pub fn place_receivers<'a>(sonar: &'a Sonar, pose: &Pose) -> Vec<PlacedReceiver<'a>> {
    let e = &sonar.params.emitter;
    sonar
        .params
        .receivers
        .iter()
        .map(|r| PlacedReceiver {
            position: place(pose, r.offset),
            beam: r.pattern(e),
        })
        .collect()
}

/// A point seen from one source (emitter or receiver): range, unit direction, azimuth and
/// elevation in the pose's frame, `e . d`, and the one-way gain of a pattern.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OneWay {
    pub range: f64,
    pub dir: V3,
    pub forward: f64,
    pub gain: f64,
}

/// The range of `center` from `from`, exactly as [`crate::lobe::rule::classify`] computes it.
#[inline(always)]
pub fn range_from(from: V3, center: V3) -> f64 {
    let dx = sub(center, from);
    dot(dx, dx).sqrt()
}

/// `center` seen from `from` (at range `r > 0`) through the pattern `beam`, in the pose's
/// frame: the same operations as [`crate::lobe::rule::classify`].
#[inline]
pub fn one_way(pose: &Pose, beam: &GaussianBeam, from: V3, center: V3, r: f64) -> OneWay {
    let dx = sub(center, from);
    let e = [dx[0] / r, dx[1] / r, dx[2] / r];
    let ed = dot(e, pose.forward);
    let el_ = dot(e, pose.left);
    let eu = dot(e, pose.up);
    let az = el_.atan2(ed);
    let el = eu.atan2((ed * ed + el_ * el_).sqrt());
    OneWay {
        range: r,
        dir: e,
        forward: ed,
        gain: beam.gain(az, el),
    }
}

/// A leaf heard by one receiver: the emitter's and the receiver's views, and the two-way
/// gain `S_tx S_rx`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heard {
    pub tx: OneWay,
    pub rx: OneWay,
    pub gain: f64,
}

impl Heard {
    /// The delay range `(r_tx + r_rx) / 2` (m).
    #[inline(always)]
    pub fn range(&self) -> f64 {
        delay_range(self.tx.range, self.rx.range)
    }
}

/// The exact decision for one leaf and one receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeardDecision {
    Out,
    /// Closer than `min_range` to the receiver (the emitter's side is [`emitter_side`]'s).
    TooClose(f64),
    In(Heard),
}

/// The emitter's side of the exact test: `Err(r)` when the leaf is closer than `min_range`
/// to the emitter, else its view from the emitter.
#[inline]
pub fn emitter_side(sonar: &Sonar, pose: &Pose, center: V3) -> Result<OneWay, f64> {
    let r = range_from(pose.position, center);
    if !(r >= sonar.params.min_range) {
        return Err(r);
    }
    Ok(one_way(
        pose,
        &sonar.params.emitter,
        pose.position,
        center,
        r,
    ))
}

/// The exact test of docs/model.md §3 for a receiver of its own: the leaf counts when it is
/// at least `min_range` from emitter and receiver, its delay range `(r_tx + r_rx) / 2` is
/// within the record (and `max_range`), and, for the detectable rule,
/// `sqrt(r_tx r_rx) <= sqrt(K S_tx S_rx)`; for the cone, when it lies in the cone seen from
/// the emitter and from the receiver. With the receiver at the emitter and the emitter's
/// pattern this decides as [`crate::lobe::rule::classify`], bit for bit.
#[inline]
pub fn classify_heard(
    sonar: &Sonar,
    pose: &Pose,
    rx: &PlacedReceiver,
    center: V3,
    tx: &OneWay,
) -> HeardDecision {
    let r_rx = range_from(rx.position, center);
    if !(r_rx >= sonar.params.min_range) {
        return HeardDecision::TooClose(r_rx);
    }
    if delay_range(tx.range, r_rx) > sonar.range_limit {
        return HeardDecision::Out;
    }
    if let LobeRule::Cone { .. } = sonar.params.lobe {
        if tx.forward < sonar.cos_half_angle {
            return HeardDecision::Out;
        }
    }
    let rv = one_way(pose, rx.beam, rx.position, center, r_rx);
    if let LobeRule::Cone { .. } = sonar.params.lobe {
        if rv.forward < sonar.cos_half_angle {
            return HeardDecision::Out;
        }
    }
    let gain = tx.gain * rv.gain;
    if let LobeRule::Detectable { .. } = sonar.params.lobe {
        if !(lobe_range(tx.range, r_rx) <= (sonar.reach_sq_per_gain * gain).sqrt()) {
            return HeardDecision::Out;
        }
    }
    HeardDecision::In(Heard {
        tx: *tx,
        rx: rv,
        gain,
    })
}
