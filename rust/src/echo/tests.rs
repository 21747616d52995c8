//! Tests of the exact kernel's paths against the scalar libm evaluation (which calls
//! [`crate::physics::leaf`]), and of its tables and regimes.
use crate::echo::exact::add_leaf;
use crate::echo::exact::add_leaf_scalar;
use crate::echo::exact::block_poly;
use crate::echo::exact::paper_blocks;
use crate::echo::exact::PaperLeaf;
use crate::echo::exact::CHEB_TOL;
use crate::echo::prepared::Prepared;
use crate::echo::regime::first_live_bin;
use crate::echo::regime::paper_regime;
use crate::echo::regime::paper_regime_bits;
use crate::echo::regime::paper_regime_of;
use crate::echo::regime::PaperRegime;
use crate::echo::regime::REGIME_KINKED;
use crate::echo::regime::REGIME_SMOOTH;
use crate::echo::regime::REGIME_ZERO;
use crate::echo::tables::LANES;
use crate::echo::tables::NODES;
use crate::echo::term::LeafTerm;
use crate::physics::leaf::PAPER_B0;
use crate::physics::leaf::PAPER_B1;
use crate::physics::leaf::PAPER_BP;
use crate::physics::leaf::PAPER_PP;
use crate::physics::phase::CyclesPerBin;
use crate::sonar::LeafModel;
use std::f64::consts::{FRAC_PI_2, PI};

use crate::physics::absorption::Atmosphere;
use crate::test_util::prepared_with as sonar_with;

fn sonar(atmosphere: Option<Atmosphere>, min_ka: f64) -> Prepared {
    sonar_with(|p| {
        p.atmosphere = atmosphere;
        p.min_ka = min_ka;
    })
}

/// Spectra of one leaf by each path: (smooth, pointwise, scalar libm).
fn paths(s: &Prepared, t: &LeafTerm) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let tab = &s.tables;
    let q = CyclesPerBin::new(
        t.range,
        s.params.fs,
        s.params.n_samples,
        s.params.sound_speed,
    );
    let lf = PaperLeaf {
        amp: t.amp,
        range: t.range,
        beta: t.beta,
        a: t.radius,
        ap: t.radius.powf(PAPER_BP),
        aq: t.radius.powf(PAPER_PP),
    };
    let z = || (vec![0.0; tab.m_pad], vec![0.0; tab.m_pad]);
    let join = |(r, i): (Vec<f64>, Vec<f64>)| {
        r[..tab.m]
            .iter()
            .chain(&i[..tab.m])
            .copied()
            .collect::<Vec<f64>>()
    };
    let atten = !tab.atten.is_empty();
    let run = |smooth: bool| {
        let (mut r, mut i) = z();
        if atten {
            paper_blocks::<true>(tab, &lf, &q, smooth, &mut r, &mut i)
        } else {
            paper_blocks::<false>(tab, &lf, &q, smooth, &mut r, &mut i)
        };
        join((r, i))
    };
    let (r1, r2) = (run(true), run(false));
    let (mut r3, mut i3) = z();
    add_leaf_scalar(s, t, &q, &mut r3, &mut i3);
    (r1, r2, join((r3, i3)))
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let peak = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if peak == 0.0 {
        return if a.iter().all(|&x| x == 0.0) {
            0.0
        } else {
            f64::INFINITY
        };
    }
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / peak
}

fn leaves() -> Vec<LeafTerm> {
    let mut out = Vec::new();
    for &radius in &[1e-3, 3e-3, 0.01, 0.025, 0.05, 0.2, 1.0] {
        for &beta in &[
            0.0,
            1e-8,
            0.3,
            0.8,
            1.2,
            1.5,
            1.57,
            std::f64::consts::FRAC_PI_2,
        ] {
            for &range in &[0.05, 1.0, 3.3, 10.19] {
                out.push(term(0.2 / (range * range), range, beta, radius));
            }
        }
    }
    out
}

fn term(amp: f64, range: f64, beta: f64, radius: f64) -> LeafTerm {
    LeafTerm::new(amp, range, beta, radius)
}

fn kink_free(s: &Prepared, t: &LeafTerm) -> bool {
    (PAPER_B1 * (s.tables.kp[0] * t.radius.powf(PAPER_BP)) + PAPER_B0) * t.beta < FRAC_PI_2
}

#[test]
fn physical_optics_blocks_match_libm_at_every_bin() {
    for atm in [None, Some(Atmosphere::default())] {
        let s = sonar_with(|p| {
            p.atmosphere = atm;
            p.leaf_model = LeafModel::PhysicalOptics;
            p.min_ka = 0.01;
        });
        let tab = &s.tables;
        let mut u = crate::test_util::uniforms(13);
        for n in 0..600 {
            // radii 0.1 mm - 30 cm; normal, grazing and oblique incidence; near and far
            let radius = 1e-4 * 3000f64.powf(u());
            let beta = match n % 5 {
                0 => 0.0,
                1 => std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9 * u()),
                _ => u() * std::f64::consts::FRAC_PI_2,
            };
            let range = 0.05 + 10.0 * u();
            let t = LeafTerm::new(0.2 / (range * range), range, beta, radius);
            let q = CyclesPerBin::new(range, s.params.fs, s.params.n_samples, s.params.sound_speed);
            let z = || (vec![0.0; tab.m_pad], vec![0.0; tab.m_pad]);
            let ((mut ar, mut ai), (mut br, mut bi)) = (z(), z());
            add_leaf(&s, &t, &mut ar, &mut ai);
            add_leaf_scalar(&s, &t, &q, &mut br, &mut bi);
            // (the bound of the paper model's paths, `max_rel`)
            let m = tab.m;
            let e = max_rel(
                &[&ar[..m], &ai[..m]].concat(),
                &[&br[..m], &bi[..m]].concat(),
            );
            assert!(e < 3e-12, "{t:?}: {e:e}");
        }
    }
}

