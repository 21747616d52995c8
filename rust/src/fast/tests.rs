//! Tests of the fast path: errors against the exact sum, bits across chunkings and thread
//! counts, the kinked leaves' routes, the node values and weights against their references.
use crate::echo::{paper_regime, PaperRegime};
use crate::echo::{sum_terms, LeafTerm};
use crate::fast::kinks::kink_bin;
use crate::fast::kinks::paper_route;
use crate::fast::kinks::PaperRoute;
use crate::fast::lanes::PaperLanes;
use crate::fast::lanes::LB;
use crate::fast::nodes::choose_nodes;
use crate::fast::nodes::erf_at_nodes;
use crate::fast::nufft::Type1Plan;
use crate::fast::pass::chunk_len;
use crate::fast::pass::fast_sum_fixed;
use crate::fast::pass::fast_sum_terms;
use crate::fast::pass::fast_sum_terms_in;
use crate::fast::pass::second_chunk_len;
use crate::fast::pass::spread_pass;
use crate::fast::pass::FAST_CHUNK;
use crate::fast::pass::KINKED_IN_TASKS_UP_TO;
use crate::fast::pass::LEAVES_PER_GRID_POINT;
use crate::fast::pass::SUB_CHUNK;
use crate::fast::plan::nodes_for_tol;
use crate::fast::plan::FastPlan;
use crate::fast::plan::MAX_NODES;
use crate::fast::prepared::FastSonar;
use crate::fast::spread::weights4;
use crate::fast::spread::weights4_mirror;
use crate::fast::subband::KinkPass;
use crate::physics::leaf::{PAPER_B0, PAPER_B1};
use crate::sonar::LeafModel;
use std::f64::consts::PI;

use crate::physics::absorption::Atmosphere;
use crate::test_util::{rel_l2_pair as rel_l2, sonar_with};

fn sonar(atm: Option<Atmosphere>, model: LeafModel) -> FastSonar {
    sonar_with(|p| {
        p.atmosphere = atm;
        p.leaf_model = model;
    })
}

use crate::test_util::uniforms;

/// Leaves of every kind: tiny to huge, normal to grazing incidence (kinked and zero-L
/// leaves included), near and far.
fn terms(n: usize) -> Vec<LeafTerm> {
    let mut u = uniforms(7);
    (0..n)
        .map(|_| {
            let radius = (0.0005f64.ln() + u() * (0.3f64.ln() - 0.0005f64.ln())).exp();
            let range = 0.05 + u() * 10.1;
            LeafTerm::new(
                0.2 / (range * range),
                range,
                u() * std::f64::consts::FRAC_PI_2,
                radius,
            )
        })
        .collect()
}

#[test]
fn fast_spectrum_is_within_tol_of_the_exact_sum() {
    let t = terms(3000);
    for (atm, model) in [
        (None, LeafModel::Paper),
        (Some(Atmosphere::default()), LeafModel::Paper),
        (None, LeafModel::PhysicalOptics),
    ] {
        let s = sonar(atm, model);
        let exact = sum_terms(&s, &t);
        for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
            let plan = FastPlan::new(&s, tol).unwrap();
            let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
            assert!(
                err <= tol,
                "{model:?} atm {} tol {tol:e}: error {err:e}",
                atm.is_some()
            );
        }
    }
}

#[test]
fn fast_spectrum_is_bit_identical_across_chunkings() {
    // Many leaves: several parallel chunks; the result must not depend on the thread count,
    // which only changes who computes each chunk.
    let t = terms(FAST_CHUNK * 2 + 123);
    assert_same_bits_on_one_and_two_threads(&sonar(None, LeafModel::Paper), &t);
}

/// `fast_sum_terms` at `tol = 1e-6` gives the same bits on the global pool (two threads)
/// and on a pool of one.
fn assert_same_bits_on_one_and_two_threads(s: &FastSonar, t: &[LeafTerm]) {
    let plan = FastPlan::new(s, 1e-6).unwrap();
    let a = fast_sum_terms(s, &plan, t);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = pool.install(|| fast_sum_terms(s, &plan, t));
    assert_eq!(a, b);
}

#[test]
fn a_first_pass_that_keeps_a_thread_awake_gives_the_bits_of_one_that_does_not() {
    // four tasks of ~25k leaves on two and three threads: a thread that ends its task
    // early waits awake for the pass's end, which changes only who computes what, when
    let s = sonar(None, LeafModel::Paper);
    let plan = FastPlan::new(&s, 1e-6).unwrap();
    let t = terms(100_000);
    for threads in [2, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let awake = pool.install(|| fast_sum_terms_in(&s, &plan, &t, true));
        let asleep = pool.install(|| fast_sum_terms_in(&s, &plan, &t, false));
        assert_eq!(awake, asleep);
    }
}

