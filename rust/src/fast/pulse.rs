//! One pulse by the fast method, fused with the lobe query: the candidates of the BVH go
//! through the exact lobe test, the leaf terms and the NUFFT spreading block by block, so that
//! no list of members or terms is ever materialised (at 1e6 leaves those lists cost more than
//! the spreading itself).
//!
//! Determinism: the candidates come in the BVH's traversal order (sequential, so the same for
//! any thread count) and are cut into chunks whose length depends only on their number; each
//! chunk spreads into its own grid and the grids are added in chunk order. Leaves the first
//! pass cannot represent (failing the smoothness check at the chosen node count, or outside
//! the paper model's domain) are kept as terms, in chunk order, for
//! [`crate::fast::leftover_pass`]: kinked ones by sub-bands, the other failures by a second
//! pass at the plan's full node count, the rest by the exact sum.
//! The set of counting leaves is exactly that of [`crate::lobe::members()`]: the same per-leaf
//! test ([`crate::lobe::classify_candidates`]).

use crate::echo::term::{leaf_amp, leaf_term, LeafTerm};
use crate::echo::{paper_regime, paper_regime_of};
use crate::error::Result;
use crate::fast::subband::KinkedLeaf;
use crate::fast::FastSonar;
use crate::fast::{
    beside_leftovers, choose_nodes_from, chunk_len, finish_grids, leftover_pass, paper_batch,
    paper_route, po_leaf, take_grid, BatchScratch, Direct, FastPlan, PaperLanes, PaperRoute,
    ADAPT_MIN_LEAVES, LB, NOT_KINKED,
};
use crate::lobe::candidates::Candidates;
use crate::lobe::{classify_candidates, classify_member, refuse_too_close, BlockView};
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::LeafModel;
use multiversion::multiversion;
use rayon::prelude::*;

/// Candidates sampled to choose the node count (it uses at most 128 smooth members): runs of
/// [`SAMPLE_RUN`] consecutive candidates, spread evenly over the list.
const SAMPLE: usize = 256;
/// Candidates per run of the sample. Single candidates at a stride of thousands each miss the
/// caches, before the pulse's tasks can start (prefetching them does not help); runs of
/// consecutive candidates share their cache lines.
const SAMPLE_RUN: usize = 16;

/// One chunk's share.
struct Part {
    grid: Vec<f64>,
    direct: Direct,
    /// Leaves that failed the smoothness check (see [`crate::fast::leftover_pass`]), kinked
    /// paper-model ones apart.
    deferred: Vec<LeafTerm>,
    kinked: Vec<KinkedLeaf>,
    /// Leaves routed to the exact sum (outside the paper model's domain).
    exact: Vec<LeafTerm>,
    count: u64,
    /// Counting leaves whose factor is not 1.
    shaded: u64,
    too_close: Option<(usize, f64)>,
}

