//! Which leaves count for a pose (MODEL.md section 3): the exact per-leaf test in f64, and a
//! conservative traversal of an obvhs BVH over the leaf centres that only ever skips nodes
//! that provably hold no counting leaf. The index never changes the answer: every candidate
//! goes through the same exact test as the brute-force scan.

pub mod candidates;

use crate::lobe::candidates::Candidates;
use crate::error::{Error, Result};
use crate::physics::pose::{cross, dot, norm, sub, Pose, V3};
use crate::scene::Scene;
use crate::sonar::{LeafModel, LobeRule, Sonar, TooClose};
use crate::math::vmath::{atan2_fast, atan2_from_ratio, atan2_ratio, exp_nonpos};
use multiversion::multiversion;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

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

/// The exact f64 test of MODEL.md section 3 for one leaf centre. The reference implementation
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
const SLACK: f64 = 1e-9;

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

/// Conservative test of the box `[lo, hi]` against the lobe of this pose, with an optional
/// cheap angular pre-test (see [`AngularBound`]). Its `atan2` is [`atan2_fast`] (within ~4e-16
/// of libm's, far inside [`SLACK`]; with FMA, from the dispatch below, it costs a fraction of
/// libm's, which took ~12 % of a 10-degree lobe query). The polynomial `cos` and `exp` of
/// [`crate::math::vmath`], built for vector lanes, measured slower here than libm's, one at a time.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub fn test_box(
    sonar: &Sonar,
    pose: &Pose,
    bound: Option<&AngularBound>,
    lo: V3,
    hi: V3,
) -> BoxTest {
    let p = pose.position;
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
    let rmin = d2.sqrt() * (1.0 - SLACK);
    let rmax = f2.sqrt() * (1.0 + SLACK);
    if rmin <= sonar.params.min_range * (1.0 + SLACK) {
        return BoxTest::Partial; // may hold a too-close leaf, which must be reported
    }
    if rmin > sonar.range_limit {
        return BoxTest::Outside;
    }
    let in_range = rmax < sonar.range_limit;
    // Angular extent: the bounding sphere of the box, seen from the pose.
    let c = [
        (lo[0] + hi[0]) * 0.5,
        (lo[1] + hi[1]) * 0.5,
        (lo[2] + hi[2]) * 0.5,
    ];
    let rad = norm(sub(hi, lo)) * 0.5 * (1.0 + SLACK);
    let v = sub(c, p);
    let dist = norm(v);
    if !(dist > rad) {
        return BoxTest::Partial;
    }
    let delta = (rad / dist).asin() + SLACK;
    if let Some(b) = bound {
        if b.rules_out(v, dist, delta, rmin) {
            return BoxTest::Outside;
        }
    }
    let vd = dot(v, pose.forward);
    let vl = dot(v, pose.left);
    let vu = dot(v, pose.up);
    match sonar.params.lobe {
        LobeRule::Cone { half_angle } => {
            let gamma_c = atan2_fast(norm(cross(v, pose.forward)), vd);
            if gamma_c - delta > half_angle + SLACK {
                BoxTest::Outside
            } else if in_range && gamma_c + delta < half_angle - SLACK {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
        LobeRule::Detectable { .. } => {
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
            // Largest and smallest one-way gain over the cap's (az, el) rectangle.
            let gain_range = |b: &crate::physics::beam::GaussianBeam| -> (f64, f64) {
                let (ivs, n) = daz_intervals(azc, h, b.az0);
                let (mut qmin, mut qmax) = (f64::INFINITY, 0.0f64);
                for &(a0, a1) in &ivs[..n] {
                    let (y0, y1) = (e_lo - b.el0, e_hi - b.el0);
                    qmin = qmin.min(b.quad_min_over_rect(a0, a1, y0, y1));
                    // a convex quadratic is largest at a corner
                    for (x, y) in [(a0, y0), (a0, y1), (a1, y0), (a1, y1)] {
                        qmax = qmax.max(b.quad(x, y));
                    }
                }
                (b.amplitude * (-qmax).exp(), b.amplitude * (-qmin).exp())
            };
            let (gtx_lo, gtx_hi) = gain_range(&sonar.params.emitter);
            let (g_lo, g_hi) = match &sonar.params.receiver {
                None => (gtx_lo * gtx_lo, gtx_hi * gtx_hi),
                Some(rx) => {
                    let (r_lo, r_hi) = gain_range(rx);
                    (gtx_lo * r_lo, gtx_hi * r_hi)
                }
            };
            if rmin > (sonar.reach_sq_per_gain * g_hi).sqrt() * (1.0 + SLACK) {
                BoxTest::Outside
            } else if in_range
                && h < PI
                && rmax < (sonar.reach_sq_per_gain * g_lo).sqrt() * (1.0 - SLACK)
            {
                BoxTest::Inside
            } else {
                BoxTest::Partial
            }
        }
    }
}

/// Subtrees with at most this many leaves are not bounded: all their leaves become candidates
/// (the exact test rejects the rest at a few nanoseconds each; a node test costs ~0.2 us).
const SMALL_SUBTREE: u32 = 8;

/// Levels of the BVH whose subtrees are walked as parallel tasks (up to 2^8 tasks): a beam's
/// boundary crosses many nodes, and the walk is bound by fetching them (a detectable 30° lobe
/// over 1e6 leaves: ~12 ms on one thread).
const PAR_LEVELS: u32 = 8;
/// Subtrees with fewer leaves than this are walked in one task (a narrow beam, or a small
/// scene, gains nothing from splitting its walk).
const PAR_MIN_LEAVES: u32 = 8192;

/// Every leaf the BVH cannot rule out (a superset of the counting leaves), in traversal order:
/// a whole subtree or a BVH leaf at a time. Called from a pool thread, the top [`PAR_LEVELS`]
/// levels split into parallel tasks whose candidates are appended in traversal order, so the
/// result is that of one sequential walk for any number of threads.
pub fn bvh_candidates(scene: &Scene, sonar: &Sonar, pose: &Pose) -> Candidates {
    if scene.bvh.nodes.is_empty() {
        return Candidates::default();
    }
    let walk = Walk {
        scene,
        sonar,
        pose,
        bound: AngularBound::new(sonar, pose),
        // With `node_ranges`, the scene is stored in BVH order (`primitive_indices` is the
        // identity), so a node's leaves are the run of stored indices below it.
        in_order: !scene.node_ranges.is_empty(),
    };
    // (only from inside the pool, where a split costs a push onto this thread's queue: from
    // outside, each split would be sent to the pool and waited for)
    let levels = match rayon::current_thread_index() {
        Some(_) => PAR_LEVELS,
        None => 0,
    };
    walk.par_subtree(0, false, levels)
}

/// The candidates of a pose in a thread-independent order: the BVH's traversal order, or
/// every leaf in index order.
pub fn candidates(scene: &Scene, sonar: &Sonar, pose: &Pose, search: Search) -> Candidates {
    match search {
        Search::Bvh => bvh_candidates(scene, sonar, pose),
        Search::BruteForce => Candidates::all(scene.len()),
    }
}

/// What the walk does at one node.
enum Step<'a> {
    /// Outside the lobe: nothing below it counts.
    Skip,
    /// Its leaves are these stored indices (or these ids, out of order).
    Run(u32, u32),
    Ids(&'a [u32]),
    /// Its two children, and whether an ancestor was entirely inside.
    Children(u32, bool),
}

/// The BVH walk of [`bvh_candidates`] for one pose.
struct Walk<'a> {
    scene: &'a Scene,
    sonar: &'a Sonar,
    pose: &'a Pose,
    bound: Option<AngularBound>,
    in_order: bool,
}

impl Walk<'_> {
    /// Node `ni`, `inside` when an ancestor was entirely inside the lobe.
    #[inline(always)]
    fn step(&self, ni: u32, inside: bool) -> Step<'_> {
        let (scene, bvh) = (self.scene, &self.scene.bvh);
        let node = &bvh.nodes[ni as usize];
        // A subtree this small costs less to test leaf by leaf (vectorised) than to bound.
        let small = match scene.node_ranges.get(ni as usize) {
            Some(&(lo, hi)) => hi - lo <= SMALL_SUBTREE,
            None => node.is_leaf(),
        };
        let inside = inside || small || {
            let a = node.aabb();
            let lo = [a.min.x as f64, a.min.y as f64, a.min.z as f64];
            let hi = [a.max.x as f64, a.max.y as f64, a.max.z as f64];
            match test_box(self.sonar, self.pose, self.bound.as_ref(), lo, hi) {
                BoxTest::Outside => return Step::Skip,
                BoxTest::Partial => false,
                BoxTest::Inside => true,
            }
        };
        if inside && self.in_order {
            // the whole subtree counts as candidates: its stored leaves are one run
            let (lo, hi) = scene.node_ranges[ni as usize];
            Step::Run(lo, hi)
        } else if node.is_leaf() {
            let (first, count) = (node.first_index, node.prim_count);
            if self.in_order {
                Step::Run(first, first + count)
            } else {
                Step::Ids(&bvh.primitive_indices[first as usize..(first + count) as usize])
            }
        } else {
            Step::Children(node.first_index, inside)
        }
    }

    /// The candidates below node `ni`, depth first, onto `out`.
    fn subtree(&self, ni: u32, inside: bool, out: &mut Candidates) {
        let mut stack: Vec<(u32, bool)> = Vec::with_capacity(64);
        stack.push((ni, inside));
        while let Some((ni, inside)) = stack.pop() {
            match self.step(ni, inside) {
                Step::Skip => {}
                Step::Run(lo, hi) => out.push_run(lo, hi),
                Step::Ids(ids) => out.push_ids(ids),
                Step::Children(first, inside) => {
                    stack.push((first + 1, inside));
                    stack.push((first, inside));
                }
            }
        }
    }

    /// [`Walk::subtree`] with the children of the top `levels` levels walked in parallel
    /// (those of subtrees of at least [`PAR_MIN_LEAVES`] leaves).
    fn par_subtree(&self, ni: u32, inside: bool, levels: u32) -> Candidates {
        let mut out = Candidates::default();
        let small = match self.scene.node_ranges.get(ni as usize) {
            Some(&(lo, hi)) => hi - lo < PAR_MIN_LEAVES,
            None => false,
        };
        if levels == 0 || small {
            self.subtree(ni, inside, &mut out);
            return out;
        }
        match self.step(ni, inside) {
            Step::Skip => {}
            Step::Run(lo, hi) => out.push_run(lo, hi),
            Step::Ids(ids) => out.push_ids(ids),
            Step::Children(first, inside) => {
                let (a, b) = rayon::join(
                    || self.par_subtree(first, inside, levels - 1),
                    || self.par_subtree(first + 1, inside, levels - 1),
                );
                out = a;
                out.append(&b);
            }
        }
        out
    }
}

