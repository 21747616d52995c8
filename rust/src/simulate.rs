//! Echoes for many poses: the lobe query, the band spectrum and the impulse response of each
//! pose, poses in parallel. Receivers at their own places take [`receivers`]' path; a scene
//! with branches or a sonar that shades takes [`scatter`]'s path per pose; without either, the
//! leaves' path is the paper model's, unchanged.

pub mod many;
pub mod receivers;
pub mod scatter;

use crate::budget;
use crate::echo::impulse::impulse_from_band;
use crate::echo::spectrum::band_spectrum;
use crate::error::{four_digits, invalid, short, Result};
use crate::fast::pulse::fast_pulse;
use crate::fast::FastSonar;
use crate::fast::{band_tightening, fast_band_spectrum, FastPlan};
use crate::interrupt::Interrupt;
use crate::lobe::candidates::Candidates;
use crate::lobe::{candidates, farthest_member_range, members_of, Search};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::Sonar;
use rayon::prelude::*;

/// Echoes of `p` poses: spectra `(p, M)` as separate real and imaginary parts, impulses
/// `(p, n)` (empty when not asked for), and the number of counting leaves per pose; with
/// branches, the wood's share of the spectra `(p, M)` (empty without) and the number of
/// counting branch pieces; with shading, the number of counting leaves it dims or silences.
/// With `R` receivers of their own (`n_receivers = R > 0`), `(p, R, M)`, `(p, R, n)` and
/// `(p, R)`, the wood's share `(p, R, M)`, the counting pieces `(p, R)` and the shaded
/// leaves `(p, R)`.
pub struct Echoes {
    pub n_bins: usize,
    pub n_receivers: usize,
    pub spectrum_re: Vec<f64>,
    pub spectrum_im: Vec<f64>,
    pub impulse: Vec<f64>,
    pub n_leaves: Vec<u64>,
    pub wood_re: Vec<f64>,
    pub wood_im: Vec<f64>,
    pub n_pieces: Vec<u64>,
    pub n_shaded: Vec<u64>,
}

/// The leaf models hold for `k a >= min_ka`; refuse smaller leaves, naming the smallest.
pub fn check_leaf_sizes(scene: &Scene, sonar: &Sonar) -> Result<()> {
    let k_lo = sonar.wavenumbers[0];
    let (i, a) = scene.smallest;
    if k_lo * a < sonar.params.min_ka {
        let i = scene.ids[i];
        return invalid(format!(
            "leaf {i} has radius {a:e} m, so k a = {} at the band's lowest frequency {} Hz, below min_ka = {}; \
             the leaf models are not valid that small (remove such leaves or lower min_ka knowingly)",
            four_digits(k_lo * a),
            short(sonar.freqs[0]),
            short(sonar.params.min_ka)
        ));
    }
    Ok(())
}

/// A pose's echoes must be finite: amplitudes beyond f64's range (an enormous gain, beam
/// amplitude or leaf) are refused, never returned as inf or NaN.
pub(crate) fn check_finite(
    pose: usize,
    re: &[f64],
    im: &[f64],
    y: &[f64],
    sonar: &Sonar,
) -> Result<()> {
    // (no early exit: the fold vectorises, and a pose's arrays are short)
    let finite = |v: &[f64]| v.iter().fold(true, |ok, x| ok & x.is_finite());
    if finite(re) && finite(im) && finite(y) {
        return Ok(());
    }
    let p = &sonar.params;
    invalid(format!(
        "the echoes of pose {pose} overflow f64 (inf or NaN): the amplitude g G / r^2 times the \
         leaf factor is beyond 1.8e308 (gain = {:e}, beam amplitudes {:e} and {:e}, spreading {}); \
         lower the gain or the beam amplitude, or check the leaves' radii",
        p.gain,
        p.emitter.amplitude,
        sonar.receiver().amplitude,
        p.spreading
    ))
}

/// The range (m) of the farthest counting leaf or branch piece of each pose (0 where none
/// counts); poses in parallel. `n_samples = "auto"` takes the record from this.
pub fn farthest_members(
    scene: &Scene,
    sonar: &Sonar,
    poses: &[Pose],
    search: Search,
) -> Result<Vec<f64>> {
    if rayon::current_thread_index().is_none() {
        // (on a pool thread, as `simulate`)
        return rayon::scope(|_| farthest_members(scene, sonar, poses, search));
    }
    if !sonar.params.receivers.is_empty() {
        return receivers::farthest_heard(scene, sonar, poses, search);
    }
    poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            let leaves = farthest_member_range(scene, sonar, pose, i, search)?;
            Ok(leaves.max(scatter::farthest_piece_range(scene, sonar, pose, i)?))
        })
        .collect()
}

