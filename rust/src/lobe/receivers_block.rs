//! The receivers' exact test on a block of up to [`CB`] candidates at once (lanes): the
//! emitter's side once per block, then each receiver's, with branch-free polynomial `atan2`
//! and `exp`; lanes near a decision's boundary are left to
//! [`classify_heard`](crate::lobe::receivers::classify_heard) (libm), so that every decision
//! equals the scalar test's.
//!
//! Mirrors [`crate::lobe::receivers::classify_heard`] (ranges, gains, the reach and the cone)
//! and [`crate::physics::bistatic::bisector_incidence`]; held to them by
//! `echo::receivers_tests::heard_blocks_match_the_libm_test_to_a_few_ulps`.
use crate::lobe::block::CB;
use crate::lobe::receivers::PlacedReceiver;
use crate::math::vmath::{atan2_fast, exp_nonpos};
use crate::physics::beam::GaussianBeam;
use crate::physics::bistatic::FORWARD_SCATTER_B;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{LobeRule, Sonar};
use std::f64::consts::{FRAC_PI_2, PI};

/// Relative window around the detectable reach in which a lane defers to libm (the lanes'
/// gains err by ~1e-13 relative at worst).
const AMBIGUOUS: f64 = 1e-11;
/// Absolute window around the cone's `cos(half_angle)` in which a lane defers to libm.
const CONE_AMBIGUOUS: f64 = 1e-14;

/// The emitter's side of a block: the candidates' centres and normals, their ranges, unit
/// directions, `e . d` and one-way gains from the emitter.
#[derive(Default)]
pub(crate) struct EmitterLanes {
    pub(crate) cx: [f64; CB],
    pub(crate) cy: [f64; CB],
    pub(crate) cz: [f64; CB],
    pub(crate) nx: [f64; CB],
    pub(crate) ny: [f64; CB],
    pub(crate) nz: [f64; CB],
    pub(crate) r: [f64; CB],
    pub(crate) ex: [f64; CB],
    pub(crate) ey: [f64; CB],
    pub(crate) ez: [f64; CB],
    pub(crate) ed: [f64; CB],
    pub(crate) gain: [f64; CB],
}

/// One receiver's view of a block: per lane 0 out, 1 in, 2 decide with libm; and for lanes
/// in, the two-way gain, the receiver's range and the bisector's incidence.
#[derive(Default)]
pub(crate) struct HeardLanes {
    pub(crate) verdict: [u8; CB],
    pub(crate) gain: [f64; CB],
    pub(crate) r_rx: [f64; CB],
    pub(crate) beta: [f64; CB],
    pub(crate) cos_beta: [f64; CB],
    pub(crate) sin_beta: [f64; CB],
}

