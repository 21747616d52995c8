//! One pose's echo from a scene with branches or a sonar that shades (docs/model.md §9-§10):
//! the counting leaves and branch pieces, each one's shading factor from the ray cast to it,
//! and the leaves' and the wood's band spectra by the chosen method, added.
//!
//! Without shading the leaves go the paper model's way ([`leaf_pose`]) and the wood is
//! added. With shading, the members' terms are scaled by their factors and summed from the
//! list; where no factor differs from 1 the leaves go the paper model's way too, so that a
//! transmission of 1 with no branch in the way gives the unshaded echo bit for bit.
use super::{cost_exact, cost_fast, fused_plan, leaf_pose, Method};
use crate::echo::{branch_term, leaf_term, sum_branch_terms, sum_terms, BranchTerm, LeafTerm};
use crate::error::{four_digits, invalid, short, Result};
use crate::fast::pulse::shaded_pulse;
use crate::fast::{fast_branch_spectrum, fast_sum_terms, FastPlan, FastSonar, MIN_TOL};
use crate::lobe::candidates::Candidates;
use crate::lobe::{branch_members, members_of, ranged_positions, PieceMember};
use crate::physics::pose::Pose;
use crate::physics::shading::ShadingFactors;
use crate::scene::Scene;
use crate::shade::{cast, Target};
use crate::sonar::Sonar;
use rayon::prelude::*;

/// One pose's echo: the windowed band spectrum, the wood's share of it (empty without
/// branches), and the numbers of counting leaves, counting branch pieces, and counting leaves
/// that shading dims or silences.
pub struct PoseEcho {
    pub re: Vec<f64>,
    pub im: Vec<f64>,
    pub wood_re: Vec<f64>,
    pub wood_im: Vec<f64>,
    pub n_leaves: u64,
    pub n_pieces: u64,
    pub n_shaded: u64,
}

impl PoseEcho {
    /// The echo of leaves alone, unshaded.
    pub fn of_leaves(re: Vec<f64>, im: Vec<f64>, n_leaves: u64) -> PoseEcho {
        PoseEcho {
            re,
            im,
            wood_re: Vec::new(),
            wood_im: Vec::new(),
            n_leaves,
            n_pieces: 0,
            n_shaded: 0,
        }
    }
}

/// True when the scene has no branches and the sonar does not shade: the paper model's path.
pub fn is_plain(scene: &Scene, sonar: &Sonar) -> bool {
    scene.branches.is_empty() && sonar.params.shading.is_none()
}

/// The share of `tol` each part's spectrum gets: a half each with leaves and wood (so that the
/// sum's error stays within `tol` of the parts' norms' mean), else all of it.
pub fn tol_share(scene: &Scene) -> f64 {
    if !scene.branches.is_empty() && !scene.is_empty() {
        0.5
    } else {
        1.0
    }
}

/// Branches as thin as the leaves' `min_ka` are refused, naming the thinnest: physical optics
/// needs `k a` well above 1 round a cylinder too.
pub fn check_branch_sizes(scene: &Scene, sonar: &Sonar) -> Result<()> {
    let br = &scene.branches;
    if br.is_empty() {
        return Ok(());
    }
    let k_lo = sonar.wavenumbers[0];
    let (i, a) = br.smallest;
    if k_lo * a < sonar.params.min_ka {
        return invalid(format!(
            "branch {i} has radius {a:e} m, so k a = {} at the band's lowest frequency {} Hz, below min_ka = {}; \
             the cylinder model is not valid that thin (leave such twigs out of the branches or lower min_ka knowingly)",
            four_digits(k_lo * a),
            short(sonar.freqs[0]),
            short(sonar.params.min_ka)
        ));
    }
    Ok(())
}

