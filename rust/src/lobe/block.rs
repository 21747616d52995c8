//! The exact test for a block of up to [`CB`] candidates at once (lanes): ranges, angles, gains
//! and incidence by branch-free polynomial code, with the cases near a boundary left to
//! [`classify`](crate::lobe::rule::classify).
use crate::lobe::members::classify_member;
use crate::lobe::members::Member;
use crate::math::vec3::{cross, V3};
use crate::math::vmath::{atan2_from_ratio, atan2_ratio, exp_nonpos};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{LeafModel, LobeRule, Sonar};
use std::f64::consts::PI;

/// Relative window around the detectable reach in which the fast decision defers to the libm
/// test. The fast gain errs by ~1e-13 relative at worst (exp of arguments up to 700).
const AMBIGUOUS: f64 = 1e-11;

/// Leaves per vector block of the fast test (16: two AVX-512 vectors per operation, so that
/// the long dependent chains of the atan2 and exp polynomials overlap).
pub(crate) const CB: usize = 16;

/// What the exact test says about each lane of a block of up to [`CB`] candidates.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct BlockView {
    /// Per lane: 0 out, 1 in, 2 within [`AMBIGUOUS`] of the reach or [`CONE_AMBIGUOUS`] of
    /// the cone's edge (decide with [`classify`]).
    pub verdict: [u8; CB],
    pub gain: [f64; CB],
    pub beta: [f64; CB],
    pub cos_beta: [f64; CB],
    pub sin_beta: [f64; CB],
}

impl BlockView {
    /// Lane `k` (candidate `i` at range `r`) as a member, or None when it does not count.
    #[inline(always)]
    pub(crate) fn member(
        &self,
        k: usize,
        i: u32,
        r: f64,
        scene: &Scene,
        sonar: &Sonar,
        pose: &Pose,
    ) -> Option<Member> {
        match self.verdict[k] {
            1 => Some(Member {
                index: i,
                range: r,
                gain: self.gain[k],
                beta: self.beta[k],
                cos_beta: self.cos_beta[k],
                sin_beta: self.sin_beta[k],
            }),
            2 => classify_member(scene, sonar, pose, i),
            _ => None,
        }
    }
}

/// The vector part of the exact test for up to [`CB`] candidates `(index, range)` already
/// within `[min_range, range_limit]`. The range is [`classify`]'s; azimuth, elevation, gain
/// and incidence come from the unnormalised offset with the polynomial `atan2` and `exp` of
/// [`crate::math::vmath`] (angles within ~6e-16 of libm's, gains ~1e-14 relative; physical optics'
/// cos and sin of the incidence exactly as [`incidence`] forms them). A lane whose range lies
/// within [`AMBIGUOUS`] of its detectable reach, or whose direction lies within
/// [`CONE_AMBIGUOUS`] of the cone's edge, is marked for [`classify`] (libm), so that every
/// decision equals the scalar test's.
#[inline(always)]
pub(crate) fn classify_block(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    block: &[(u32, f64)],
) -> BlockView {
    let p = pose.position;
    let n = block.len();
    // Gather (missing lanes repeat the last candidate).
    let mut g = Gathered::default();
    for k in 0..CB {
        let (i, rk) = block[k.min(n - 1)];
        let c = scene.centers.get(i as usize);
        let nv = scene.normals.get(i as usize);
        (g.dx[k], g.dy[k], g.dz[k], g.r[k]) = (c[0] - p[0], c[1] - p[1], c[2] - p[2], rk);
        (g.nx[k], g.ny[k], g.nz[k]) = (nv[0], nv[1], nv[2]);
    }
    classify_lanes(sonar, pose, &g, n)
}

/// How far ahead of a run's block (in stored leaves) the lobe test prefetches the next
/// coordinates: the hardware prefetcher alone leaves the six coordinate streams waiting on
/// memory.
const PREFETCH_AHEAD: usize = 128;

/// Offsets, ranges and normals of up to [`CB`] candidates, lanes.
#[derive(Default)]
pub(super) struct Gathered {
    pub(super) dx: [f64; CB],
    pub(super) dy: [f64; CB],
    pub(super) dz: [f64; CB],
    pub(super) r: [f64; CB],
    pub(super) nx: [f64; CB],
    pub(super) ny: [f64; CB],
    pub(super) nz: [f64; CB],
}