/// One counting leaf: its index, range, two-way gain and incidence angle `beta` in [0, pi/2].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Member {
    pub index: u32,
    pub range: f64,
    pub gain: f64,
    pub beta: f64,
    /// `cos(beta) = |e . n|` and `sin(beta) = |e x n|`, straight from the geometry (well
    /// conditioned at normal and grazing incidence, where `cos(atan2(...))` is not).
    pub cos_beta: f64,
    pub sin_beta: f64,
}

/// Incidence angle between the unit direction `e` and the unit normal `n`, folded to [0, pi/2],
/// with its cosine `|e . n|` and sine `|e x n|`. The angle is `atan2(|e x n|, e . n)`, which
/// stays accurate at normal and grazing incidence.
#[inline]
pub fn incidence(e: V3, n: V3) -> (f64, f64, f64) {
    let s = norm(cross(e, n));
    let c = dot(e, n);
    let b = s.atan2(c);
    (b.min(PI - b), c.abs().min(1.0), s.min(1.0))
}

/// How the candidates are found; the result is the same either way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Search {
    Bvh,
    BruteForce,
}

/// Candidates per parallel task of the exact test.
const CLASSIFY_CHUNK: usize = 2048;

/// Per chunk of candidates: the counting leaves, and the first too-close leaf (index, range).
type Part = (Vec<Member>, Option<(usize, f64)>);