/// The range (m) of the farthest counting branch piece of one pose (0 where none counts).
pub fn farthest_piece_range(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    pose_index: usize,
) -> Result<f64> {
    let pieces = branch_members(scene, sonar, pose, pose_index)?;
    Ok(pieces.iter().fold(0.0f64, |a, p| a.max(p.range)))
}

/// The windowed spectrum of leaf terms by the cheaper method for their number.
fn leaf_terms_spectrum(
    sonar: &FastSonar,
    plan: Option<&FastPlan>,
    terms: &[LeafTerm],
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    match plan {
        Some(pl) if cost_fast(terms.len(), m, pl) < cost_exact(terms.len(), m) => {
            fast_sum_terms(sonar, pl, terms)
        }
        _ => sum_terms(sonar, terms),
    }
}

/// The margin by which the wood's fast spectrum must clear its tolerance (see
/// [`wood_spectrum`]).
const WOOD_TOL_MARGIN: f64 = 4.0;

/// The wood's first fast sum is taken at its tolerance divided by this (see
/// [`wood_spectrum`]): the pieces of a segment cancel at their shared edges, commonly to a
/// half or a third of the root sum of squares of their sizes, which a tenth of the tolerance
/// clears with [`WOOD_TOL_MARGIN`], so that one sum is enough.
const WOOD_FIRST_TIGHTENING: f64 = 10.0;

/// An upper bound on the size of a piece's echo over the band (its largest factor times its
/// amplitude times the square root of the bin count): the scale of its error in the fast sum.
fn piece_size(sonar: &Sonar, t: &BranchTerm) -> f64 {
    let k = &sonar.wavenumbers;
    let (k_lo, k_hi) = (k[0], k[k.len() - 1]);
    let c0 = 0.5 * t.length * (t.radius * t.cos_gamma * t.k_scale / std::f64::consts::PI).sqrt();
    let kx = k_lo * t.length * t.sin_gamma * t.k_scale;
    let sinc_bound = if kx > 1.0 { 1.0 / kx } else { 1.0 };
    t.amp * c0 * k_hi.sqrt() * sinc_bound * (k.len() as f64).sqrt()
}

/// The norm of a spectrum.
fn norm(re: &[f64], im: &[f64]) -> f64 {
    re.iter()
        .zip(im)
        .map(|(a, b)| a * a + b * b)
        .sum::<f64>()
        .sqrt()
}

/// The fast plan at tolerance `tol`, if it is within the fast method's floor and cheaper than
/// the exact sum of `points` echo points.
fn cheaper_plan(sonar: &FastSonar, tol: f64, points: usize) -> Option<std::sync::Arc<FastPlan>> {
    let m = sonar.n_bins();
    if tol < MIN_TOL {
        return None;
    }
    let pl = sonar.plans.get(sonar, tol).ok()?;
    (cost_fast(points, m, &pl) < cost_exact(points, m)).then_some(pl)
}

/// The windowed spectrum of branch terms by the cheaper method for their number of echo
/// points (one or two a piece, each costing about what a smooth leaf does).
///
/// The fast method at tolerance `t` keeps each point's error within `t` of that point's size,
/// and the errors add about as a root sum of squares (`rss`, of the pieces' sizes). The pieces
/// of one segment cancel (their shared edges), so the wood's sum may be far smaller than its
/// pieces: a fast sum at `t` is kept only where `WOOD_TOL_MARGIN t rss` is within the plan's
/// `tol` times the sum's norm. The first sum is taken at `tol /` [`WOOD_FIRST_TIGHTENING`];
/// where it is not kept, the sum is redone with the tolerance tightened by the ratio
/// (rounded down to a power of ten, so that few plans are built), or exactly where that falls
/// below the fast method's floor or costs more.
pub(crate) fn wood_spectrum(
    sonar: &FastSonar,
    plan: Option<&FastPlan>,
    terms: &[BranchTerm],
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let points = 2 * terms.len();
    let tol = match plan {
        Some(pl) if cost_fast(points, m, pl) < cost_exact(points, m) => pl.tol,
        _ => return sum_branch_terms(sonar, terms),
    };
    let rss = terms
        .iter()
        .map(|t| piece_size(sonar, t).powi(2))
        .sum::<f64>()
        .sqrt();
    let Some(first) = cheaper_plan(sonar, tol / WOOD_FIRST_TIGHTENING, points) else {
        return sum_branch_terms(sonar, terms);
    };
    let (re, im) = fast_branch_spectrum(sonar, &first, terms);
    let norm = norm(&re, &im);
    if WOOD_TOL_MARGIN * first.tol * rss <= tol * norm {
        return (re, im);
    }
    let tight = tol * norm / (WOOD_TOL_MARGIN * rss);
    let tight = 10f64.powf(tight.log10().floor());
    match cheaper_plan(sonar, tight, points) {
        Some(tp) if tp.tol < first.tol => fast_branch_spectrum(sonar, &tp, terms),
        _ => sum_branch_terms(sonar, terms),
    }
}