/// The whole exact test for up to [`CB`] candidates, the range pass included (the fused
/// pulse's path: no list of in-range candidates): as [`near_candidates`] then
/// [`classify_block`], the view written into `v` and the lanes' ranges returned. Lanes
/// outside `[min_range, range_limit]` are out; the smallest caller index of a too-close leaf
/// goes to `too_close`.
#[inline(always)]
pub(crate) fn classify_candidates(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    cands: &[u32],
    consecutive: bool,
    too_close: &mut Option<(usize, f64)>,
    v: &mut BlockView,
) -> [f64; CB] {
    let p = pose.position;
    let sp = &sonar.params;
    let n = cands.len();
    let mut g = Gathered::default();
    if consecutive && n == CB {
        // a run of stored leaves: plain loads, no gather
        let first = cands[0] as usize;
        let (c, nv) = (&scene.centers, &scene.normals);
        for v in [&c.x, &c.y, &c.z, &nv.x, &nv.y, &nv.z] {
            crate::math::prefetch::ahead::<_, CB>(v, first + PREFETCH_AHEAD);
        }
        let run = |v: &Vec<f64>| -> [f64; CB] {
            v[first..first + CB].try_into().expect("a run of CB leaves")
        };
        let (cx, cy, cz) = (run(&c.x), run(&c.y), run(&c.z));
        (g.nx, g.ny, g.nz) = (run(&nv.x), run(&nv.y), run(&nv.z));
        for k in 0..CB {
            (g.dx[k], g.dy[k], g.dz[k]) = (cx[k] - p[0], cy[k] - p[1], cz[k] - p[2]);
        }
    } else {
        for k in 0..CB {
            let i = cands[k.min(n - 1)] as usize;
            let (c, nv) = (scene.centers.get(i), scene.normals.get(i));
            (g.dx[k], g.dy[k], g.dz[k]) = (c[0] - p[0], c[1] - p[1], c[2] - p[2]);
            (g.nx[k], g.ny[k], g.nz[k]) = (nv[0], nv[1], nv[2]);
        }
    }
    // the range exactly as `classify` computes it
    for k in 0..CB {
        g.r[k] = (g.dx[k] * g.dx[k] + g.dy[k] * g.dy[k] + g.dz[k] * g.dz[k]).sqrt();
    }
    // (a loop, not `map`: the generic `map` can be an out-of-line call compiled for baseline
    // x86-64, outside the fused pulse's AVX-512 clone)
    let mut inside = [false; CB];
    for (ok, &r) in inside.iter_mut().zip(&g.r) {
        *ok = r >= sp.min_range && r <= sonar.range_limit;
    }
    if g.r.iter().any(|&r| !(r >= sp.min_range)) {
        for (k, &i) in cands.iter().enumerate() {
            if !(g.r[k] >= sp.min_range) {
                let id = scene.ids[i as usize] as usize;
                if too_close.is_none_or(|(j, _)| id < j) {
                    *too_close = Some((id, g.r[k]));
                }
            }
        }
    }
    classify_lanes_into(sonar, pose, &g, n, v);
    for (verdict, ok) in v.verdict.iter_mut().zip(inside) {
        if !ok {
            *verdict = 0;
        }
    }
    g.r
}

/// [`classify_block`] on gathered lanes (`n` of them real; the rest repeat the last).
/// Branch-free loops over the lanes (each vectorises).
#[inline(always)]
pub(super) fn classify_lanes(sonar: &Sonar, pose: &Pose, g: &Gathered, n: usize) -> BlockView {
    let mut v = BlockView::default();
    classify_lanes_into(sonar, pose, g, n, &mut v);
    v
}