#[test]
fn paper_regime_bits_name_the_regime_exactly() {
    let mut u = crate::test_util::uniforms(11);
    for f_lo in [60e3, 20e3] {
        let s = sonar_with(|p| p.f_lo = f_lo);
        let tab = &s.tables;
        let mut seen = [0usize; 4];
        for _ in 0..200_000 {
            let radius = 1e-4 * 3000f64.powf(u());
            let beta = u() * std::f64::consts::FRAC_PI_2;
            let ap = radius.powf(PAPER_BP);
            let regime = paper_regime_of(tab, ap, beta);
            seen[regime as usize] += 1;
            let want = match regime {
                PaperRegime::Zero => REGIME_ZERO,
                PaperRegime::Smooth => REGIME_SMOOTH,
                PaperRegime::Kinked => REGIME_KINKED,
                PaperRegime::OutOfDomain => 0,
            };
            assert_eq!(paper_regime_bits(tab, ap, beta), want, "{radius} {beta}");
        }
        assert!(seen.iter().all(|&n| n > 0) || f_lo > 50e3, "{seen:?}");
    }
    let tab = &sonar_with(|_| ()).tables;
    assert_eq!(paper_regime_bits(tab, f64::NAN, 1.0), 0);
    assert_eq!(paper_regime_bits(tab, 1.0, f64::NAN), 0);
}

#[test]
fn first_live_bin_is_the_first_bin_the_predicate_calls_live() {
    // the default band, and a wide one (where the first guess is far off)
    let wide = sonar_with(|p| {
        p.min_ka = 0.01;
        (p.f_lo, p.f_hi) = (15e3, 150e3);
    });
    for s in [sonar(None, 0.01), wide] {
        first_live_bin_matches_the_predicate(&s);
    }
}

fn first_live_bin_matches_the_predicate(s: &Prepared) {
    let tab = &s.tables;
    let x = |ap: f64, beta: f64, j: usize| PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) * beta;
    let mut u = crate::test_util::uniforms(11);
    let (mut kinked, m) = (0, tab.m);
    for _ in 0..20_000 {
        let radius = 0.0005 * 600f64.powf(u());
        let (ap, beta) = (radius.powf(PAPER_BP), FRAC_PI_2 * u().sqrt());
        let (lo, hi) = if u() < 0.5 {
            (0, m - 1)
        } else {
            let lo = (u() * m as f64) as usize;
            (lo, lo + ((u() * (m - lo) as f64) as usize).min(m - 1 - lo))
        };
        let want = (lo..=hi)
            .find(|&j| x(ap, beta, j) < FRAC_PI_2)
            .unwrap_or(hi + 1);
        assert_eq!(
            first_live_bin(tab, ap, beta, lo, hi),
            want,
            "{radius} {beta} {lo} {hi}"
        );
        kinked += usize::from(want > lo && want <= hi);
    }
    assert!(kinked > 200, "{kinked}");
}

#[test]
fn the_tables_inverse_of_kp_is_within_a_bin_over_the_default_band() {
    let s = sonar(None, 0.01);
    let tab = &s.tables;
    let worst = (0..tab.m)
        .map(|j| (tab.bin_of_kp.at(tab.kp[j]) - j as f64).abs())
        .fold(0.0f64, f64::max);
    assert!(worst < 0.5, "{worst}");
}

#[test]
fn kinked_leaves_match_libm_with_the_kink_anywhere_in_a_block() {
    for atm in [None, Some(Atmosphere::default())] {
        let s = sonar(atm, 0.5);
        let tab = &s.tables;
        for &radius in &[3e-3f64, 0.01, 0.025, 0.05] {
            let ap = radius.powf(PAPER_BP);
            for frac in [0.013, 0.1, 0.37, 0.5, 0.61, 0.83, 0.995] {
                // beta that puts B(c) beta = pi/2 just past band bin frac * M
                let j = (frac * tab.m as f64) as usize;
                let beta = FRAC_PI_2 / PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) + 1e-12;
                let t = term(0.2 / 9.0, 3.0, beta, radius);
                assert_eq!(paper_regime(tab, &t), PaperRegime::Kinked);
                let (_, blocks, exact) = paths(&s, &t);
                let e = max_rel(&blocks, &exact);
                assert!(e < 3e-12, "radius {radius}, kink at {frac}: {e:e}");
            }
        }
    }
}