/// Relative window around the detectable reach in which the fast decision defers to the libm
/// test. The fast gain errs by ~1e-13 relative at worst (exp of arguments up to 700).
const AMBIGUOUS: f64 = 1e-11;

/// Leaves per vector block of the fast test (16: two AVX-512 vectors per operation, so that
/// the long dependent chains of the atan2 and exp polynomials overlap; 8 was 3% slower).
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
/// coordinates. Measured on the 1e6-leaf box scene: 128 against 64 and 256; with it the fused
/// pulse ran ~5 % faster (the hardware prefetcher alone left the six coordinate streams
/// waiting on memory).
const PREFETCH_AHEAD: usize = 128;

/// Offsets, ranges and normals of up to [`CB`] candidates, lanes.
#[derive(Default)]
struct Gathered {
    dx: [f64; CB],
    dy: [f64; CB],
    dz: [f64; CB],
    r: [f64; CB],
    nx: [f64; CB],
    ny: [f64; CB],
    nz: [f64; CB],
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
    // (a loop, not `map`: the generic `map` was an out-of-line call, compiled for baseline
    // x86-64, in the fused pulse's AVX-512 clone)
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
fn classify_lanes(sonar: &Sonar, pose: &Pose, g: &Gathered, n: usize) -> BlockView {
    let mut v = BlockView::default();
    classify_lanes_into(sonar, pose, g, n, &mut v);
    v
}

/// [`classify_lanes`] into `v` (every field written). The fused pulse keeps one view per
/// task: a view returned by value (528 bytes) was copied twice per block, each copy a call
/// to `memcpy` after a `vzeroupper`.
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

/// `|e x n|` and `e . n` of each lane, with `e(k)` the lane's direction (any scale).
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

/// The libm decision for a leaf on the detectable boundary (see [`classify_block`]), exactly
/// as the reference makes it.
pub(crate) fn classify_member(scene: &Scene, sonar: &Sonar, pose: &Pose, i: u32) -> Option<Member> {
    match classify(sonar, pose, scene.centers.get(i as usize)) {
        Decision::In(v) => {
            let (beta, cos_beta, sin_beta) = incidence(v.dir, scene.normals.get(i as usize));
            Some(Member {
                index: i,
                range: v.range,
                gain: v.gain,
                beta,
                cos_beta,
                sin_beta,
            })
        }
        _ => None,
    }
}

/// The range (m) of stored leaf `i` from the pose, exactly as [`classify`] computes it.
#[inline(always)]
fn leaf_range(scene: &Scene, pose: &Pose, i: u32) -> f64 {
    let (c, p) = (scene.centers.get(i as usize), pose.position);
    let dx = [c[0] - p[0], c[1] - p[1], c[2] - p[2]];
    (dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]).sqrt()
}