/// Kinked paper-model leaves only (the factor's cosine crosses zero inside the band).
fn kinked_terms(s: &FastSonar, n: usize) -> Vec<LeafTerm> {
    terms(40 * n)
        .into_iter()
        .filter(|t| paper_regime(&s.tables, t) == PaperRegime::Kinked)
        .take(n)
        .collect()
}

#[test]
fn kinked_leaves_are_within_tol_of_the_exact_sum_and_mostly_spread() {
    for atm in [None, Some(Atmosphere::default())] {
        let s = sonar(atm, LeafModel::Paper);
        let t = kinked_terms(&s, 400);
        assert!(t.len() >= 200, "{}", t.len());
        let exact = sum_terms(&s, &t);
        // (every kinked leaf goes into a batch: its interpolant is subtracted on the
        // shorter zero side, or added on the shorter live side)
        let spread = t.clone();
        for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
            let plan = FastPlan::new(&s, tol).unwrap();
            let deferred = spread_pass(
                &s,
                &plan,
                &spread,
                &[],
                chunk_len(spread.len(), plan.nufft.nf),
                None,
                false,
            )
            .deferred;
            // (a few fail the check on their live side and are summed exactly)
            assert!(
                deferred.len() * 4 <= spread.len(),
                "tol {tol:e}: {} of {} deferred",
                deferred.len(),
                spread.len()
            );
            let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
            assert!(err <= tol, "atm {} tol {tol:e}: {err:e}", atm.is_some());
        }
        // each kinked leaf alone, too (its own peak sets the scale)
        let plan = FastPlan::new(&s, 1e-9).unwrap();
        for leaf in t.iter().take(40) {
            let one = std::slice::from_ref(leaf);
            let err = rel_l2(&fast_sum_terms(&s, &plan, one), &sum_terms(&s, one));
            assert!(err <= 1e-9, "{leaf:?}: {err:e}");
        }
    }
}

/// 20,000 leaves, every tenth kinked: a first pass of four tasks, which spread their
/// kinked leaves themselves.
fn few_task_terms(s: &FastSonar) -> Vec<LeafTerm> {
    let kinked = kinked_terms(s, 2000);
    let smooth = terms(18_000);
    let mut t = Vec::with_capacity(20_000);
    for (i, k) in kinked.iter().enumerate() {
        t.push(*k);
        t.extend_from_slice(&smooth[9 * i..9 * i + 9]);
    }
    t
}

#[test]
fn a_few_task_pass_spreads_its_kinked_leaves_in_its_tasks() {
    let s = sonar(None, LeafModel::Paper);
    let t = few_task_terms(&s);
    // (the first pass's node count for these leaves, which most kinked ones fail)
    let full = FastPlan::new(&s, 1e-6).unwrap();
    let p = choose_nodes(&s, &full, &t);
    assert!(p < full.p, "{p} {}", full.p);
    let plan = s.plans.get_with_nodes(&s, 1e-6, p).unwrap();
    let chunk = chunk_len(t.len(), plan.nufft.nf);
    assert!(t.len().div_ceil(chunk) <= KINKED_IN_TASKS_UP_TO);
    let kink = KinkPass::new(&s, 1e-6, p).unwrap();
    let f = spread_pass(&s, &plan, &t, &[], chunk, Some(&kink), false);
    // (none left for a later pass; one share per task)
    assert!(f.kinked.is_empty());
    assert_eq!(f.shares.len(), t.len().div_ceil(chunk));
    let without = spread_pass(&s, &plan, &t, &[], chunk, None, false);
    assert!(without.kinked.len() > 100, "{}", without.kinked.len());
}

#[test]
fn kinked_leaves_spread_in_the_tasks_are_within_tol_of_the_exact_sum() {
    for atm in [None, Some(Atmosphere::default())] {
        let s = sonar(atm, LeafModel::Paper);
        let t = few_task_terms(&s);
        let exact = sum_terms(&s, &t);
        for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
            let plan = FastPlan::new(&s, tol).unwrap();
            let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
            assert!(err <= tol, "atm {} tol {tol:e}: {err:e}", atm.is_some());
        }
        // the kinked leaves alone (their own peaks set the scale)
        let kinked: Vec<LeafTerm> = t.iter().step_by(10).copied().collect();
        let plan = FastPlan::new(&s, 1e-9).unwrap();
        let err = rel_l2(&fast_sum_terms(&s, &plan, &kinked), &sum_terms(&s, &kinked));
        assert!(err <= 1e-9, "atm {}: {err:e}", atm.is_some());
    }
}

