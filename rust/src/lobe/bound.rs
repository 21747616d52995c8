//! The conservative test of a BVH node's box against a pose's lobe, with a cheap angular
//! pre-test for circular-enough beams.
use crate::math::vec3::{cross, dot, norm, sub, V3};
use crate::math::vmath::atan2_fast;
use crate::physics::beam::GaussianBeam;
use crate::physics::pose::Pose;
use crate::sonar::{LobeRule, Sonar};
use multiversion::multiversion;
use std::f64::consts::{FRAC_PI_2, PI};

/// Smallest |wrap(az - az0)| interval pieces for `az` in `[azc - h, azc + h]`: returns up to
/// two intervals of `daz` inside [-pi, pi].
fn daz_intervals(azc: f64, h: f64, az0: f64) -> ([(f64, f64); 2], usize) {
    if h >= PI {
        return ([(-PI, PI), (0.0, 0.0)], 1);
    }
    let mut dc = azc - az0;
    if dc > PI {
        dc -= 2.0 * PI;
    }
    if dc < -PI {
        dc += 2.0 * PI;
    }
    let (lo, hi) = (dc - h, dc + h);
    if hi > PI {
        ([(lo, PI), (-PI, hi - 2.0 * PI)], 2)
    } else if lo < -PI {
        ([(-PI, hi), (lo + 2.0 * PI, PI)], 2)
    } else {
        ([(lo, hi), (0.0, 0.0)], 1)
    }
}

/// Relative slack of the conservative node test: bounds are loosened by this much so that
/// rounding in the bound itself can never prune a counting leaf.
pub(super) const SLACK: f64 = 1e-9;

/// What the BVH may conclude about a node's box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxTest {
    /// No point of the box can count.
    Outside,
    /// Some points may count: descend.
    Partial,
    /// Every point of the box passes the lobe and range tests (with margin): take all leaves
    /// as candidates without testing the nodes below. (Each still gets the exact test.)
    Inside,
}

/// Per-pose constants of a cheap angular pre-test (circular-enough beams: any Gaussian whose
/// receiver is the emitter). On the sphere, the angle `gamma` between a direction and the beam
/// centre is at most `sqrt(daz^2 + del^2)` (the straight line in (az, el) is a path no shorter
/// than the geodesic), so `G <= A1^2 exp(-2 lambda_min gamma^2)`, with `lambda_min` the
/// smaller eigenvalue of the quadratic form.
#[derive(Clone, Copy, Debug)]
pub struct AngularBound {
    /// Beam centre direction (world frame).
    centre: V3,
    /// `2 lambda_min` (rad^-2).
    lambda2: f64,
    /// `ln(K A1^2)`, K the detection constant (m^2).
    ln_reach_sq: f64,
}

impl AngularBound {
    pub fn new(sonar: &Sonar, pose: &Pose) -> Option<Self> {
        if sonar.params.receiver.is_some()
            || !matches!(sonar.params.lobe, LobeRule::Detectable { .. })
        {
            return None;
        }
        let b = &sonar.params.emitter;
        let lambda_min = (b.a + b.c) / 2.0 - (((b.a - b.c) / 2.0).powi(2) + b.b * b.b).sqrt();
        if !(lambda_min > 0.0) {
            return None;
        }
        let (ce, se) = (b.el0.cos(), b.el0.sin());
        let (ca, sa) = (b.az0.cos(), b.az0.sin());
        let centre: V3 = std::array::from_fn(|i| {
            ce * ca * pose.forward[i] + ce * sa * pose.left[i] + se * pose.up[i]
        });
        Some(AngularBound {
            centre,
            lambda2: 2.0 * lambda_min * (1.0 - SLACK),
            ln_reach_sq: (sonar.reach_sq_per_gain * b.amplitude * b.amplitude).ln() + SLACK,
        })
    }

    /// True when no point at distance >= `rmin`, within the angle `delta` of the direction
    /// `v / dist`, can count.
    #[inline]
    fn rules_out(&self, v: V3, dist: f64, delta: f64, rmin: f64) -> bool {
        let l = self.ln_reach_sq - 2.0 * rmin.ln();
        if !(l > 0.0) {
            return true;
        }
        let gamma_lim = (l / self.lambda2).sqrt();
        if gamma_lim + delta >= PI {
            return false;
        }
        let cos_gamma = dot(v, self.centre) / dist;
        cos_gamma < (gamma_lim + delta).cos() - SLACK
    }
}

/// The distances from `p` to the nearest and farthest points of the box `[lo, hi]`,
/// loosened by [`SLACK`].
#[inline(always)]
pub(super) fn box_distances(p: V3, lo: V3, hi: V3) -> (f64, f64) {
    let (mut d2, mut f2) = (0.0, 0.0);
    for i in 0..3 {
        let near = if p[i] < lo[i] {
            lo[i] - p[i]
        } else if p[i] > hi[i] {
            p[i] - hi[i]
        } else {
            0.0
        };
        let far = (p[i] - lo[i]).abs().max((hi[i] - p[i]).abs());
        d2 += near * near;
        f2 += far * far;
    }
    (d2.sqrt() * (1.0 - SLACK), f2.sqrt() * (1.0 + SLACK))
}