/// Pass 1 of the exact test, cheap: the range of every candidate (the same operations as
/// [`classify`]). Candidates within `[min_range, range_limit]` go to `near`; the smallest index
/// of a too-close leaf (the caller's index, with its range) is kept in `too_close`.
#[inline(always)]
pub(crate) fn near_candidates(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    chunk: &[u32],
    near: &mut Vec<(u32, f64)>,
    too_close: &mut Option<(usize, f64)>,
) {
    let sp = &sonar.params;
    for &i in chunk {
        let r = leaf_range(scene, pose, i);
        if !(r >= sp.min_range) {
            let id = scene.ids[i as usize] as usize;
            if too_close.is_none_or(|(j, _)| id < j) {
                *too_close = Some((id, r));
            }
        } else if r <= sonar.range_limit {
            near.push((i, r));
        }
    }
}

/// The exact test for a chunk of candidates, eight at a time ([`classify_block`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn classify_many(scene: &Scene, sonar: &Sonar, pose: &Pose, chunk: &[u32]) -> Part {
    let mut out = Vec::with_capacity(chunk.len());
    let mut too_close = None;
    let mut near: Vec<(u32, f64)> = Vec::with_capacity(chunk.len());
    near_candidates(scene, sonar, pose, chunk, &mut near, &mut too_close);
    for block in near.chunks(CB) {
        let v = classify_block(scene, sonar, pose, block);
        for (k, &(i, r)) in block.iter().enumerate() {
            out.extend(v.member(k, i, r, scene, sonar, pose));
        }
    }
    (out, too_close)
}

/// The counting leaves for one pose, sorted by stored index (the scene's BVH order; map with
/// `scene.ids` to the caller's indices). `pose_index` only labels errors. The exact test runs
/// on the candidates in parallel chunks (in index order, so the result does not depend on the
/// number of threads).
pub fn members(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    search: Search,
) -> Result<Vec<Member>> {
    members_of(
        scene,
        sonar,
        pose,
        pose_index,
        candidates(scene, sonar, pose, search).to_vec(),
    )
}