#[test]
fn kinked_leaves_spread_in_the_tasks_are_bit_identical_for_one_and_two_threads() {
    let s = sonar(None, LeafModel::Paper);
    assert_same_bits_on_one_and_two_threads(&s, &few_task_terms(&s));
}

#[test]
fn kinked_leaves_with_a_tiny_live_part_are_within_tol_alone() {
    // The corner in the band's top bins: the live side is a few bins where cos(B beta)
    // has barely turned positive (~1e-4 of the factor's scale), so the node values'
    // rounding (~2e-16 of that scale) is ~1e-12 of the live values.
    let s = sonar(None, LeafModel::Paper);
    let (tab, m) = (&s.tables, s.n_bins());
    for &radius in &[0.003f64, 0.0045, 0.0056, 0.008] {
        let ap = radius.powf(crate::physics::leaf::PAPER_BP);
        for live in [2usize, 5, 8, 20, 26, 64, 100] {
            let j = m - live;
            let beta =
                std::f64::consts::FRAC_PI_2 / PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) + 1e-12;
            for range in [2.44, 9.48] {
                let leaf = LeafTerm::new(0.01, range, beta, radius);
                assert_eq!(paper_regime(tab, &leaf), PaperRegime::Kinked);
                let one = std::slice::from_ref(&leaf);
                let exact = sum_terms(&s, one);
                // (1e-6 and 1e-3: the shortest series, whose relative errors, ~1e-8, scale
                // with the factor and so with its small live values)
                for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                    let plan = FastPlan::new(&s, tol).unwrap();
                    let err = rel_l2(&fast_sum_terms(&s, &plan, one), &exact);
                    assert!(err <= tol, "{leaf:?} live {live} tol {tol:e}: {err:e}");
                }
            }
        }
    }
}

#[test]
fn a_deferring_pass_returns_exact_routed_leaves_apart_from_its_failures() {
    // a 20-80 kHz band: wide enough for leaves outside the model's domain (B(c) beta past
    // pi at the low edge while live at the high one)
    let s = sonar_with(|p| {
        p.f_lo = 20e3;
        p.min_ka = 0.01;
    });
    // kinked leaves (in batches) and, every fourth, a 0.2 mm leaf outside the model's
    // domain (to the exact sum)
    let mut u = uniforms(5);
    let t: Vec<LeafTerm> = kinked_terms(&s, 450)
        .into_iter()
        .enumerate()
        .flat_map(|(i, l)| {
            let tiny = LeafTerm::new(l.amp, l.range, 0.62 + 0.07 * u(), 2e-4);
            std::iter::once(l).chain((i % 3 == 0).then_some(tiny))
        })
        .collect();
    assert!(t
        .iter()
        .any(|l| paper_regime(&s.tables, l) == PaperRegime::OutOfDomain));
    let routed = |l: &LeafTerm| {
        let route = paper_route(&s, paper_regime(&s.tables, l), l.radius_pow_b, l.beta);
        matches!(route, PaperRoute::Defer)
    };
    let want: Vec<usize> = (0..t.len()).filter(|&i| routed(&t[i])).collect();
    assert!(
        want.len() >= 50 && t.len() - want.len() >= 50,
        "{}",
        want.len()
    );
    let plan = FastPlan::new(&s, 1e-6).unwrap();
    // several tasks, so that the indices cross task boundaries
    let f = spread_pass(&s, &plan, &t, &[], 64, None, false);
    assert_eq!(f.exact, want);
    assert!(f.deferred.iter().all(|i| !routed(&t[*i])));
    // a whole pass sums both exactly: every leaf is counted once
    let g = fast_sum_fixed(&s, &plan, &t, &[], 64);
    assert!(rel_l2(&g, &sum_terms(&s, &t)) <= 1e-6);
}

#[test]
fn second_pass_tasks_are_a_quarter_of_the_leaves_in_whole_sub_chunks() {
    assert_eq!(second_chunk_len(1), SUB_CHUNK);
    assert_eq!(second_chunk_len(4188), 2 * SUB_CHUNK);
    assert_eq!(second_chunk_len(10_000_000), FAST_CHUNK);
    for n in [1, 500, 4096, 4188, 20_000, 1 << 20] {
        let c = second_chunk_len(n);
        assert_eq!(c % SUB_CHUNK, 0);
        assert!(n.div_ceil(c) <= 4 || c == FAST_CHUNK, "{n}: {c}");
    }
}