/// The shading of every counting leaf and piece of one pose: their factors in the members'
/// order, then the pieces'.
fn shading_factors(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    leaves: &[u32],
    pieces: &[PieceMember],
) -> Vec<f64> {
    let Some(sh) = sonar.params.shading else {
        return vec![1.0; leaves.len() + pieces.len()];
    };
    // (in parallel; the collected lists keep their order)
    let targets: Vec<Target> = leaves
        .par_iter()
        .map(|&i| Target::Leaf {
            point: scene.centers.get(i as usize),
            leaf: i,
        })
        .chain(pieces.par_iter().map(|p| Target::Piece {
            point: p.reference,
            segment: p.segment,
        }))
        .collect();
    let factors = ShadingFactors::new(sh.leaf_transmission);
    cast(scene, pose.position, &targets, sh.branches_block)
        .par_iter()
        .map(|s| factors.get(s.crossings, s.blocked))
        .collect()
}

/// One pose's echo (see the module's comment). `plan` is that of each part's share of `tol`
/// ([`tol_share`]); `pose_index` only labels errors.
pub fn pose_echo(
    scene: &Scene,
    sonar: &FastSonar,
    plan: Option<&FastPlan>,
    method: Method,
    pose: &Pose,
    pose_index: usize,
    cands: &Candidates,
) -> Result<PoseEcho> {
    let pieces = branch_members(scene, sonar, pose, pose_index)?;
    let mut wood: Vec<BranchTerm> = pieces.iter().map(|p| branch_term(sonar, p)).collect();
    let (re, im, n_leaves, n_shaded) = if sonar.params.shading.is_none() {
        let (re, im, n) = leaf_pose(scene, sonar, plan, method, pose, pose_index, cands)?;
        (re, im, n, 0)
    } else {
        if let Some(pl) = fused_plan(plan, method, cands) {
            return shaded_fused(scene, sonar, pl, pose, pose_index, cands, pieces, wood);
        }
        let mem = members_of(scene, sonar, pose, pose_index, cands.to_vec())?;
        let ids: Vec<u32> = mem.iter().map(|mb| mb.index).collect();
        let factors = shading_factors(scene, sonar, pose, &ids, &pieces);
        let (leaf_f, wood_f) = factors.split_at(mem.len());
        for (t, &f) in wood.iter_mut().zip(wood_f) {
            t.amp *= f;
        }
        wood.retain(|t| t.amp != 0.0);
        let n_shaded = leaf_f.iter().filter(|&&f| f != 1.0).count() as u64;
        if n_shaded == 0 {
            let (re, im, n) = leaf_pose(scene, sonar, plan, method, pose, pose_index, cands)?;
            (re, im, n, 0)
        } else {
            // (in parallel; the collected list keeps the members' order)
            let terms: Vec<LeafTerm> = mem
                .par_iter()
                .zip(leaf_f.par_iter())
                .filter(|(_, &f)| f != 0.0)
                .map(|(mb, &f)| {
                    let mut t = leaf_term(sonar, scene, mb);
                    t.amp *= f;
                    t
                })
                .collect();
            let (re, im) = leaf_terms_spectrum(sonar, plan, &terms);
            (re, im, mem.len() as u64, n_shaded)
        }
    };
    let echo = PoseEcho {
        n_pieces: pieces.len() as u64,
        n_shaded,
        ..PoseEcho::of_leaves(re, im, n_leaves)
    };
    Ok(with_wood(scene, sonar, plan, echo, &wood))
}