/// Unit directions from `at` to the lanes' centres, the ranges (as `range_from` computes
/// them), `e . d`, and the one-way gain of `beam` there (angles in the pose's frame). The
/// angles are ratios of the offset's projections, so they come from the offset itself; one
/// reciprocal of the range makes the unit direction.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn one_way_lanes(
    pose: &Pose,
    beam: &GaussianBeam,
    at: [f64; 3],
    em: &EmitterLanes,
) -> ([f64; CB], [[f64; CB]; 3], [f64; CB], [f64; CB]) {
    let (d, l, u) = (pose.forward, pose.left, pose.up);
    let (mut r, mut e, mut ed, mut gain) = ([0.0; CB], [[0.0; CB]; 3], [0.0; CB], [0.0; CB]);
    let mut q = [0.0; CB];
    for k in 0..CB {
        let dx = [em.cx[k] - at[0], em.cy[k] - at[1], em.cz[k] - at[2]];
        r[k] = (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt();
        let inv_r = 1.0 / r[k];
        (e[0][k], e[1][k], e[2][k]) = (dx[0] * inv_r, dx[1] * inv_r, dx[2] * inv_r);
        let pd = dx[0] * d[0] + dx[1] * d[1] + dx[2] * d[2];
        let pl = dx[0] * l[0] + dx[1] * l[1] + dx[2] * l[2];
        let pu = dx[0] * u[0] + dx[1] * u[1] + dx[2] * u[2];
        ed[k] = pd * inv_r;
        let az = atan2_fast(pl, pd);
        let el = atan2_fast(pu, (pd * pd + pl * pl).sqrt());
        q[k] = beam.quad(beam.delta_az(az), el - beam.el0);
    }
    for k in 0..CB {
        gain[k] = beam.amplitude * exp_nonpos(-q[k]);
    }
    for k in 0..CB {
        if q[k] > 700.0 {
            gain[k] = beam.amplitude * (-q[k]).exp();
        }
    }
    (r, e, ed, gain)
}

/// The emitter's side of the block `ids` (stored indices; `consecutive`: one run).
#[inline(always)]
pub(crate) fn emitter_lanes(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    ids: &[u32],
    consecutive: bool,
    em: &mut EmitterLanes,
) {
    let n = ids.len();
    let (c, nv) = (&scene.centers, &scene.normals);
    if consecutive && n == CB {
        let first = ids[0] as usize;
        let run = |v: &Vec<f64>| -> [f64; CB] {
            v[first..first + CB].try_into().expect("a run of CB leaves")
        };
        (em.cx, em.cy, em.cz) = (run(&c.x), run(&c.y), run(&c.z));
        (em.nx, em.ny, em.nz) = (run(&nv.x), run(&nv.y), run(&nv.z));
    } else {
        for k in 0..CB {
            let i = ids[k.min(n - 1)] as usize;
            (em.cx[k], em.cy[k], em.cz[k]) = (c.x[i], c.y[i], c.z[i]);
            (em.nx[k], em.ny[k], em.nz[k]) = (nv.x[i], nv.y[i], nv.z[i]);
        }
    }
    let (r, e, ed, gain) = one_way_lanes(pose, &sonar.params.emitter, pose.position, em);
    (em.r, em.ex, em.ey, em.ez, em.ed, em.gain) = (r, e[0], e[1], e[2], ed, gain);
}

/// Receiver `rx`'s view of a block whose emitter side is `em` (`n` lanes real).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // (lane loops over several arrays, vectorised)
pub(crate) fn heard_lanes(
    sonar: &Sonar,
    pose: &Pose,
    rx: &PlacedReceiver,
    em: &EmitterLanes,
    n: usize,
    out: &mut HeardLanes,
) {
    let sp = &sonar.params;
    let (r_rx, e_rx, ed_rx, s_rx) = one_way_lanes(pose, rx.beam, rx.position, em);
    let (lo, hi) = ((1.0 - AMBIGUOUS).powi(2), (1.0 + AMBIGUOUS).powi(2));
    let detectable = matches!(sp.lobe, LobeRule::Detectable { .. });
    // The bisector's incidence (`bisector_incidence`): b = e_tx + e_rx, then `incidence` of
    // b / |b|; |b| below FORWARD_SCATTER_B is grazing.
    for k in 0..CB {
        let b = [
            em.ex[k] + e_rx[0][k],
            em.ey[k] + e_rx[1][k],
            em.ez[k] + e_rx[2][k],
        ];
        let nb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        let bu = [b[0] / nb, b[1] / nb, b[2] / nb];
        let cr = [
            bu[1] * em.nz[k] - bu[2] * em.ny[k],
            bu[2] * em.nx[k] - bu[0] * em.nz[k],
            bu[0] * em.ny[k] - bu[1] * em.nx[k],
        ];
        let s = (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        let c = bu[0] * em.nx[k] + bu[1] * em.ny[k] + bu[2] * em.nz[k];
        let bt = atan2_fast(s, c);
        let grazing = !(nb >= FORWARD_SCATTER_B);
        out.beta[k] = if grazing { FRAC_PI_2 } else { bt.min(PI - bt) };
        out.cos_beta[k] = if grazing { 0.0 } else { c.abs().min(1.0) };
        out.sin_beta[k] = if grazing { 1.0 } else { s.min(1.0) };
    }
    for k in 0..CB {
        let (r_tx, r) = (em.r[k], r_rx[k]);
        let g = em.gain[k] * s_rx[k];
        out.gain[k] = g;
        out.r_rx[k] = r;
        let near = r_tx >= sp.min_range && r >= sp.min_range;
        let in_record = (r_tx + r) / 2.0 <= sonar.range_limit;
        let mut v = u8::from(near && in_record);
        if detectable {
            // sqrt(r_tx r_rx) against the reach sqrt(K g), squared
            let (rr, reach_sq) = (r_tx * r, sonar.reach_sq_per_gain * g);
            if rr > reach_sq * hi {
                v = 0;
            } else if !(rr <= reach_sq * lo) && v == 1 {
                v = 2;
            }
        } else {
            let c = sonar.cos_half_angle;
            let worst = em.ed[k].min(ed_rx[k]);
            if worst < c - CONE_AMBIGUOUS {
                v = 0;
            } else if !(worst > c + CONE_AMBIGUOUS) && v == 1 {
                v = 2;
            }
        }
        out.verdict[k] = v;
    }
    for v in &mut out.verdict[n..] {
        *v = 0;
    }
}