/// The box's bounding sphere seen from `p`: the offset `v` of its centre, the distance to it,
/// and its angular radius `delta`; None when `p` lies inside the sphere.
#[inline(always)]
pub(super) fn box_cap(p: V3, lo: V3, hi: V3) -> Option<(V3, f64, f64, f64)> {
    let c = [
        (lo[0] + hi[0]) * 0.5,
        (lo[1] + hi[1]) * 0.5,
        (lo[2] + hi[2]) * 0.5,
    ];
    let rad = norm(sub(hi, lo)) * 0.5 * (1.0 + SLACK);
    let v = sub(c, p);
    let dist = norm(v);
    if !(dist > rad) {
        return None;
    }
    let delta = (rad / dist).asin() + SLACK;
    Some((v, dist, rad, delta))
}

/// The (azimuth, elevation) rectangle that holds a cap of angular radius `delta` around the
/// direction `v` (at distance `dist`, bounding radius `rad`) in the pose's frame: its centre
/// azimuth `azc`, half width `h` (pi: every azimuth) and elevations `[e_lo, e_hi]`.
#[derive(Clone, Copy, Debug)]
pub(super) struct CapRect {
    pub(super) azc: f64,
    pub(super) h: f64,
    pub(super) e_lo: f64,
    pub(super) e_hi: f64,
}

#[inline(always)]
pub(super) fn cap_rect(pose: &Pose, v: V3, dist: f64, rad: f64, delta: f64) -> CapRect {
    let vd = dot(v, pose.forward);
    let vl = dot(v, pose.left);
    let vu = dot(v, pose.up);
    let azc = atan2_fast(vl, vd);
    let hd = (vd * vd + vl * vl).sqrt();
    let elc = atan2_fast(vu, hd);
    let (e_lo, e_hi) = ((elc - delta).max(-FRAC_PI_2), (elc + delta).min(FRAC_PI_2));
    let h = if elc.abs() + delta >= FRAC_PI_2 {
        PI
    } else {
        // sin(delta) <= rad / dist + SLACK (delta = asin(rad / dist) + SLACK), and
        // cos(elc) = hd / |(vd, vl, vu)|
        let cos_elc = hd / (hd * hd + vu * vu).sqrt();
        ((rad / dist + SLACK) / cos_elc).min(1.0).asin() + SLACK
    };
    CapRect { azc, h, e_lo, e_hi }
}

/// The smallest and largest one-way gain of the beam `b` over a cap's rectangle.
#[inline(always)]
pub(super) fn gain_range(b: &GaussianBeam, cap: &CapRect) -> (f64, f64) {
    let (ivs, n) = daz_intervals(cap.azc, cap.h, b.az0);
    let (mut qmin, mut qmax) = (f64::INFINITY, 0.0f64);
    for &(a0, a1) in &ivs[..n] {
        let (y0, y1) = (cap.e_lo - b.el0, cap.e_hi - b.el0);
        qmin = qmin.min(b.quad_min_over_rect(a0, a1, y0, y1));
        // a convex quadratic is largest at a corner
        for (x, y) in [(a0, y0), (a0, y1), (a1, y0), (a1, y1)] {
            qmax = qmax.max(b.quad(x, y));
        }
    }
    (b.amplitude * (-qmax).exp(), b.amplitude * (-qmin).exp())
}

/// Conservative test of the box `[lo, hi]` against the lobe of this pose, with an optional
/// cheap angular pre-test (see [`AngularBound`]). Its `atan2` is [`atan2_fast`] (within ~4e-16
/// of libm's, far inside [`SLACK`]; with FMA, from the dispatch below, it costs a fraction of
/// libm's). `cos` and `exp` are libm's: the polynomial ones of [`crate::math::vmath`] are built
/// for vector lanes and cost more one at a time.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub fn test_box(
    sonar: &Sonar,
    pose: &Pose,
    bound: Option<&AngularBound>,
    lo: V3,
    hi: V3,
) -> BoxTest {
    let p = pose.position;
    let (rmin, rmax) = box_distances(p, lo, hi);
    if rmin <= sonar.params.min_range * (1.0 + SLACK) {
        return BoxTest::Partial; // may hold a too-close leaf, which must be reported
    }
    if rmin > sonar.range_limit {
        return BoxTest::Outside;
    }
    let in_range = rmax < sonar.range_limit;
    // Angular extent: the bounding sphere of the box, seen from the pose.
    let Some((v, dist, rad, delta)) = box_cap(p, lo, hi) else {
        return BoxTest::Partial;
    };
    if let Some(b) = bound {
        if b.rules_out(v, dist, delta, rmin) {
            return BoxTest::Outside;
        }
    }
    match sonar.params.lobe {
        LobeRule::Cone { half_angle } => {
            let gamma_c = atan2_fast(norm(cross(v, pose.forward)), dot(v, pose.forward));
            if gamma_c - delta > half_angle + SLACK {
                BoxTest::Outside
            } else if in_range && gamma_c + delta < half_angle - SLACK {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
        LobeRule::Detectable { .. } => {
            let cap = cap_rect(pose, v, dist, rad, delta);
            // Largest and smallest one-way gain over the cap's (az, el) rectangle.
            let (gtx_lo, gtx_hi) = gain_range(&sonar.params.emitter, &cap);
            let (g_lo, g_hi) = match &sonar.params.receiver {
                None => (gtx_lo * gtx_lo, gtx_hi * gtx_hi),
                Some(rx) => {
                    let (r_lo, r_hi) = gain_range(rx, &cap);
                    (gtx_lo * r_lo, gtx_hi * r_hi)
                }
            };
            if rmin > (sonar.reach_sq_per_gain * g_hi).sqrt() * (1.0 + SLACK) {
                BoxTest::Outside
            } else if in_range
                && cap.h < PI
                && rmax < (sonar.reach_sq_per_gain * g_lo).sqrt() * (1.0 - SLACK)
            {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
    }
}