/// The leaves' echo shaded by the fused fast path: the rays cast to the candidates within the
/// sonar's ranges (every counting leaf among them, found without the lobe test, which the
/// pulse makes) and to the pieces, then the fused pulse with each leaf's factor, which counts
/// the leaves shaded; where no factor differs from 1, the unshaded fused pulse (the same
/// bits).
#[allow(clippy::too_many_arguments)]
fn shaded_fused(
    scene: &Scene,
    sonar: &FastSonar,
    plan: &FastPlan,
    pose: &Pose,
    pose_index: usize,
    cands: &Candidates,
    pieces: Vec<PieceMember>,
    mut wood: Vec<BranchTerm>,
) -> Result<PoseEcho> {
    let (positions, ids) = ranged_positions(scene, sonar, pose, cands);
    let factors = shading_factors(scene, sonar, pose, &ids, &pieces);
    let (leaf_f, wood_f) = factors.split_at(ids.len());
    for (t, &f) in wood.iter_mut().zip(wood_f) {
        t.amp *= f;
    }
    wood.retain(|t| t.amp != 0.0);
    let any_shaded = leaf_f.par_iter().any(|&f| f != 1.0);
    let by_position = any_shaded.then(|| by_position(cands.len(), &positions, leaf_f));
    let pulse = shaded_pulse(
        scene,
        sonar,
        plan,
        pose,
        pose_index,
        cands,
        by_position.as_deref(),
    )?;
    let echo = PoseEcho {
        n_pieces: pieces.len() as u64,
        n_shaded: pulse.n_shaded,
        ..PoseEcho::of_leaves(pulse.re, pulse.im, pulse.n_leaves)
    };
    Ok(with_wood(scene, sonar, Some(plan), echo, &wood))
}

/// The factors `f` of the leaves at the ascending `positions` among `n` candidates, as a
/// factor per candidate (1 for those not listed), filled in parallel by spans of candidates.
fn by_position(n: usize, positions: &[u32], f: &[f64]) -> Vec<f64> {
    const SPAN: usize = 16384;
    let mut out = vec![1.0; n];
    out.par_chunks_mut(SPAN).enumerate().for_each(|(c, span)| {
        let lo = positions.partition_point(|&p| (p as usize) < c * SPAN);
        let hi = positions.partition_point(|&p| (p as usize) < c * SPAN + span.len());
        for (&p, &x) in positions[lo..hi].iter().zip(&f[lo..hi]) {
            span[p as usize - c * SPAN] = x;
        }
    });
    out
}

/// `echo` with the wood's spectrum `wood` added and kept apart (nothing without branches).
fn with_wood(
    scene: &Scene,
    sonar: &FastSonar,
    plan: Option<&FastPlan>,
    mut echo: PoseEcho,
    wood: &[BranchTerm],
) -> PoseEcho {
    let m = sonar.n_bins();
    if !scene.branches.is_empty() {
        let (wr, wi) = if wood.is_empty() {
            (vec![0.0; m], vec![0.0; m])
        } else {
            wood_spectrum(sonar, plan, wood)
        };
        for j in 0..m {
            echo.re[j] += wr[j];
            echo.im[j] += wi[j];
        }
        (echo.wood_re, echo.wood_im) = (wr, wi);
    }
    echo
}