/// [`members`] from the pose's candidates (any order; they are sorted here).
pub fn members_of(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    mut candidates: Vec<u32>,
) -> Result<Vec<Member>> {
    if !candidates.is_sorted() {
        candidates.par_sort_unstable();
    }
    let classify_chunk = |chunk: &[u32]| -> Part { classify_many(scene, sonar, pose, chunk) };
    let parts: Vec<Part> = if candidates.len() <= CLASSIFY_CHUNK {
        vec![classify_chunk(&candidates)]
    } else {
        candidates
            .par_chunks(CLASSIFY_CHUNK)
            .map(classify_chunk)
            .collect()
    };
    if sonar.params.too_close == TooClose::Error {
        if let Some((leaf, range)) = parts.iter().filter_map(|p| p.1).min_by_key(|&(l, _)| l) {
            return Err(Error::TooClose {
                pose: pose_index,
                leaf,
                range,
                min_range: sonar.params.min_range,
            });
        }
    }
    let mut out = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
    for (m, _) in parts {
        out.extend(m);
    }
    Ok(out)
}

/// The range (m) of the farthest counting leaf of one pose (0 where none counts): the largest
/// range among [`members`], and the same error where a leaf is too close, without testing
/// every candidate. The candidates' ranges first (in parallel; a range, not the lobe test),
/// then the exact test for those in range slices from the farthest down, each slice twice as
/// wide as the last (1/64 of the span of ranges first), until a slice holds a counting leaf:
/// every farther leaf was tested and does not count, so that slice's farthest member is the
/// pose's. In a full lobe the first slice decides. (`n_samples = "auto"` took a whole lobe
/// query per pose before this: 39 ms at 1e6 leaves, more than a fast pulse.)
pub fn farthest_member_range(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
    search: Search,
) -> Result<f64> {
    let sp = &sonar.params;
    let ids = candidates(scene, sonar, pose, search).to_vec();
    let ranges: Vec<f64> = ids
        .par_iter()
        .with_min_len(CLASSIFY_CHUNK)
        .map(|&i| leaf_range(scene, pose, i))
        .collect();
    if sp.too_close == TooClose::Error && ranges.par_iter().any(|&r| !(r >= sp.min_range)) {
        // (the error exactly as `members` reports it)
        return members_of(scene, sonar, pose, pose_index, ids).map(|m| farthest_of(&m));
    }
    let can_count = |r: f64| r >= sp.min_range && r <= sonar.range_limit;
    let span = ranges
        .par_iter()
        .with_min_len(CLASSIFY_CHUNK)
        .filter(|&&r| can_count(r))
        .map(|&r| (r, r))
        .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)));
    let Some((lo, hi)) = span else {
        return Ok(0.0);
    };
    let (mut top, mut width) = (f64::INFINITY, (hi - lo) / 64.0);
    loop {
        // the slice [bottom, top); the last one reaches down to `lo`
        let bottom = if hi - width > lo {
            hi - width
        } else {
            f64::NEG_INFINITY
        };
        let slice: Vec<u32> = ids
            .par_iter()
            .zip(&ranges)
            .with_min_len(CLASSIFY_CHUNK)
            .filter(|&(_, &r)| r >= bottom && r < top && can_count(r))
            .map(|(&i, _)| i)
            .collect();
        let far = slice
            .par_chunks(CLASSIFY_CHUNK)
            .map(|c| farthest_of(&classify_many(scene, sonar, pose, c).0))
            .reduce(|| 0.0, f64::max);
        if far > 0.0 || bottom == f64::NEG_INFINITY {
            return Ok(far);
        }
        (top, width) = (bottom, 2.0 * width);
    }
}