/// [`classify_lanes`] into `v` (every field written). The fused pulse keeps one view per
/// task: a view returned by value (528 bytes) is copied twice per block, each copy a call to
/// `memcpy` after a `vzeroupper`.
///
/// Mirrors [`crate::lobe::rule::classify`] (the two-way gain of
/// [`crate::physics::beam::GaussianBeam::gain`], the reach `r^2 <= K G` of
/// [`crate::physics::amplitude::detection_constant`], the cone) and, in
/// [`incidence_lanes`], [`crate::physics::leaf::incidence`]; held to them by
/// `lobe::tests::block_views_match_the_libm_test_to_a_few_ulps`.
#[inline(always)]
fn classify_lanes_into(sonar: &Sonar, pose: &Pose, g: &Gathered, n: usize, v: &mut BlockView) {
    let (d, u, l) = (pose.forward, pose.up, pose.left);
    let sp = &sonar.params;
    let detectable = matches!(sp.lobe, LobeRule::Detectable { .. });
    let Gathered {
        dx,
        dy,
        dz,
        r,
        nx,
        ny,
        nz,
    } = g;
    // The angles are ratios of the offset's projections, so the offset is not normalised.
    let (mut pd, mut pl, mut pu) = ([0.0; CB], [0.0; CB], [0.0; CB]);
    for k in 0..CB {
        pd[k] = dx[k] * d[0] + dy[k] * d[1] + dz[k] * d[2];
        pl[k] = dx[k] * l[0] + dy[k] * l[1] + dz[k] * l[2];
        pu[k] = dx[k] * u[0] + dy[k] * u[1] + dz[k] * u[2];
    }
    // The incidence's sine and cosine, times r. Physical optics scales the echo by them, so
    // for it they come from e = dx / r exactly as `incidence` computes them (a leaf that the
    // reference finds exactly edge-on is edge-on here too); the paper model needs only beta.
    let po = sp.leaf_model == LeafModel::PhysicalOptics;
    let (mut sb, mut cb, mut hz) = ([0.0; CB], [0.0; CB], [0.0; CB]);
    let normals = [nx, ny, nz];
    if po {
        let e = |k: usize| [dx[k] / r[k], dy[k] / r[k], dz[k] / r[k]];
        incidence_lanes(e, normals, &mut sb, &mut cb);
    } else {
        incidence_lanes(|k| [dx[k], dy[k], dz[k]], normals, &mut sb, &mut cb);
    }
    for k in 0..CB {
        hz[k] = (pd[k] * pd[k] + pl[k] * pl[k]).sqrt();
    }
    // The three atan2 ratios (azimuth, elevation, incidence) and 1/r (for cos and sin of
    // the incidence and the cone test) from one division, of the product of the four
    // denominators (a few ulps each, against 0.5 for four divisions). The elevation's and
    // the incidence's lie within [r / 2, 2 r] (unit normals); the azimuth's within [0, 2 r]
    // (1 where it is 0: a leaf straight above or below). A block whose product leaves
    // [1e-250, 1e250] (a range outside [1e-60, 1e60] m, or an azimuth denominator below
    // ~1e-250 / r^3) divides them one by one.
    let (mut t_az, mut t_el, mut t_b, mut inv_r) = ([0.0; CB], [0.0; CB], [0.0; CB], [0.0; CB]);
    let mut one_division = true;
    for k in 0..CB {
        let (n1, d1) = atan2_ratio(pl[k], pd[k]);
        let (n2, d2) = atan2_ratio(pu[k], hz[k]);
        // (the incidence's ratio brought to the scale r where its terms are unit-scale)
        let unit = if po { r[k] } else { 1.0 };
        let (n3, d3) = atan2_ratio(sb[k], cb[k]);
        let (n3, d3) = (n3 * unit, d3 * unit);
        let (d12, d3r) = (d1 * d2, d3 * r[k]);
        let prod = d12 * d3r;
        one_division &= prod > 1e-250 && prod < 1e250;
        let rcp = 1.0 / prod;
        t_az[k] = n1 * (d2 * d3r) * rcp;
        t_el[k] = n2 * (d1 * d3r) * rcp;
        t_b[k] = n3 * (d12 * r[k]) * rcp;
        inv_r[k] = (d12 * d3) * rcp;
    }
    if !one_division {
        for k in 0..CB {
            let ((n1, d1), (n2, d2)) = (atan2_ratio(pl[k], pd[k]), atan2_ratio(pu[k], hz[k]));
            let (n3, d3) = atan2_ratio(sb[k], cb[k]);
            (t_az[k], t_el[k], t_b[k]) = (n1 / d1, n2 / d2, n3 / d3);
            inv_r[k] = 1.0 / r[k];
        }
    }
    v.verdict = [0; CB];
    v.gain = [0.0; CB];
    let (mut az, mut el) = ([0.0; CB], [0.0; CB]);
    for k in 0..CB {
        az[k] = atan2_from_ratio(pl[k], pd[k], t_az[k]);
        el[k] = atan2_from_ratio(pu[k], hz[k], t_el[k]);
        let bt = atan2_from_ratio(sb[k], cb[k], t_b[k]);
        v.beta[k] = bt.min(PI - bt);
        let to_unit = if po { 1.0 } else { inv_r[k] };
        v.cos_beta[k] = (cb[k].abs() * to_unit).min(1.0);
        v.sin_beta[k] = (sb[k] * to_unit).min(1.0);
    }
    let quad_lanes = |b: &crate::physics::beam::GaussianBeam, q: &mut [f64; CB]| {
        for k in 0..CB {
            q[k] = b.quad(b.delta_az(az[k]), el[k] - b.el0);
        }
    };
    let (mut q_tx, mut q_rx) = ([0.0; CB], [0.0; CB]);
    quad_lanes(&sp.emitter, &mut q_tx);
    match &sp.receiver {
        Some(rx) => quad_lanes(rx, &mut q_rx),
        None => q_rx = q_tx,
    }
    // Gains: the polynomial exp holds down to exp(-700); beyond, libm (subnormal or 0).
    let (mut s_tx, mut s_rx) = ([0.0; CB], [0.0; CB]);
    for k in 0..CB {
        s_tx[k] = exp_nonpos(-q_tx[k]);
    }
    if sp.receiver.is_some() {
        for k in 0..CB {
            s_rx[k] = exp_nonpos(-q_rx[k]);
        }
    } else {
        s_rx = s_tx;
    }
    for k in 0..n {
        if q_tx[k] > 700.0 {
            s_tx[k] = (-q_tx[k]).exp();
        }
        if q_rx[k] > 700.0 {
            s_rx[k] = (-q_rx[k]).exp();
        }
    }
    let rx_amp = sonar.receiver().amplitude;
    let (lo, hi) = ((1.0 - AMBIGUOUS).powi(2), (1.0 + AMBIGUOUS).powi(2));
    for k in 0..n {
        let r = r[k];
        let g = (sp.emitter.amplitude * s_tx[k]) * (rx_amp * s_rx[k]);
        v.gain[k] = g;
        v.verdict[k] = 1;
        if detectable {
            // r against the reach sqrt(K g), squared
            let reach_sq = sonar.reach_sq_per_gain * g;
            if r * r > reach_sq * hi {
                v.verdict[k] = 0;
            } else if !(r * r <= reach_sq * lo) {
                v.verdict[k] = 2;
            }
        } else {
            // the cone: `classify` divides first (e = dx / r, then e.d); this product
            // differs from it by a few ulps, so a lane that close to the edge is left to it
            let ed = pd[k] * inv_r[k];
            if ed < sonar.cos_half_angle - CONE_AMBIGUOUS {
                v.verdict[k] = 0;
            } else if !(ed > sonar.cos_half_angle + CONE_AMBIGUOUS) {
                v.verdict[k] = 2;
            }
        }
    }
}

/// `|e x n|` and `e . n` of each lane, with `e(k)` the lane's direction (any scale), as
/// [`crate::physics::leaf::incidence`] forms them.
#[inline(always)]
fn incidence_lanes(
    e: impl Fn(usize) -> V3,
    [nx, ny, nz]: [&[f64; CB]; 3],
    sb: &mut [f64; CB],
    cb: &mut [f64; CB],
) {
    for k in 0..CB {
        let e = e(k);
        let cr = cross(e, [nx[k], ny[k], nz[k]]);
        sb[k] = (cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]).sqrt();
        cb[k] = e[0] * nx[k] + e[1] * ny[k] + e[2] * nz[k];
    }
}

/// Absolute window around the cone's `cos(half_angle)` in which the fast decision defers to
/// [`classify`] (the two cosines differ by a few ulps).
const CONE_AMBIGUOUS: f64 = 1e-14;