#[test]
fn first_pass_tasks_are_four_to_sixteen_with_ten_leaves_per_grid_point() {
    // the default record's grid (2430 points): 1e5 leaves in 4 tasks, 1e6 in 16
    assert_eq!(100_000usize.div_ceil(chunk_len(100_000, 2430)), 4);
    assert_eq!(chunk_len(1_000_000, 2430), 62_500);
    for nf in [100, 2430, 100_000] {
        for n in [1, 5000, 20_000, 100_000, 400_000, 1_000_000, 10_000_000] {
            let c = chunk_len(n, nf);
            assert!((1..=FAST_CHUNK).contains(&c), "{n} {nf}: {c}");
            let tasks = n.div_ceil(c);
            // tasks of 4096 leaves at least, unless the leaves are too few for that
            assert!(c >= 4096 || tasks == n.div_ceil(4096), "{n} {nf}: {c}");
            assert!(
                tasks <= 16 || tasks == n.div_ceil(FAST_CHUNK),
                "{n} {nf}: {tasks}"
            );
            assert!(tasks >= 4 || c < 4096 + tasks, "{n} {nf}: {tasks}");
            // the last task at most one leaf per task shorter than the others
            assert!(n - (tasks - 1) * c + tasks > c, "{n} {nf}: {c}");
            // past 16 tasks' worth, at least ten leaves per grid point (or the cap)
            if n >= 4 * LEAVES_PER_GRID_POINT * nf && tasks < 16 {
                assert!(c >= LEAVES_PER_GRID_POINT * nf, "{n} {nf}");
            }
        }
    }
}

#[test]
fn mirror_weights_match_the_horner_weights_of_an_eight_tap_kernel() {
    let plan = Type1Plan::new(1201, 2e-7).unwrap();
    assert_eq!(plan.w, 8);
    let mut worst: f64 = 0.0;
    for k in 0..2000 {
        let u = [
            k as f64 / 2000.0,
            0.5,
            1.0 - k as f64 / 2000.0,
            (k as f64 * 0.37) % 1.0,
        ];
        let want = weights4::<8>(&plan.horner, u);
        let got = weights4_mirror(&plan.mirror, u);
        for (g, w) in got.iter().zip(&want) {
            for t in 0..8 {
                worst = worst.max((g[t] - w[t]).abs());
            }
        }
    }
    assert!(worst <= 1e-15, "{worst:e}");
}

#[cfg(target_arch = "x86_64")]
#[test]
fn a_block_transposed_in_registers_equals_the_block_pushed_leaf_by_leaf() {
    if !std::arch::is_x86_feature_detected!("avx512f") {
        return;
    }
    let t = terms(3 * LB);
    for block in t.chunks_exact(LB) {
        let block: &[LeafTerm; LB] = block.try_into().unwrap();
        let want = PaperLanes::of_block(block);
        // SAFETY: AVX-512F was detected above.
        let got = unsafe { PaperLanes::of_block_avx512(block) };
        assert_eq!(got.n, want.n);
        for (g, w) in [
            (got.amp, want.amp),
            (got.range, want.range),
            (got.beta, want.beta),
            (got.a, want.a),
            (got.ap, want.ap),
            (got.aq, want.aq),
            (got.floor, want.floor),
        ] {
            assert_eq!(g.map(f64::to_bits), w.map(f64::to_bits));
        }
        assert_eq!((got.kink, got.skip), (want.kink, want.skip));
    }
}

#[test]
fn erf_at_nodes_matches_libm_at_each_level() {
    // node ranges as the 60-80 kHz band gives them (half-width up to 0.051 (|z_c| + 1.5)),
    // and wider ones (the fallback)
    let mut u = uniforms(3);
    for spread in [0.051, 0.3] {
        let mut worst = [0.0f64; 3];
        for _ in 0..2000 {
            let p = 2 + (u() * 14.0) as usize;
            let centres: [f64; LB] = std::array::from_fn(|_| -3.0 + 12.0 * u());
            let z: [[f64; LB]; MAX_NODES] = std::array::from_fn(|q| {
                let t = ((2 * q + 1) as f64 * PI / (2 * p) as f64).cos();
                centres.map(|zc| zc + spread * (zc.abs() + 1.5) * t)
            });
            let mut c = [[0.0; LB]; MAX_NODES];
            let mut got = [[[0.0; LB]; MAX_NODES]; 3];
            erf_at_nodes::<22, 7>(p, &z, &mut c, &mut got[0]);
            erf_at_nodes::<28, 11>(p, &z, &mut c, &mut got[1]);
            erf_at_nodes::<40, 14>(p, &z, &mut c, &mut got[2]);
            for (lvl, g) in got.iter().enumerate() {
                for q in 0..p {
                    for i in 0..LB {
                        let e = (g[q][i] - libm::erf(z[q][i])).abs();
                        worst[lvl] = worst[lvl].max(e);
                    }
                }
            }
        }
        assert!(worst[0] <= 2e-9, "spread {spread}: {worst:?}");
        assert!(worst[1] <= 1e-12, "spread {spread}: {worst:?}");
        assert!(worst[2] <= 2e-15, "spread {spread}: {worst:?}");
    }
}