/// The largest range among `members` (0 for none).
fn farthest_of(members: &[Member]) -> f64 {
    members.iter().fold(0.0f64, |a, mb| a.max(mb.range))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::beam::GaussianBeam;
    use crate::sonar::SonarParams;

    /// Detectable and cone lobes, the paper model and physical optics, and an elliptical,
    /// rotated, off-centre emitter with its own receiver.
    fn sonars() -> Vec<Sonar> {
        let mut out = Vec::new();
        for model in [LeafModel::Paper, LeafModel::PhysicalOptics] {
            for cone in [false, true] {
                let mut p = SonarParams::with_beamwidth(40f64.to_radians()).unwrap();
                p.leaf_model = model;
                if cone {
                    p.lobe = LobeRule::Cone {
                        half_angle: 70f64.to_radians(),
                    };
                }
                out.push(Sonar::new(p).unwrap());
            }
        }
        let mut p = SonarParams::with_beamwidth(40f64.to_radians()).unwrap();
        p.emitter = GaussianBeam::new(1.3, 0.4, 0.2, 0.7, 0.3, -0.2).unwrap();
        p.receiver = Some(GaussianBeam::new(0.8, 0.3, 0.5, -0.4, -0.1, 0.1).unwrap());
        out.push(Sonar::new(p).unwrap());
        out
    }

    /// `n` leaves around the origin, 2 cm - 14 m away in every direction (some closer than
    /// the 1 cm `min_range` when `too_close`), random normals, radii 1 - 3 cm.
    fn leaves_around(n: usize, seed: u64, too_close: bool) -> Scene {
        let mut u = crate::test_util::uniforms(seed);
        let (mut c, mut nv, mut r) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..n {
            let (z, ph) = (2.0 * u() - 1.0, 2.0 * PI * u());
            let q = (1.0 - z * z).sqrt();
            let d = [q * ph.cos(), q * ph.sin(), z];
            let range = if too_close && k % 997 == 5 {
                0.004
            } else {
                0.02 + 14.0 * u()
            };
            c.push(d.map(|x| x * range));
            let v = [u() - 0.5, u() - 0.5, u() + 0.1];
            nv.push(v.map(|x| x / dot(v, v).sqrt()));
            r.push(0.01 + 0.02 * u());
        }
        Scene::new(c, nv, r).unwrap()
    }

    /// The bucketed search gives exactly the largest range of `members` (0 for an empty lobe),
    /// and the same too-close error, for every sonar of `sonars()` (the detectable reach cuts
    /// the far buckets' leaves off the beam's axis), poses in and out of the cloud, both lobe
    /// searches.
    #[test]
    fn the_farthest_member_range_is_the_largest_range_of_the_members() {
        let poses = [
            Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
            Pose::new([3.0, -2.0, 1.0], [-0.3, 1.0, 0.2], [0.0, 0.0, 1.0]).unwrap(),
            Pose::new([40.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
        ];
        let (mut counted, mut errors) = (0, 0);
        for too_close in [false, true] {
            let scene = leaves_around(20_000, 21, too_close);
            for mut sonar in sonars() {
                for mode in [TooClose::Skip, TooClose::Error] {
                    sonar.params.too_close = mode;
                    for (i, pose) in poses.iter().enumerate() {
                        for search in [Search::Bvh, Search::BruteForce] {
                            let want = members(&scene, &sonar, pose, i, search)
                                .map(|m| m.iter().fold(0.0f64, |a, mb| a.max(mb.range)));
                            let got = farthest_member_range(&scene, &sonar, pose, i, search);
                            match (want, got) {
                                (Ok(w), Ok(g)) => {
                                    assert_eq!(w.to_bits(), g.to_bits(), "pose {i}");
                                    counted += usize::from(w > 0.0);
                                }
                                (Err(w), Err(g)) => {
                                    assert_eq!(w.to_string(), g.to_string());
                                    errors += 1;
                                }
                                (w, g) => panic!("pose {i}: {w:?} against {g:?}"),
                            }
                        }
                    }
                }
            }
        }
        assert!(counted > 40 && errors > 5, "{counted} {errors}");
    }

    /// The walk's parallel top levels change nothing: the candidates (runs and all) equal
    /// those of one sequential walk, in pools of one and three threads, for every sonar of
    /// `sonars()` and poses inside, beside and outside the cloud.
    #[test]
    fn the_parallel_bvh_walk_gives_the_sequential_walks_candidates() {
        let scene = leaves_around(30_000, 23, false);
        let poses = [
            Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
            Pose::new([3.0, -2.0, 1.0], [-0.3, 1.0, 0.2], [0.0, 0.0, 1.0]).unwrap(),
            Pose::new([40.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
        ];
        let pool = |n| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        };
        let (one, three) = (pool(1), pool(3));
        let mut split = 0;
        for sonar in sonars() {
            for pose in &poses {
                let walk = Walk {
                    scene: &scene,
                    sonar: &sonar,
                    pose,
                    bound: AngularBound::new(&sonar, pose),
                    in_order: true,
                };
                let mut sequential = Candidates::default();
                walk.subtree(0, false, &mut sequential);
                // (split only on a pool thread)
                assert_eq!(
                    three.install(|| bvh_candidates(&scene, &sonar, pose)),
                    sequential
                );
                assert_eq!(
                    one.install(|| bvh_candidates(&scene, &sonar, pose)),
                    sequential
                );
                assert_eq!(bvh_candidates(&scene, &sonar, pose), sequential);
                split += usize::from(matches!(walk.step(0, false), Step::Children(..)));
            }
        }
        assert!(split >= 5, "{split}");
    }

    /// The node test is conservative: a box it calls `Outside` holds no counting point, and
    /// one it calls `Inside` holds only counting points. Boxes of 1 cm - 3 m at directions
    /// within 120 degrees of the beam and ranges 5 cm - 15 m (many on the lobe's edge), for
    /// every sonar of `sonars()`, with and without the angular pre-test; 40 points per box,
    /// its corners among them.
    #[test]
    fn the_node_test_never_contradicts_the_exact_test_of_a_point_in_the_box() {
        let mut u = crate::test_util::uniforms(11);
        let pose = Pose::new([0.3, -0.2, 1.0], [1.0, 0.4, 0.1], [0.0, 0.0, 1.0]).unwrap();
        let (mut outside, mut inside) = (0, 0);
        for sonar in sonars() {
            let bound = AngularBound::new(&sonar, &pose);
            for _ in 0..3000 {
                let (th, ph) = (120f64.to_radians() * u(), 2.0 * PI * u());
                let (st, ct) = th.sin_cos();
                let r = 0.05 * 300f64.powf(u());
                let c: V3 = std::array::from_fn(|i| {
                    pose.position[i]
                        + r * (ct * pose.forward[i]
                            + st * (ph.cos() * pose.left[i] + ph.sin() * pose.up[i]))
                });
                let half: V3 = std::array::from_fn(|_| 0.005 * 300f64.powf(u()));
                let (lo, hi) = (sub(c, half), std::array::from_fn(|i| c[i] + half[i]));
                for b in [bound.as_ref(), None] {
                    let verdict = test_box(&sonar, &pose, b, lo, hi);
                    outside += usize::from(verdict == BoxTest::Outside);
                    inside += usize::from(verdict == BoxTest::Inside);
                    for k in 0..40 {
                        let x: V3 = std::array::from_fn(|i| {
                            let t = if k < 8 { ((k >> i) & 1) as f64 } else { u() };
                            lo[i] + t * (hi[i] - lo[i])
                        });
                        let counts = matches!(classify(&sonar, &pose, x), Decision::In(_));
                        match verdict {
                            BoxTest::Outside => assert!(!counts, "{x:?} counts in {lo:?}..{hi:?}"),
                            BoxTest::Inside => assert!(counts, "{x:?} fails in {lo:?}..{hi:?}"),
                            BoxTest::Partial => {}
                        }
                    }
                }
            }
        }
        // (both verdicts are exercised)
        assert!(
            outside > 1000 && inside > 100,
            "outside {outside}, inside {inside}"
        );
    }

    /// A block of lanes: directions within 100 degrees of `forward`, ranges 5 cm - 12 m
    /// (log-uniform) times `scale`, random unit normals (some exactly edge-on or facing).
    fn block(u: &mut impl FnMut() -> f64, pose: &Pose, scale: f64) -> Gathered {
        let mut g = Gathered::default();
        for k in 0..CB {
            let (th, ph) = (100f64.to_radians() * u(), 2.0 * PI * u());
            let (st, ct) = th.sin_cos();
            let e: V3 = std::array::from_fn(|i| {
                ct * pose.forward[i] + st * (ph.cos() * pose.left[i] + ph.sin() * pose.up[i])
            });
            let r = 0.05 * 240f64.powf(u()) * scale;
            // the offset from a centre, as the gather computes it
            let c: V3 = std::array::from_fn(|i| pose.position[i] + e[i] * r);
            let p = pose.position;
            (g.dx[k], g.dy[k], g.dz[k]) = (c[0] - p[0], c[1] - p[1], c[2] - p[2]);
            g.r[k] = (g.dx[k] * g.dx[k] + g.dy[k] * g.dy[k] + g.dz[k] * g.dz[k]).sqrt();
            let (z, q) = (2.0 * u() - 1.0, 2.0 * PI * u());
            let s = (1.0 - z * z).sqrt();
            let n = match k % 8 {
                0 => pose.up,
                1 => e,
                _ => [s * q.cos(), s * q.sin(), z],
            };
            (g.nx[k], g.ny[k], g.nz[k]) = (n[0], n[1], n[2]);
        }
        g
    }

    #[test]
    fn block_views_match_the_libm_test_to_a_few_ulps() {
        let mut u = crate::test_util::uniforms(5);
        let pose = Pose::new([0.5, -1.0, 2.0], [1.0, 0.3, -0.2], [0.1, 0.0, 1.0]).unwrap();
        let (mut worst_angle, mut worst_gain, mut decided) = (0.0f64, 0.0f64, 0);
        for s in sonars() {
            for _ in 0..400 {
                let g = block(&mut u, &pose, 1.0);
                let v = classify_lanes(&s, &pose, &g, CB);
                for k in 0..CB {
                    if !(g.r[k] >= s.params.min_range && g.r[k] <= s.range_limit) {
                        continue; // (the range test precedes the lanes)
                    }
                    let d = [g.dx[k], g.dy[k], g.dz[k]];
                    // (exact: the offsets are differences of centres near the pose)
                    let centre = std::array::from_fn(|i| pose.position[i] + d[i]);
                    let view = match classify(&s, &pose, centre) {
                        Decision::In(view) => view,
                        _ => {
                            assert_ne!(v.verdict[k], 1, "lane {k} counts; libm says it does not");
                            continue;
                        }
                    };
                    assert_ne!(v.verdict[k], 0, "lane {k} is out; libm says it counts");
                    if v.verdict[k] == 2 {
                        continue;
                    }
                    decided += 1;
                    let (beta, cos_b, sin_b) = incidence(view.dir, [g.nx[k], g.ny[k], g.nz[k]]);
                    for (a, b) in [
                        (v.beta[k], beta),
                        (v.cos_beta[k], cos_b),
                        (v.sin_beta[k], sin_b),
                    ] {
                        worst_angle = worst_angle.max((a - b).abs());
                    }
                    worst_gain = worst_gain.max((v.gain[k] - view.gain).abs() / view.gain);
                }
            }
        }
        assert!(decided > 10_000, "{decided}");
        // (measured: 5.6e-16 and 7.2e-15)
        assert!(
            worst_angle <= 1e-15,
            "beta, cos, sin off by {worst_angle:e}"
        );
        assert!(worst_gain <= 1e-13, "gain off by {worst_gain:e} (relative)");
    }

    #[test]
    fn block_views_do_not_depend_on_the_scale_of_the_offsets() {
        // ranges near 1e-80 or 1e80 m: the product of the four denominators would underflow or
        // overflow, and the block divides them one by one
        let pose = Pose::new([0.0; 3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
        for s in sonars() {
            let mut u = crate::test_util::uniforms(9);
            let one = block(&mut u, &pose, 1.0);
            let v1 = classify_lanes(&s, &pose, &one, CB);
            for scale in [1e-80, 1e80] {
                let mut u = crate::test_util::uniforms(9);
                let v = classify_lanes(&s, &pose, &block(&mut u, &pose, scale), CB);
                for k in 0..CB {
                    assert!(
                        (v.beta[k] - v1.beta[k]).abs() <= 1e-15,
                        "{scale:e} lane {k}"
                    );
                    assert!((v.cos_beta[k] - v1.cos_beta[k]).abs() <= 1e-15);
                    assert!((v.sin_beta[k] - v1.sin_beta[k]).abs() <= 1e-15);
                    assert!((v.gain[k] - v1.gain[k]).abs() <= 1e-14 * v1.gain[k].max(1e-300));
                }
            }
        }
    }
}
