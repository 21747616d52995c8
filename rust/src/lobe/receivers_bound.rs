//! The conservative test of a BVH node's box for receivers at their own places: a node is
//! skipped only when no leaf in it can count for any receiver, and taken whole when every leaf
//! in it counts for some receiver (the candidates are the union over the receivers; each then
//! gets the exact test of [`crate::lobe::receivers`]).
use crate::lobe::bound::{box_cap, box_distances, cap_rect, gain_range, BoxTest, SLACK};
use crate::lobe::receivers::PlacedReceiver;
use crate::math::vec3::{cross, dot, norm, V3};
use crate::math::vmath::atan2_fast;
use crate::physics::pose::Pose;
use crate::sonar::{LobeRule, Sonar};
use multiversion::multiversion;
use std::f64::consts::PI;

/// What one source (emitter or receiver) bounds about a box: its nearest and farthest
/// distance, and over the box's directions its one-way gain range (detectable rule) or its
/// angle from the cone's edge (cone rule).
#[derive(Clone, Copy, Debug)]
struct SourceBound {
    rmin: f64,
    rmax: f64,
    /// The gain range (detectable), or `(gamma_c - delta, gamma_c + delta)` (cone).
    lo: f64,
    hi: f64,
    /// Every azimuth is in the cap (no `Inside` decision then).
    whole: bool,
}

/// `None`: the source may lie in the box (a too-close leaf may be there, or its directions
/// cover everything): descend.
#[inline(always)]
fn source_bound(
    sonar: &Sonar,
    pose: &Pose,
    at: V3,
    beam: &crate::physics::beam::GaussianBeam,
    lo: V3,
    hi: V3,
) -> Option<SourceBound> {
    let (rmin, rmax) = box_distances(at, lo, hi);
    if rmin <= sonar.params.min_range * (1.0 + SLACK) {
        return None;
    }
    let (v, dist, rad, delta) = box_cap(at, lo, hi)?;
    Some(match sonar.params.lobe {
        LobeRule::Cone { .. } => {
            let gamma_c = atan2_fast(norm(cross(v, pose.forward)), dot(v, pose.forward));
            SourceBound {
                rmin,
                rmax,
                lo: gamma_c - delta,
                hi: gamma_c + delta,
                whole: false,
            }
        }
        LobeRule::Detectable { .. } => {
            let cap = cap_rect(pose, v, dist, rad, delta);
            let (g_lo, g_hi) = gain_range(beam, &cap);
            SourceBound {
                rmin,
                rmax,
                lo: g_lo,
                hi: g_hi,
                whole: cap.h >= PI,
            }
        }
    })
}

/// The node test for one receiver, from the emitter's bound.
#[inline(always)]
fn one_receiver(sonar: &Sonar, tx: &SourceBound, rx: &SourceBound) -> BoxTest {
    if (tx.rmin + rx.rmin) / 2.0 > sonar.range_limit {
        return BoxTest::Outside;
    }
    let in_range = (tx.rmax + rx.rmax) / 2.0 < sonar.range_limit;
    match sonar.params.lobe {
        LobeRule::Cone { half_angle } => {
            if tx.lo > half_angle + SLACK || rx.lo > half_angle + SLACK {
                BoxTest::Outside
            } else if in_range && tx.hi < half_angle - SLACK && rx.hi < half_angle - SLACK {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
        LobeRule::Detectable { .. } => {
            let k = sonar.reach_sq_per_gain;
            if (tx.rmin * rx.rmin).sqrt() > (k * tx.hi * rx.hi).sqrt() * (1.0 + SLACK) {
                BoxTest::Outside
            } else if in_range
                && !tx.whole
                && !rx.whole
                && (tx.rmax * rx.rmax).sqrt() < (k * tx.lo * rx.lo).sqrt() * (1.0 - SLACK)
            {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
    }
}

/// Conservative test of the box `[lo, hi]` for the receivers `rxs` of this pose: `Outside`
/// when no point of it can count for any receiver, `Inside` when every point counts for one
/// of them (with margin), else `Partial`.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub fn test_box_heard(
    sonar: &Sonar,
    pose: &Pose,
    rxs: &[PlacedReceiver],
    lo: V3,
    hi: V3,
) -> BoxTest {
    let Some(tx) = source_bound(sonar, pose, pose.position, &sonar.params.emitter, lo, hi) else {
        return BoxTest::Partial;
    };
    let mut all_outside = true;
    for rx in rxs {
        let Some(rb) = source_bound(sonar, pose, rx.position, rx.beam, lo, hi) else {
            return BoxTest::Partial;
        };
        match one_receiver(sonar, &tx, &rb) {
            BoxTest::Inside => return BoxTest::Inside,
            BoxTest::Partial => all_outside = false,
            BoxTest::Outside => {}
        }
    }
    if all_outside {
        BoxTest::Outside
    } else {
        BoxTest::Partial
    }
}