#[test]
fn kink_bin_splits_the_band_where_the_factor_turns_on() {
    let s = sonar(None, LeafModel::Paper);
    for t in kinked_terms(&s, 100) {
        let mk = kink_bin(&s, t.radius_pow_b, t.beta);
        assert!(mk > 0 && mk < s.n_bins());
        let x = |m: usize| PAPER_B1.mul_add(s.tables.kp[m] * t.radius_pow_b, PAPER_B0) * t.beta;
        assert!(x(mk - 1) >= std::f64::consts::FRAC_PI_2 && x(mk) < std::f64::consts::FRAC_PI_2);
    }
}

#[test]
fn nodes_grow_as_the_tolerance_tightens() {
    let p: Vec<usize> = [1e-3, 1e-6, 1e-9, 1e-12]
        .iter()
        .map(|&t| nodes_for_tol(t))
        .collect();
    assert!(p.windows(2).all(|w| w[0] < w[1]), "{p:?}");
    assert!(FastPlan::new(&sonar(None, LeafModel::Paper), 1e-14).is_err());
}

#[test]
fn paper_node_values_match_the_scalar_leaf_model_at_each_level() {
    use crate::echo::{paper_regime, PaperRegime};
    use crate::fast::nodes::{paper_nodes, BatchScratch};
    use crate::physics::leaf;
    // (tolerance, largest error relative to the leaf's peak over the nodes): the full, short
    // and shortest series of `paper_nodes`
    for (tol, bound) in [(1e-12, 1e-14), (1e-9, 2e-12), (1e-6, 3e-8)] {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, LeafModel::Paper);
            let plan = FastPlan::new(&s, tol).unwrap();
            let smooth: Vec<LeafTerm> = terms(4000)
                .into_iter()
                .filter(|t| paper_regime(&s.tables, t) == PaperRegime::Smooth)
                .take(4 * LB)
                .collect();
            assert_eq!(smooth.len(), 4 * LB);
            let mut scratch = BatchScratch::new();
            for batch in smooth.chunks(LB) {
                let f = |g: fn(&LeafTerm) -> f64| -> [f64; LB] {
                    std::array::from_fn(|i| g(&batch[i]))
                };
                let (amp, range, beta) = (f(|t| t.amp), f(|t| t.range), f(|t| t.beta));
                let (a, ap, aq) = (
                    f(|t| t.radius),
                    f(|t| t.radius_pow_b),
                    f(|t| t.radius_pow_p),
                );
                if atm.is_some() {
                    paper_nodes::<true>(&plan, &amp, &range, &beta, &a, &ap, &aq, &mut scratch);
                } else {
                    paper_nodes::<false>(&plan, &amp, &range, &beta, &a, &ap, &aq, &mut scratch);
                }
                for (i, t) in batch.iter().enumerate() {
                    let want: Vec<(f64, f64)> = (0..plan.p)
                        .map(|q| {
                            let k = plan.nodes.k[q];
                            let (l, psi) = leaf::paper(k * t.radius, t.beta);
                            let mut am = t.amp * l * plan.node_scale[q];
                            if let Some(&x) = plan.nodes.atten.get(q) {
                                am *= (-x * t.range).exp();
                            }
                            (am * psi.cos(), -am * psi.sin())
                        })
                        .collect();
                    let peak = want
                        .iter()
                        .fold(0.0f64, |m, w| m.max(w.0.abs()).max(w.1.abs()));
                    for (q, w) in want.iter().enumerate() {
                        let (gr, gi) = (scratch.fr[q][i], scratch.fi[q][i]);
                        let e = (gr - w.0).abs().max((gi - w.1).abs()) / peak;
                        assert!(e <= bound, "tol {tol:e}, node {q}, {t:?}: {e:e}");
                    }
                }
            }
        }
    }
}