/// Lobe test, terms and spreading for the candidates at positions `span`.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn pulse_chunk(
    scene: &Scene,
    sonar: &FastSonar,
    pose: &Pose,
    plan: &FastPlan,
    cands: &Candidates,
    factors: Option<&[f64]>,
    span: std::ops::Range<usize>,
) -> Part {
    let (p, glen) = (plan.p, plan.nufft.grid_len());
    let mut part = Part {
        grid: take_grid(2 * p * glen),
        direct: Direct::new(sonar.n_bins()),
        deferred: Vec::new(),
        kinked: Vec::new(),
        exact: Vec::new(),
        count: 0,
        shaded: 0,
        too_close: None,
    };
    let sp = &sonar.params;
    let paper = sp.leaf_model == LeafModel::Paper;
    let atten = !plan.nodes.atten.is_empty();
    let mut lanes = PaperLanes::new();
    let mut s = BatchScratch::new();
    let mut flush = |lanes: &mut PaperLanes, part: &mut Part| {
        if lanes.n == 0 {
            return;
        }
        lanes.pad();
        let (grid, direct) = (&mut part.grid, &mut part.direct);
        let failed = if atten {
            paper_batch::<true>(sonar, plan, lanes, grid, direct, &mut s)
        } else {
            paper_batch::<false>(sonar, plan, lanes, grid, direct, &mut s)
        };
        for i in 0..lanes.n {
            if failed.defer[i] {
                match lanes.kinked_leaf(sonar, plan, i) {
                    Some(kl) => part.kinked.push(kl),
                    None => part.deferred.push(lanes.term(i)),
                }
            } else if failed.exact[i] {
                part.exact.push(lanes.term(i));
            }
        }
        lanes.n = 0;
    };
    let mut pos = span.start;
    let mut blocks = cands.blocks(span);
    let mut v = BlockView::default();
    while let Some((block, consecutive)) = blocks.next_block() {
        let at = pos;
        pos += block.len();
        // lane k's shading factor (1 unshaded)
        let factor = |k: usize| factors.map_or(1.0, |f| f[at + k]);
        let range = classify_candidates(
            scene,
            sonar,
            pose,
            block,
            consecutive,
            &mut part.too_close,
            &mut v,
        );
        if !paper {
            for (k, &i) in block.iter().enumerate() {
                let Some(mb) = v.member(k, i, range[k], scene, sonar, pose) else {
                    continue;
                };
                part.count += 1;
                part.shaded += u64::from(factor(k) != 1.0);
                let mut t = leaf_term(sonar, scene, &mb);
                t.amp *= factor(k);
                if !po_leaf(sonar, plan, &t, &mut part.grid) {
                    part.deferred.push(t);
                }
            }
            continue;
        }
        // The block's lanes as paper-model terms (as `leaf_term` computes them).
        let nb = block.len();
        let leaf = |k: usize| block[k.min(nb - 1)] as usize;
        let mut bl = PaperLanes {
            n: nb,
            amp: std::array::from_fn(|k| {
                leaf_amp(sonar, v.gain[k], range[k]) * factor(k.min(nb - 1))
            }),
            range,
            beta: v.beta,
            a: std::array::from_fn(|k| scene.radii[leaf(k)]),
            ap: std::array::from_fn(|k| scene.radius_pow_b[leaf(k)]),
            aq: std::array::from_fn(|k| scene.radius_pow_p[leaf(k)]),
            kink: [NOT_KINKED; LB],
            floor: [0.0; LB],
            skip: [false; LB],
        };
        // A block is a batch as it stands where it can be (`ready_whole`); otherwise each
        // counting leaf goes its route.
        // (loops, not `map`: the generic `map` can be an out-of-line call, compiled for
        // baseline x86-64)
        let (mut out, mut inside) = ([false; LB], [false; LB]);
        for k in 0..LB {
            out[k] = v.verdict[k] == 0;
            inside[k] = v.verdict[k] == 1;
        }
        if bl.ready_whole(sonar, &out, &inside) {
            part.count += inside.iter().map(|&x| u64::from(x)).sum::<u64>();
            if factors.is_some() {
                part.shaded += (0..nb)
                    .map(|k| u64::from(inside[k] && factor(k) != 1.0))
                    .sum::<u64>();
            }
            flush(&mut bl, &mut part);
            continue;
        }
        for (k, &i) in block.iter().enumerate() {
            let route = match v.verdict[k] {
                0 => continue,
                1 => {
                    let regime = paper_regime_of(&sonar.tables, bl.ap[k], bl.beta[k]);
                    paper_route(sonar, regime, bl.ap[k], bl.beta[k])
                }
                _ => {
                    // on the lobe's boundary: the libm decision
                    let Some(mb) = classify_member(scene, sonar, pose, i) else {
                        continue;
                    };
                    let t = leaf_term(sonar, scene, &mb);
                    (bl.amp[k], bl.range[k], bl.beta[k]) = (t.amp * factor(k), t.range, t.beta);
                    paper_route(
                        sonar,
                        paper_regime(&sonar.tables, &t),
                        t.radius_pow_b,
                        t.beta,
                    )
                }
            };
            part.count += 1;
            part.shaded += u64::from(factor(k) != 1.0);
            match route {
                PaperRoute::Skip => {}
                PaperRoute::Defer => part.exact.push(bl.term(k)),
                PaperRoute::Batch(kink) => {
                    lanes.push_lane(&bl, k, kink);
                    if lanes.n == LB {
                        flush(&mut lanes, &mut part);
                    }
                }
            }
        }
    }
    flush(&mut lanes, &mut part);
    part
}

/// The terms of the counting leaves among `cands` (the lobe test of [`pulse_chunk`], block by
/// block).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn sample_terms(scene: &Scene, sonar: &FastSonar, pose: &Pose, cands: &[u32]) -> Vec<LeafTerm> {
    let mut out = Vec::with_capacity(cands.len());
    let mut too_close = None; // (reported by the pass itself)
    let mut v = BlockView::default();
    for block in cands.chunks(crate::lobe::CB) {
        let range = classify_candidates(scene, sonar, pose, block, false, &mut too_close, &mut v);
        for (k, &i) in block.iter().enumerate() {
            if let Some(mb) = v.member(k, i, range[k], scene, sonar, pose) {
                out.push(leaf_term(sonar, scene, &mb));
            }
        }
    }
    out
}