#[test]
fn smooth_and_pointwise_paths_match_libm_per_leaf() {
    for atm in [None, Some(Atmosphere::default())] {
        let s = sonar(atm, 0.5);
        for t in leaves() {
            // Relative to the leaf's peak; where cos(B beta) ~ 0 over the whole band, rounding
            // of B beta alone moves the factor by ~1e-13 of its (small) peak.
            let (smooth, point, exact) = paths(&s, &t);
            let e = max_rel(&point, &exact);
            assert!(e < 3e-12, "pointwise {t:?}: {e:e}");
            if kink_free(&s, &t) {
                let e = max_rel(&smooth, &exact);
                assert!(e < 3e-12, "smooth {t:?}: {e:e}");
            }
        }
    }
}

fn node_t() -> [f64; LANES] {
    std::array::from_fn(|i| {
        if i < NODES {
            ((2 * i + 1) as f64 * PI / (2 * NODES) as f64).cos()
        } else {
            1.0
        }
    })
}

#[test]
fn block_interpolation_reproduces_polynomials_of_its_degree() {
    let s = sonar(None, 0.5);
    let f = |t: f64| 0.3 - 1.2 * t + 0.5 * t.powi(3) + 1e-8 * t.powi(6);
    let t = node_t();
    let fr: [f64; LANES] = std::array::from_fn(|i| f(t[i]));
    let fi: [f64; LANES] = std::array::from_fn(|i| -2.0 * f(t[i]));
    let (cr, ci) =
        block_poly(&s.tables, &fr, &fi, CHEB_TOL).expect("a degree-6 polynomial is smooth");
    for j in 0..=100 {
        let x = -1.0 + j as f64 / 50.0;
        let horner = |c: &[f64; NODES]| c.iter().rev().fold(0.0, |acc, &a| acc * x + a);
        assert!(
            (horner(&cr) - f(x)).abs() < 1e-14,
            "{x}: {}",
            horner(&cr) - f(x)
        );
        assert!((horner(&ci) + 2.0 * f(x)).abs() < 2e-14);
    }
}

#[test]
fn block_interpolation_is_refused_for_a_kinked_factor() {
    let s = sonar(None, 0.5);
    let t = node_t();
    let fr: [f64; LANES] = std::array::from_fn(|i| t[i].abs());
    assert!(block_poly(&s.tables, &fr, &[0.0; LANES], CHEB_TOL).is_none());
}

#[test]
fn smooth_path_handles_records_with_many_bins() {
    let s = sonar_with(|p| p.n_samples = 1_000_000);
    let t = term(1.0, 3.0, 0.4, 0.02);
    let (smooth, _point, exact) = paths(&s, &t);
    assert!(s.tables.nodes.n_blocks > 300);
    assert!(max_rel(&smooth, &exact) < 1e-12);
}

#[test]
fn paper_regimes_and_first_live_bins_agree_with_the_scalar_leaf_model() {
    // `paper_regime_of` and `first_live_bin` state `B(c) beta` with the table's `k^-0.9065`
    // times the leaf's `a^-0.9065`; `physics::leaf::paper` with `c^-0.9065`. They agree but
    // where `B(c) beta` is within rounding of pi/2 at some bin, where the leaf is skipped.
    use crate::physics::leaf;
    for f_lo in [60e3, 20e3] {
        let s = sonar_with(|p| {
            p.f_lo = f_lo;
            p.min_ka = 0.01;
        });
        let tab = &s.tables;
        let mut u = crate::test_util::uniforms(23);
        let mut seen = [0usize; 4];
        for _ in 0..3000 {
            let radius = 1e-3 * 100f64.powf(u());
            let beta = u() * FRAC_PI_2;
            let ap = radius.powf(PAPER_BP);
            let x: Vec<f64> = (0..tab.m)
                .map(|j| (PAPER_B1 * (tab.k[j] * radius).powf(PAPER_BP) + PAPER_B0) * beta)
                .collect();
            if x.iter()
                .any(|&x| (x - FRAC_PI_2).abs() < 1e-9 || (x - PI).abs() < 1e-9)
            {
                continue;
            }
            let live: Vec<bool> = (0..tab.m)
                .map(|j| leaf::paper(tab.k[j] * radius, beta).0 > 0.0)
                .collect();
            let regime = paper_regime_of(tab, ap, beta);
            seen[regime as usize] += 1;
            match regime {
                PaperRegime::Zero => assert!(live.iter().all(|&l| !l), "{radius} {beta}"),
                PaperRegime::Smooth => assert!(live.iter().all(|&l| l), "{radius} {beta}"),
                PaperRegime::Kinked => {
                    let first = live.iter().position(|&l| l).expect("live at the top bin");
                    assert!(live[first..].iter().all(|&l| l), "{radius} {beta}");
                    assert_eq!(first_live_bin(tab, ap, beta, 0, tab.m - 1), first);
                }
                PaperRegime::OutOfDomain => assert!(x[0] > PI, "{radius} {beta}"),
            }
        }
        assert!(seen[..3].iter().all(|&n| n > 0), "{seen:?}");
    }
}
