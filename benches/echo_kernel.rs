//! Criterion benchmarks of the echo kernel (`cargo bench`):
//! - the spectrum kernel for 1e3, 1e4, 1e5 leaves at 1201 bins (the model's defaults, docs/model.md);
//! - the lobe query on a 1e6-leaf scene for 10 and 50 degree beams, BVH against brute force;
//! - one whole fast pulse (lobe query and spectrum, tol 1e-6) with 1e5 and 1e6 leaves in the
//!   lobe: fused (`pulse::fast_pulse`, as `simulate` runs it) against the members list first;
//! - exact and fast (tol 1e-6) spectra of 1e5 leaves in the lobe, in the lobe query's order;
//! - a whole pulse (`simulate`) heard by one ear against two ears (and monostatic), exact and
//!   fast (tol 1e-6), at 1e4 and 1e5 leaves in the lobe; and the part the ears share (the
//!   lobe query and the pass that makes every ear's terms) alone;
//! - shading's cast alone (every leaf's ray from the sonar, against every leaf disk) at 1e4 and
//!   1e5 leaves in the box;
//! - the clearance (nearest leaf disk) of 1000 points in the 1e6-leaf canopy.

use batecho::echo::{heard_terms, leaf_term, sum_terms, LeafTerm};
use batecho::fast::pulse::fast_pulse;
use batecho::fast::FastSonar;
use batecho::fast::{fast_band_spectrum, fast_sum_terms, FastPlan};
use batecho::interrupt::NEVER;
use batecho::lobe::{candidates, candidates_heard, members, place_receivers, Search};
use batecho::physics::beam::GaussianBeam;
use batecho::physics::pose::Pose;
use batecho::scene::Scene;
use batecho::shade::{cast, Target};
use batecho::simulate::{simulate, Method};
use batecho::sonar::LobeRule;
use batecho::sonar::{Receiver, Sonar, SonarParams};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;

/// A small deterministic generator (SplitMix64) so the bench needs no extra crates.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

fn sonar(beamwidth_deg: f64) -> FastSonar {
    FastSonar::new(
        Sonar::new(SonarParams::with_beamwidth(beamwidth_deg.to_radians()).unwrap()).unwrap(),
    )
}

fn terms(n: usize, rng: &mut Rng) -> Vec<LeafTerm> {
    (0..n)
        .map(|_| {
            let range = rng.uniform(1.0, 10.0);
            let radius = rng.uniform(0.015, 0.025);
            LeafTerm::new(
                0.2 * rng.uniform(0.0, 1.0) / (range * range),
                range,
                rng.uniform(0.0, std::f64::consts::FRAC_PI_2),
                radius,
            )
        })
        .collect()
}