/// With `method = auto`, poses with at least this many lobe candidates take the fused fast
/// path ([`fast_pulse`]) without counting their members first.
pub const FUSED_MIN_CANDIDATES: usize = 4096;

/// How the band spectrum is summed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// Every (leaf, bin) term, exact to rounding.
    Exact,
    /// The NUFFT path, relative L2 error of the spectrum at most `tol`.
    Fast { tol: f64 },
    /// Per pose, whichever of the two is cheaper for `tol` (exact when `tol` is below the fast
    /// path's floor).
    Auto { tol: f64 },
}

/// Estimated cost (ns, one core) of summing `n` leaves exactly over `m` bins.
pub fn cost_exact(n: usize, m: usize) -> f64 {
    1.9 * (n * m) as f64
}

/// Estimated cost (ns, one core) of the fast path for `n` leaves.
pub fn cost_fast(n: usize, m: usize, plan: &FastPlan) -> f64 {
    let p = plan.p as f64;
    let w = plan.nufft.w as f64;
    let nf = plan.nufft.nf as f64;
    n as f64 * (40.0 + 3.0 * p + 0.6 * p * w)
        + p * (nf * nf.log2() * 1.5 + 3.0 * nf)
        + 2.0 * p * m as f64
}

/// Echoes of every pose by `method`, poses in parallel; each pose first looks at `stop`, so
/// that a raised interrupt ends the call within about one pose's time.
pub fn simulate(
    scene: &Scene,
    sonar: &FastSonar,
    poses: &[Pose],
    with_impulse: bool,
    search: Search,
    method: Method,
    stop: &Interrupt,
) -> Result<Echoes> {
    if rayon::current_thread_index().is_none() {
        // Called from outside the pool: run on a pool thread. A parallel iterator over one
        // pose runs that pose on the calling thread, where the BVH walk cannot split (see
        // `bvh_candidates`), and the walk is a large part of a pulse.
        return rayon::scope(|_| simulate(scene, sonar, poses, with_impulse, search, method, stop));
    }
    check_leaf_sizes(scene, sonar)?;
    scatter::check_branch_sizes(scene, sonar)?;
    // With leaves and wood, each part's spectrum gets half of `tol` (docs/model.md §9); on a
    // band wider than the fast path's calibration, a tenth or a hundredth of that, and none
    // (the exact sum) on the widest (§6).
    let tightening = match (sonar.freqs.first(), sonar.freqs.last()) {
        (Some(&lo), Some(&hi)) => band_tightening(lo, hi),
        _ => 1.0,
    };
    let share = scatter::tol_share(scene) / tightening;
    // (the tightest working tol the fast sum takes: higher on a wide band)
    let floor = if tightening > 1.0 {
        crate::fast::WIDE_BAND_MIN_TOL
    } else {
        crate::fast::MIN_TOL
    };
    let m = sonar.n_bins();
    let n = sonar.params.n_samples;
    // Each receiver has a pose's arrays of its own: the output is that many records per pose.
    let records = poses
        .len()
        .saturating_mul(sonar.params.receivers.len().max(1));
    budget::check(
        budget::echoes_bytes(records, m, n, with_impulse),
        || {
            let ears = match sonar.params.receivers.len() {
                0 => String::new(),
                r => format!(" for {r} receivers"),
            };
            format!(
                "simulate of {} poses{ears} with n_samples = {n} ({m} band bins{})",
                poses.len(),
                if with_impulse {
                    ", impulses included"
                } else {
                    ""
                }
            )
        },
        "simulate the poses in pieces (poses[i:j]) and join the results",
    )?;
    let plan = match method {
        Method::Exact => None,
        Method::Fast { tol } => {
            crate::fast::check_tol(tol)?;
            if tol * share < floor {
                None // (below the fast method's floor: the exact sum holds tol)
            } else {
                Some(sonar.plans.get(sonar, tol * share)?)
            }
        }
        Method::Auto { tol } => {
            if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
                return invalid(format!("tol must be in (0, 1), got {tol:e}"));
            }
            if tol * share >= floor {
                Some(sonar.plans.get(sonar, tol * share)?)
            } else {
                None
            }
        }
    };
    if !sonar.params.receivers.is_empty() {
        return receivers::simulate_heard(
            scene,
            sonar,
            poses,
            with_impulse,
            (search, method),
            plan,
            stop,
        );
    }
    let plain = scatter::is_plain(scene, sonar);
    let per_pose: Vec<(scatter::PoseEcho, Vec<f64>)> = poses
        .par_iter()
        .enumerate()
        .map(|(i, pose)| {
            stop.check()?;
            let cands = candidates(scene, sonar, pose, search);
            let echo = if plain {
                let (re, im, count) =
                    leaf_pose(scene, sonar, plan.as_deref(), method, pose, i, &cands)?;
                scatter::PoseEcho::of_leaves(re, im, count)
            } else {
                scatter::pose_echo(scene, sonar, plan.as_deref(), method, pose, i, &cands)?
            };
            let mut y = Vec::new();
            if with_impulse {
                y = budget::filled(n, 0.0, "the impulse response")?;
                impulse_from_band(n, sonar.k0, &echo.re, &echo.im, &mut y);
            }
            check_finite(i, &echo.re, &echo.im, &y, sonar)?;
            Ok((echo, y))
        })
        .collect::<Result<Vec<_>>>()?;
    let what = "simulate's output";
    let p = poses.len();
    let wood = !scene.branches.is_empty();
    let mut out = Echoes {
        n_bins: m,
        n_receivers: 0,
        spectrum_re: budget::with_capacity(p.saturating_mul(m), what)?,
        spectrum_im: budget::with_capacity(p.saturating_mul(m), what)?,
        impulse: budget::with_capacity(if with_impulse { p.saturating_mul(n) } else { 0 }, what)?,
        n_leaves: budget::with_capacity(p, what)?,
        wood_re: budget::with_capacity(if wood { p.saturating_mul(m) } else { 0 }, what)?,
        wood_im: budget::with_capacity(if wood { p.saturating_mul(m) } else { 0 }, what)?,
        n_pieces: budget::with_capacity(p, what)?,
        n_shaded: budget::with_capacity(p, what)?,
    };
    for (e, y) in per_pose {
        out.spectrum_re.extend_from_slice(&e.re);
        out.spectrum_im.extend_from_slice(&e.im);
        out.impulse.extend_from_slice(&y);
        out.n_leaves.push(e.n_leaves);
        if wood {
            out.wood_re.extend_from_slice(&e.wood_re);
            out.wood_im.extend_from_slice(&e.wood_im);
        }
        out.n_pieces.push(e.n_pieces);
        out.n_shaded.push(e.n_shaded);
    }
    Ok(out)
}

