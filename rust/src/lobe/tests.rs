//! Tests of the lobe query: the BVH against brute force, the block test against the scalar
//! one, the conservative bounds.
use crate::lobe::block::classify_lanes;
use crate::lobe::block::Gathered;
use crate::lobe::block::CB;
use crate::lobe::bound::test_box;
use crate::lobe::bound::AngularBound;
use crate::lobe::bound::BoxTest;
use crate::lobe::candidates::Candidates;
use crate::lobe::members::farthest_member_range;
use crate::lobe::members::Search;
use crate::lobe::rule::Decision;
use crate::lobe::walk::bvh_candidates;
use crate::lobe::walk::Step;
use crate::lobe::walk::Walk;
use crate::math::vec3::{dot, sub, V3};
use crate::physics::leaf::incidence;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{LeafModel, LobeRule, Sonar, TooClose};
use std::f64::consts::PI;

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

/// The leaves at `ranged_positions` hold every member (whatever the too-close mode) and only
/// leaves within the sonar's ranges, for every sonar of `sonars()` and poses in and out of the
/// cloud.
#[test]
fn ranged_positions_hold_every_member_and_only_leaves_in_range() {
    let poses = [
        Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
        Pose::new([3.0, -2.0, 1.0], [-0.3, 1.0, 0.2], [0.0, 0.0, 1.0]).unwrap(),
    ];
    let (mut counted, mut beyond) = (0, 0);
    for too_close in [false, true] {
        let scene = leaves_around(20_000, 23, too_close);
        for mut sonar in sonars() {
            sonar.params.too_close = TooClose::Skip;
            for (i, pose) in poses.iter().enumerate() {
                let cands = candidates(&scene, &sonar, pose, Search::Bvh);
                let members = members_of(&scene, &sonar, pose, i, cands.to_vec()).unwrap();
                let (got, ids) = ranged_positions(&scene, &sonar, pose, &cands);
                assert!(got.windows(2).all(|p| p[0] < p[1]), "ascending");
                let at: Vec<u32> = got.iter().map(|&p| cands.get(p as usize)).collect();
                assert_eq!(ids, at, "the stored indices at the positions");
                let leaves: std::collections::HashSet<u32> = ids.into_iter().collect();
                for m in &members {
                    assert!(leaves.contains(&m.index), "pose {i}: member {}", m.index);
                }
                for &leaf in &leaves {
                    let c = scene.centers.get(leaf as usize);
                    let d = [0, 1, 2].map(|k| c[k] - pose.position[k]);
                    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    assert!(r > 0.0 && r >= sonar.params.min_range && r <= sonar.range_limit);
                }
                counted += usize::from(!members.is_empty());
                beyond += leaves.len() - members.len();
            }
        }
    }
    assert!(counted > 10 && beyond > 100, "{counted} {beyond}");
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
                receivers: None,
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

#[test]
fn visit_spans_visits_in_order_every_piece_a_conservative_test_keeps() {
    use crate::lobe::pieces::visit_spans;
    // pieces 0..1000 of which those in [300, 420) and 777 count; a span is ruled out when it
    // holds none of them
    let counts = |k: usize| (300..420).contains(&k) || k == 777;
    let out = |k0: usize, k1: usize| !(k0..k1).any(counts);
    for n in [0, 1, 15, 16, 17, 1000] {
        let mut seen = Vec::new();
        visit_spans(0, n, &out, &mut |k| seen.push(k));
        assert!(seen.windows(2).all(|w| w[0] < w[1]), "in order");
        let kept: Vec<usize> = seen.iter().copied().filter(|&k| counts(k)).collect();
        let all: Vec<usize> = (0..n).filter(|&k| counts(k)).collect();
        assert_eq!(kept, all, "n = {n}");
        assert!(
            seen.len() <= all.len() + 32,
            "visits {} for {}",
            seen.len(),
            all.len()
        );
    }
}