/// One pose's fast pulse: the windowed band spectrum, the number of counting leaves, and the
/// number of those whose factor is not 1.
pub struct Pulse {
    pub re: Vec<f64>,
    pub im: Vec<f64>,
    pub n_leaves: u64,
    pub n_shaded: u64,
}

/// The windowed band spectrum `(re, im)` of one pose by the fast method, and its number of
/// counting leaves ([`shaded_pulse`] without factors). `pose_index` only labels errors.
pub fn fast_pulse(
    scene: &Scene,
    sonar: &FastSonar,
    plan: &FastPlan,
    pose: &Pose,
    pose_index: usize,
    cands: &Candidates,
) -> Result<(Vec<f64>, Vec<f64>, u64)> {
    let p = shaded_pulse(scene, sonar, plan, pose, pose_index, cands, None)?;
    Ok((p.re, p.im, p.n_leaves))
}

/// One pose's [`Pulse`] by the fast method. `factors`, by candidate position, scale the
/// counting leaves' amplitudes (shading's factors, docs/model.md §10; a leaf of factor 0
/// counts and adds nothing; the factors of candidates that do not count are not read for
/// the echo). `pose_index` only labels errors.
pub fn shaded_pulse(
    scene: &Scene,
    sonar: &FastSonar,
    plan: &FastPlan,
    pose: &Pose,
    pose_index: usize,
    cands: &Candidates,
    factors: Option<&[f64]>,
) -> Result<Pulse> {
    if rayon::current_thread_index().is_none() {
        // Called from outside the pool: run the pulse on a pool thread, so that its parallel
        // steps follow one another there (from outside, each step is injected into the pool
        // and this thread sleeps and wakes in between).
        return rayon::scope(|_| {
            shaded_pulse(scene, sonar, plan, pose, pose_index, cands, factors)
        });
    }
    // The node count, from a sample of the counting leaves (see `fast::choose_nodes`).
    let small_plan;
    let first: &FastPlan =
        if cands.len() >= ADAPT_MIN_LEAVES && sonar.params.leaf_model == LeafModel::Paper {
            // (the runs' j-th candidates side by side, so that the first members the choice
            // takes come from the whole list)
            let runs = SAMPLE / SAMPLE_RUN;
            let gap = cands.len() / runs;
            let picked: Vec<u32> = (0..SAMPLE_RUN)
                .flat_map(|j| (0..runs).map(move |r| r * gap + j))
                .map(|pos| cands.get(pos))
                .collect();
            let sample = sample_terms(scene, sonar, pose, &picked);
            let refs: Vec<&LeafTerm> = sample.iter().collect();
            let p = choose_nodes_from(sonar, plan, &refs);
            if p < plan.p {
                small_plan = sonar.plans.get_with_nodes(sonar, plan.tol, p)?;
                &small_plan
            } else {
                plan
            }
        } else {
            plan
        };
    let n = cands.len();
    let cl = chunk_len(n, first.nufft.nf);
    let parts: Vec<Part> = (0..n.div_ceil(cl))
        .into_par_iter()
        .map(|c| {
            pulse_chunk(
                scene,
                sonar,
                pose,
                first,
                cands,
                factors,
                c * cl..n.min((c + 1) * cl),
            )
        })
        .collect();
    refuse_too_close(sonar, pose_index, parts.iter().filter_map(|p| p.too_close))?;
    let m = sonar.n_bins();
    if parts.is_empty() {
        return Ok(Pulse {
            re: vec![0.0; m],
            im: vec![0.0; m],
            n_leaves: 0,
            n_shaded: 0,
        });
    }
    // The chunks' grids and direct sums for the first pass's transforms, their leftover
    // leaves (in chunk order) for the later passes, and the count.
    let count = parts.iter().map(|p| p.count).sum();
    let n_shaded = parts.iter().map(|p| p.shaded).sum();
    let mut grids = Vec::with_capacity(parts.len());
    let mut directs = Vec::with_capacity(parts.len());
    let mut left_over = Vec::with_capacity(parts.len());
    for part in parts {
        grids.push(part.grid);
        directs.push(part.direct);
        left_over.push((part.deferred, part.kinked, part.exact));
    }
    // The leaves the first pass left run beside the sum of the chunks' grids and the first
    // pass's transforms (each parallel inside); each side gathers its own inputs.
    let (re, im) = beside_leftovers(
        || {
            let (mut deferred, mut kinked, mut exact) = (Vec::new(), Vec::new(), Vec::new());
            for (d, k, e) in &left_over {
                deferred.extend_from_slice(d);
                kinked.extend_from_slice(k);
                exact.extend_from_slice(e);
            }
            leftover_pass(sonar, plan, &deferred, &kinked, &exact, None)
        },
        || {
            let mut directs = directs.into_iter();
            let mut direct = directs.next().expect("one part at least");
            for d in directs {
                direct.add(&d);
            }
            finish_grids(sonar, first, grids, (direct.re, direct.im))
        },
    );
    Ok(Pulse {
        re,
        im,
        n_leaves: count,
        n_shaded,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::echo::spectrum::band_spectrum;
    use crate::lobe::{candidates, Search};
    use crate::sonar::{LobeRule, Sonar, SonarParams};
    use crate::test_util::rel_l2;

    /// `n` leaves in a box in front of the origin: radii 0.5 mm - 5 cm, random normals.
    fn scene(n: usize, seed: u64) -> Scene {
        let mut u = crate::test_util::uniforms(seed);
        let mut c = Vec::with_capacity(n);
        let mut nv = Vec::with_capacity(n);
        let mut r = Vec::with_capacity(n);
        for _ in 0..n {
            c.push([0.3 + 9.0 * u(), -3.0 + 6.0 * u(), -3.0 + 6.0 * u()]);
            let (z, ph) = (2.0 * u() - 1.0, 2.0 * std::f64::consts::PI * u());
            let q = (1.0 - z * z).sqrt();
            nv.push([q * ph.cos(), q * ph.sin(), z]);
            r.push(0.0005 * 100f64.powf(u()));
        }
        Scene::new(c, nv, r).unwrap()
    }

    fn sonars() -> Vec<FastSonar> {
        let mut out = Vec::new();
        for lobe in [
            None,
            Some(LobeRule::Cone {
                half_angle: 60f64.to_radians(),
            }),
        ] {
            for model in [LeafModel::Paper, LeafModel::PhysicalOptics] {
                let mut p = SonarParams::with_beamwidth(40f64.to_radians()).unwrap();
                p.min_ka = 0.01;
                p.leaf_model = model;
                if let Some(l) = lobe {
                    p.lobe = l;
                }
                out.push(FastSonar::new(Sonar::new(p).unwrap()));
            }
        }
        out
    }

    #[test]
    fn fused_pulse_is_within_tol_of_the_exact_sum_and_counts_the_members() {
        let sc = scene(20_000, 3);
        let pose = Pose::new([0.0, 0.1, -0.2], [1.0, 0.05, 0.0], [0.0, 0.0, 1.0]).unwrap();
        for s in sonars() {
            let mem = crate::lobe::members(&sc, &s, &pose, 0, Search::Bvh).unwrap();
            assert!(mem.len() > 2000, "{}", mem.len());
            let (er, ei) = band_spectrum(&s, &sc, &mem);
            let cands = candidates(&sc, &s, &pose, Search::Bvh);
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                let plan = FastPlan::new(&s, tol).unwrap();
                let (re, im, n) = fast_pulse(&sc, &s, &plan, &pose, 0, &cands).unwrap();
                assert_eq!(n as usize, mem.len());
                let err = rel_l2((&re, &im), (&er, &ei));
                assert!(err <= tol, "{:?} tol {tol:e}: {err:e}", s.params.leaf_model);
            }
        }
    }

    #[test]
    fn whole_blocks_of_kinked_leaves_and_leaves_past_the_record_are_within_tol() {
        // Every leaf within the record is kinked in the band (2 cm, incidence 1.541 rad); one
        // in eight lies past the record's end, in the cone (out, with a nonzero beam gain):
        // whole blocks mix both.
        let mut u = crate::test_util::uniforms(17);
        let (mut c, mut nv) = (Vec::new(), Vec::new());
        for k in 0..40_000 {
            let x = [1.0 + 8.0 * u(), -2.0 + 4.0 * u(), -2.0 + 4.0 * u()];
            let x = if k % 8 == 0 {
                [x[0] + 12.0, x[1], x[2]]
            } else {
                x
            };
            let r = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt();
            let e = [x[0] / r, x[1] / r, x[2] / r];
            let t = crate::math::vec3::cross(e, [0.0, 0.0, 1.0]);
            let tn = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            let (cb, sb) = (1.541f64.cos(), 1.541f64.sin());
            nv.push([0, 1, 2].map(|i| cb * e[i] + sb * t[i] / tn));
            c.push(x);
        }
        let sc = Scene::new(c, nv, vec![0.02; 40_000]).unwrap();
        let pose = Pose::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
        let mut p = SonarParams::with_beamwidth(40f64.to_radians()).unwrap();
        p.lobe = LobeRule::Cone {
            half_angle: 70f64.to_radians(),
        };
        let s = FastSonar::new(Sonar::new(p).unwrap());
        let mem = crate::lobe::members(&sc, &s, &pose, 0, Search::Bvh).unwrap();
        assert_eq!(mem.len(), 35_000);
        let kinked = mem.iter().filter(|m| {
            let t = crate::echo::term::leaf_term(&s, &sc, m);
            paper_regime(&s.tables, &t) == crate::echo::PaperRegime::Kinked
        });
        assert_eq!(kinked.count(), mem.len());
        let (er, ei) = band_spectrum(&s, &sc, &mem);
        let cands = Candidates::all(sc.len());
        for tol in [1e-3, 1e-6, 1e-9] {
            let plan = FastPlan::new(&s, tol).unwrap();
            let (re, im, n) = fast_pulse(&sc, &s, &plan, &pose, 0, &cands).unwrap();
            assert_eq!(n as usize, mem.len());
            let err = rel_l2((&re, &im), (&er, &ei));
            assert!(err <= tol, "tol {tol:e}: {err:e}");
        }
    }

    #[test]
    fn fused_pulse_is_bit_identical_for_one_and_two_threads() {
        let sc = scene(150_000, 5);
        let pose = Pose::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
        let s = &sonars()[2];
        let plan = FastPlan::new(s, 1e-6).unwrap();
        let cands = candidates(&sc, s, &pose, Search::Bvh);
        assert!(cands.len() > 2 * chunk_len(cands.len(), plan.nufft.nf));
        let a = fast_pulse(&sc, s, &plan, &pose, 0, &cands).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| fast_pulse(&sc, s, &plan, &pose, 0, &cands).unwrap());
        assert_eq!(a, b);
    }

    #[test]
    fn bvh_candidates_come_in_ascending_storage_order() {
        let sc = scene(50_000, 9);
        assert_eq!(sc.node_ranges.len(), sc.bvh.nodes.len());
        let pose = Pose::new([0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.0, 0.0, 1.0]).unwrap();
        for s in sonars() {
            let c: Vec<u32> = candidates(&sc, &s, &pose, Search::Bvh).iter().collect();
            assert!(!c.is_empty());
            assert!(c.windows(2).all(|w| w[0] < w[1]));
        }
        let mut ids = sc.ids.clone();
        ids.sort_unstable();
        assert!(ids.iter().enumerate().all(|(k, &i)| i as usize == k));
    }

    #[test]
    fn a_too_close_leaf_is_reported_by_the_callers_smallest_index() {
        let sc = scene(20_000, 3);
        let s = &sonars()[0];
        // every leaf within 1 m of this pose is too close (min_range 1 m)
        let mut p = s.params.clone();
        p.min_range = 1.0;
        let s = FastSonar::new(Sonar::new(p).unwrap());
        let pose = Pose::new([0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
        let want = (0..sc.len())
            .filter(|&k| {
                let c = sc.centers.get(k);
                let d = [c[0] - 0.5, c[1], c[2]];
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() < 1.0
            })
            .map(|k| sc.ids[k] as usize)
            .min()
            .unwrap();
        let plan = FastPlan::new(&s, 1e-6).unwrap();
        let cands = candidates(&sc, &s, &pose, Search::Bvh);
        for res in [
            fast_pulse(&sc, &s, &plan, &pose, 0, &cands).map(|_| ()),
            crate::lobe::members(&sc, &s, &pose, 0, Search::Bvh).map(|_| ()),
        ] {
            match res {
                Err(crate::error::Error::TooClose { leaf, .. }) => assert_eq!(leaf, want),
                other => panic!("expected a too-close error, got {other:?}"),
            }
        }
    }
}