fn bench_spectrum(c: &mut Criterion) {
    let s = sonar(30.0);
    let mut rng = Rng(1);
    let mut g = c.benchmark_group("spectrum_exact");
    g.sample_size(10);
    for &n in &[1_000usize, 10_000, 100_000] {
        let t = terms(n, &mut rng);
        g.throughput(Throughput::Elements((n * s.n_bins()) as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &t, |b, t| {
            b.iter(|| black_box(sum_terms(&s, t)))
        });
    }
    g.finish();
}

/// 1e6 leaves uniformly in a 100 m x 100 m x (2..12) m canopy slab.
fn forest(n: usize) -> Scene {
    let mut rng = Rng(7);
    let mut centers = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    let mut radii = Vec::with_capacity(n);
    for _ in 0..n {
        centers.push([
            rng.uniform(-50.0, 50.0),
            rng.uniform(-50.0, 50.0),
            rng.uniform(2.0, 12.0),
        ]);
        let (th, ph) = (
            rng.uniform(0.0, std::f64::consts::PI),
            rng.uniform(0.0, 2.0 * std::f64::consts::PI),
        );
        normals.push([th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()]);
        radii.push(rng.uniform(0.015, 0.035));
    }
    Scene::new(centers, normals, radii).unwrap()
}

fn bench_lobe(c: &mut Criterion) {
    let scene = forest(1_000_000);
    eprintln!(
        "BVH build for 1e6 leaves: {:.1} ms",
        scene.build_time.as_secs_f64() * 1e3
    );
    let pose = Pose::new([0.0, 0.0, 5.0], [1.0, 0.3, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let mut g = c.benchmark_group("lobe_query_1e6");
    g.sample_size(10);
    for &bw in &[10.0, 50.0] {
        let s = sonar(bw);
        let n_in = members(&scene, &s, &pose, 0, Search::Bvh).unwrap().len();
        eprintln!("beamwidth {bw} deg: {n_in} leaves in the lobe");
        for (name, search) in [("bvh", Search::Bvh), ("brute_force", Search::BruteForce)] {
            g.bench_function(BenchmarkId::new(name, bw), |b| {
                b.iter(|| black_box(members(&scene, &s, &pose, 0, search).unwrap().len()))
            });
        }
    }
    g.finish();
}

fn bench_fast(c: &mut Criterion) {
    let s = sonar(30.0);
    let mut rng = Rng(1);
    let mut g = c.benchmark_group("spectrum_fast");
    g.sample_size(10);
    for &tol in &[1e-3, 1e-6, 1e-9, 1e-12] {
        let plan = FastPlan::new(&s, tol).unwrap();
        for &n in &[1_000usize, 100_000, 1_000_000] {
            let t = terms(n, &mut rng);
            g.throughput(Throughput::Elements(n as u64));
            g.bench_with_input(BenchmarkId::new(format!("tol{tol:e}"), n), &t, |b, t| {
                b.iter(|| black_box(fast_sum_terms(&s, &plan, t)))
            });
        }
    }
    g.finish();
}

/// `n` leaves uniform in x in [1, 9.5] m, y, z in [-2, 2] m, radius N(2, 0.2) cm, random
/// normals (the scene of `benches/speed_vs_error.py`); every leaf lies in a 75-degree cone.
fn box_scene(n: usize) -> Scene {
    let mut rng = Rng(7);
    let mut normal = || {
        let u = rng.uniform(1e-300, 1.0);
        let v = rng.uniform(0.0, 1.0);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    };
    let mut centers = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    let mut radii = Vec::with_capacity(n);
    for _ in 0..n {
        let v = [normal(), normal(), normal()];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        normals.push([v[0] / l, v[1] / l, v[2] / l]);
        radii.push(0.02 + 0.002 * normal());
    }
    let mut rng = Rng(11);
    for _ in 0..n {
        centers.push([
            rng.uniform(1.0, 9.5),
            rng.uniform(-2.0, 2.0),
            rng.uniform(-2.0, 2.0),
        ]);
    }
    Scene::new(centers, normals, radii).unwrap()
}

fn bench_pulse(c: &mut Criterion) {
    let mut p = SonarParams::with_beamwidth(30f64.to_radians()).unwrap();
    p.lobe = LobeRule::Cone {
        half_angle: 75f64.to_radians(),
    };
    let s = FastSonar::new(Sonar::new(p).unwrap());
    let plan = FastPlan::new(&s, 1e-6).unwrap();
    let pose = Pose::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let mut g = c.benchmark_group("pulse_fast_tol1e-6");
    g.sample_size(10);
    for &n in &[100_000usize, 1_000_000] {
        let scene = box_scene(n);
        assert_eq!(members(&scene, &s, &pose, 0, Search::Bvh).unwrap().len(), n);
        g.bench_function(BenchmarkId::new("fused", n), |b| {
            b.iter(|| {
                let cands = candidates(&scene, &s, &pose, Search::Bvh);
                black_box(fast_pulse(&scene, &s, &plan, &pose, 0, &cands).unwrap())
            })
        });
        g.bench_function(BenchmarkId::new("members_then_spectrum", n), |b| {
            b.iter(|| {
                let mem = members(&scene, &s, &pose, 0, Search::Bvh).unwrap();
                black_box(fast_band_spectrum(&s, &plan, &scene, &mem))
            })
        });
    }
    g.finish();
    // The spectrum kernels alone on the terms of 1e5 leaves in the lobe, in the order a lobe
    // query gives them (the scene's BVH order: neighbours in space, so in delay), against
    // `spectrum_exact` / `spectrum_fast`, whose terms come in random order.
    let scene = box_scene(100_000);
    let mem = members(&scene, &s, &pose, 0, Search::Bvh).unwrap();
    let t: Vec<LeafTerm> = mem.iter().map(|mb| leaf_term(&s, &scene, mb)).collect();
    let mut g = c.benchmark_group("spectrum_lobe_order");
    g.sample_size(10);
    g.bench_function(BenchmarkId::new("exact", t.len()), |b| {
        b.iter(|| black_box(sum_terms(&s, &t)))
    });
    g.bench_function(BenchmarkId::new("fast_tol1e-6", t.len()), |b| {
        b.iter(|| black_box(fast_sum_terms(&s, &plan, &t)))
    });
    g.finish();
}

/// Ears 2 cm apart, turned 30 degrees outward, each with a 40-degree beam.
fn ears(n: usize) -> Vec<Receiver> {
    let ear = |side: f64| Receiver {
        offset: [0.0, side * 0.01, 0.0],
        beam: Some(
            GaussianBeam::circular(40f64.to_radians())
                .and_then(|b| {
                    GaussianBeam::new(
                        1.0,
                        b.sigma_x,
                        b.sigma_y,
                        0.0,
                        side * 30f64.to_radians(),
                        0.0,
                    )
                })
                .unwrap(),
        ),
    };
    [ear(1.0), ear(-1.0)][..n].to_vec()
}

fn bench_ears(c: &mut Criterion) {
    let pose = Pose::new([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let sonar_with = |receivers: Vec<Receiver>| {
        let mut p = SonarParams::with_beamwidth(30f64.to_radians()).unwrap();
        p.lobe = LobeRule::Cone {
            half_angle: 75f64.to_radians(),
        };
        p.receivers = receivers;
        FastSonar::new(Sonar::new(p).unwrap())
    };
    let sonars = [
        ("monostatic", sonar_with(Vec::new())),
        ("one_ear", sonar_with(ears(1))),
        ("two_ears", sonar_with(ears(2))),
    ];
    for &n in &[10_000usize, 100_000] {
        let scene = box_scene(n);
        let mut g = c.benchmark_group(format!("ears_pulse_{n}"));
        g.sample_size(10);
        for (name, s) in &sonars[1..] {
            g.bench_function(BenchmarkId::new("lobe_and_terms", name), |b| {
                b.iter(|| {
                    let rxs = place_receivers(s, &pose);
                    let cands = candidates_heard(&scene, s, &pose, &rxs, Search::Bvh);
                    black_box(heard_terms(&scene, s, &pose, 0, &rxs, &cands).unwrap())
                })
            });
        }
        for (method, m) in [
            ("exact", Method::Exact),
            ("fast_tol1e-6", Method::Fast { tol: 1e-6 }),
        ] {
            for (name, s) in &sonars {
                let run = || simulate(&scene, s, &[pose], false, Search::Bvh, m, &NEVER).unwrap();
                assert!(run().n_leaves.iter().all(|&k| k as usize == n));
                g.bench_function(BenchmarkId::new(method, name), |b| {
                    b.iter(|| black_box(run()))
                });
            }
        }
        g.finish();
    }
}

/// The clearance of 1000 points in the 1e6-leaf canopy of [`forest`] (BVH walk), beside
/// the pulse it guards (`bench_lobe`'s lobe query is one part of a pulse).
/// Shading's cast alone: the ray of every leaf of the box (all in the lobe) from the sonar,
/// through the light buffer, against every leaf disk (`batecho.Shading()` casts these rays
/// for a pulse; `benches/bench_shading.py` times the whole shaded pulse against the unshaded).
fn bench_cast(c: &mut Criterion) {
    let mut g = c.benchmark_group("shade_cast");
    g.sample_size(10);
    for &n in &[10_000usize, 100_000] {
        let scene = box_scene(n);
        let targets: Vec<Target> = (0..n)
            .map(|i| Target::Leaf {
                point: scene.centers.get(i),
                leaf: i as u32,
            })
            .collect();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(BenchmarkId::new("every_leaf", n), |b| {
            b.iter(|| black_box(cast(&scene, [0.0; 3], &targets, true).len()))
        });
    }
    g.finish();
}

fn bench_clearance(c: &mut Criterion) {
    let scene = forest(1_000_000);
    let mut rng = Rng(3);
    let points: Vec<[f64; 3]> = (0..1000)
        .map(|_| {
            [
                rng.uniform(-50.0, 50.0),
                rng.uniform(-50.0, 50.0),
                rng.uniform(0.0, 14.0),
            ]
        })
        .collect();
    let mut g = c.benchmark_group("clearance_1e6");
    g.sample_size(10);
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("bvh_1000_points", |b| {
        b.iter(|| black_box(scene.clearance(&points).unwrap().len()))
    });
    g.finish();
}

criterion_group!(
    benches,
    bench_spectrum,
    bench_fast,
    bench_lobe,
    bench_pulse,
    bench_ears,
    bench_cast,
    bench_clearance
);
criterion_main!(benches);