/// The plan of the fused fast path ([`fast_pulse`]) where a pose takes it: many candidates
/// (for `auto` too: with this many its fixed cost is small against either method's per-leaf
/// work). Otherwise (None) the members come first, then the cheaper method for their number.
pub(crate) fn fused_plan<'a>(
    plan: Option<&'a FastPlan>,
    method: Method,
    cands: &Candidates,
) -> Option<&'a FastPlan> {
    match (plan, method) {
        (Some(pl), Method::Fast { .. }) => Some(pl),
        (Some(pl), Method::Auto { .. }) if cands.len() >= FUSED_MIN_CANDIDATES => Some(pl),
        _ => None,
    }
}

/// The windowed band spectrum of one pose's counting leaves and their number, as the paper
/// model sums them: by the fused fast path when there are many candidates (or the method is
/// fast), else from the members by the cheaper method for their number.
pub(crate) fn leaf_pose(
    scene: &Scene,
    sonar: &FastSonar,
    plan: Option<&FastPlan>,
    method: Method,
    pose: &Pose,
    i: usize,
    cands: &Candidates,
) -> Result<(Vec<f64>, Vec<f64>, u64)> {
    let m = sonar.n_bins();
    if let Some(pl) = fused_plan(plan, method, cands) {
        return fast_pulse(scene, sonar, pl, pose, i, cands);
    }
    let mem = members_of(scene, sonar, pose, i, cands.to_vec())?;
    let (re, im) = match plan {
        Some(pl) if cost_fast(mem.len(), m, pl) < cost_exact(mem.len(), m) => {
            fast_band_spectrum(sonar, pl, scene, &mem)
        }
        _ => band_spectrum(sonar, scene, &mem),
    };
    Ok((re, im, mem.len() as u64))
}
