//! Tests of the receivers' lobe query and pass: the exact test reduces to the monostatic one,
//! the node test is conservative for receivers at offsets, the lanes decide as libm, and the
//! BVH finds what brute force does.
use crate::echo::receivers::heard_members;
use crate::lobe::bound::BoxTest;
use crate::lobe::members::{members, Search};
use crate::lobe::receivers::{classify_heard, emitter_side, place_receivers, HeardDecision};
use crate::lobe::receivers_bound::test_box_heard;
use crate::lobe::rule::{classify, Decision};
use crate::lobe::walk::candidates_heard;
use crate::math::vec3::{dot, sub, V3};
use crate::physics::beam::GaussianBeam;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::{LobeRule, Receiver, Sonar, SonarParams};
use std::f64::consts::PI;

/// Detectable and cone lobes, each with two ears and with a receiver far from the emitter
/// (a pattern of its own, turned sideways).
fn sonars() -> Vec<Sonar> {
    let mut out = Vec::new();
    for cone in [false, true] {
        for far in [false, true] {
            let mut p = SonarParams::with_beamwidth(40f64.to_radians()).unwrap();
            if cone {
                p.lobe = LobeRule::Cone {
                    half_angle: 70f64.to_radians(),
                };
            }
            let ear = |az: f64| GaussianBeam::new(1.0, 0.35, 0.35, 0.0, az, 0.0).unwrap();
            p.receivers = if far {
                vec![
                    Receiver {
                        offset: [1.5, 2.0, -0.5],
                        beam: Some(GaussianBeam::new(1.2, 0.5, 0.3, 0.3, -1.2, 0.2).unwrap()),
                    },
                    Receiver::at_emitter(),
                ]
            } else {
                vec![
                    Receiver {
                        offset: [0.0, 0.01, 0.0],
                        beam: Some(ear(0.5)),
                    },
                    Receiver {
                        offset: [0.0, -0.01, 0.0],
                        beam: Some(ear(-0.5)),
                    },
                ]
            };
            out.push(Sonar::new(p).unwrap());
        }
    }
    out
}

fn leaves_around(n: usize, seed: u64) -> Scene {
    let mut u = crate::test_util::uniforms(seed);
    let (mut c, mut nv, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..n {
        let (z, ph) = (2.0 * u() - 1.0, 2.0 * PI * u());
        let q = (1.0 - z * z).sqrt();
        let range = 0.05 + 14.0 * u();
        c.push([q * ph.cos() * range, q * ph.sin() * range, z * range]);
        let v = [u() - 0.5, u() - 0.5, u() + 0.1];
        nv.push(v.map(|x| x / dot(v, v).sqrt()));
        r.push(0.01 + 0.02 * u());
    }
    Scene::new(c, nv, r).unwrap()
}

#[test]
fn a_receiver_at_the_emitter_decides_as_the_monostatic_test_bit_for_bit() {
    let mut u = crate::test_util::uniforms(3);
    let pose = Pose::new([0.3, -0.2, 1.0], [1.0, 0.4, 0.1], [0.0, 0.0, 1.0]).unwrap();
    for cone in [false, true] {
        let mut p = SonarParams::with_beamwidth(35f64.to_radians()).unwrap();
        if cone {
            p.lobe = LobeRule::Cone {
                half_angle: 50f64.to_radians(),
            };
        }
        let mono = Sonar::new(p.clone()).unwrap();
        p.receivers = vec![Receiver::at_emitter()];
        let heard = Sonar::new(p).unwrap();
        let rxs = place_receivers(&heard, &pose);
        let mut counted = 0;
        for _ in 0..20_000 {
            let x: V3 = std::array::from_fn(|i| pose.position[i] + 24.0 * (u() - 0.5));
            let want = classify(&mono, &pose, x);
            let got = match emitter_side(&heard, &pose, x) {
                Err(r) => Decision::TooClose(r),
                Ok(tx) => match classify_heard(&heard, &pose, &rxs[0], x, &tx) {
                    HeardDecision::In(h) => {
                        assert_eq!(h.range(), h.tx.range);
                        Decision::In(crate::lobe::rule::LeafView {
                            range: h.tx.range,
                            dir: h.tx.dir,
                            az: 0.0,
                            el: 0.0,
                            gain: h.gain,
                        })
                    }
                    HeardDecision::TooClose(r) => Decision::TooClose(r),
                    HeardDecision::Out => Decision::Out,
                },
            };
            match (want, got) {
                (Decision::In(a), Decision::In(b)) => {
                    counted += 1;
                    assert_eq!((a.range, a.dir, a.gain), (b.range, b.dir, b.gain));
                }
                (a, b) => assert_eq!(a, b),
            }
        }
        assert!(counted > 100, "{counted}");
    }
}

#[test]
fn the_receivers_node_test_never_contradicts_the_exact_test_of_a_point_in_the_box() {
    let mut u = crate::test_util::uniforms(11);
    let pose = Pose::new([0.3, -0.2, 1.0], [1.0, 0.4, 0.1], [0.0, 0.0, 1.0]).unwrap();
    let (mut outside, mut inside) = (0, 0);
    for sonar in sonars() {
        let rxs = place_receivers(&sonar, &pose);
        for _ in 0..3000 {
            let (th, ph) = (150f64.to_radians() * u(), 2.0 * PI * u());
            let (st, ct) = th.sin_cos();
            let r = 0.05 * 300f64.powf(u());
            let c: V3 = std::array::from_fn(|i| {
                pose.position[i]
                    + r * (ct * pose.forward[i]
                        + st * (ph.cos() * pose.left[i] + ph.sin() * pose.up[i]))
            });
            let half: V3 = std::array::from_fn(|_| 0.005 * 300f64.powf(u()));
            let (lo, hi) = (sub(c, half), std::array::from_fn(|i| c[i] + half[i]));
            let verdict = test_box_heard(&sonar, &pose, &rxs, lo, hi);
            outside += usize::from(verdict == BoxTest::Outside);
            inside += usize::from(verdict == BoxTest::Inside);
            for k in 0..40 {
                let x: V3 = std::array::from_fn(|i| {
                    let t = if k < 8 { ((k >> i) & 1) as f64 } else { u() };
                    lo[i] + t * (hi[i] - lo[i])
                });
                // counts for some receiver (or is too close: must be found)
                let found = match emitter_side(&sonar, &pose, x) {
                    Err(_) => true,
                    Ok(tx) => rxs.iter().any(|rx| {
                        !matches!(
                            classify_heard(&sonar, &pose, rx, x, &tx),
                            HeardDecision::Out
                        )
                    }),
                };
                match verdict {
                    BoxTest::Outside => assert!(!found, "{x:?} counts in {lo:?}..{hi:?}"),
                    BoxTest::Inside => assert!(found, "{x:?} fails in {lo:?}..{hi:?}"),
                    BoxTest::Partial => {}
                }
            }
        }
    }
    assert!(
        outside > 1000 && inside > 100,
        "outside {outside}, inside {inside}"
    );
}

#[test]
fn the_bvh_finds_each_receivers_members_as_brute_force_does() {
    let scene = leaves_around(30_000, 5);
    let poses = [
        Pose::new([0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap(),
        Pose::new([3.0, -2.0, 1.0], [-0.3, 1.0, 0.2], [0.0, 0.0, 1.0]).unwrap(),
    ];
    for sonar in sonars() {
        for pose in &poses {
            let rxs = place_receivers(&sonar, pose);
            let mut found = 0;
            let run = |search| {
                let c = candidates_heard(&scene, &sonar, pose, &rxs, search);
                heard_members(&scene, &sonar, pose, 0, &rxs, &c).unwrap()
            };
            let (bvh, brute) = (run(Search::Bvh), run(Search::BruteForce));
            assert_eq!(bvh, brute);
            for m in &bvh {
                found += m.len();
            }
            assert!(found > 100, "{found}");
            assert!(
                candidates_heard(&scene, &sonar, pose, &rxs, Search::Bvh).len() < scene.len(),
                "the walk prunes"
            );
        }
    }
}

#[test]
fn a_receiver_at_the_emitter_counts_the_monostatic_members() {
    let scene = leaves_around(20_000, 8);
    let pose = Pose::new([0.5, 0.0, 0.0], [1.0, 0.2, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let mut p = SonarParams::with_beamwidth(50f64.to_radians()).unwrap();
    let mono = Sonar::new(p.clone()).unwrap();
    p.receivers = vec![Receiver::at_emitter()];
    let heard = Sonar::new(p).unwrap();
    let rxs = place_receivers(&heard, &pose);
    let c = candidates_heard(&scene, &heard, &pose, &rxs, Search::Bvh);
    let got = heard_members(&scene, &heard, &pose, 0, &rxs, &c).unwrap();
    let want: Vec<u32> = members(&scene, &mono, &pose, 0, Search::Bvh)
        .unwrap()
        .iter()
        .map(|m| m.index)
        .collect();
    assert_eq!(got[0], want);
}

/// The lanes' verdicts agree with libm's wherever they decide, and their gains, ranges and
/// incidences are within a few ulps of the scalar test's.
#[test]
fn heard_blocks_match_the_libm_test_to_a_few_ulps() {
    use crate::lobe::block::CB;
    use crate::lobe::receivers_block::{emitter_lanes, heard_lanes, EmitterLanes, HeardLanes};
    use crate::physics::bistatic::bisector_incidence;
    let scene = leaves_around(4096, 21);
    let pose = Pose::new([0.2, 0.1, -0.3], [1.0, 0.3, 0.2], [0.0, 0.0, 1.0]).unwrap();
    let (mut decided, mut ins) = (0, 0);
    for sonar in sonars() {
        let rxs = place_receivers(&sonar, &pose);
        let (mut em, mut hl) = (EmitterLanes::default(), HeardLanes::default());
        for first in (0..scene.len() as u32).step_by(CB) {
            let ids: Vec<u32> = (first..first + CB as u32).collect();
            emitter_lanes(&scene, &sonar, &pose, &ids, true, &mut em);
            for rx in &rxs {
                heard_lanes(&sonar, &pose, rx, &em, CB, &mut hl);
                for (k, &i) in ids.iter().enumerate() {
                    let x = scene.centers.get(i as usize);
                    let Ok(tx) = emitter_side(&sonar, &pose, x) else {
                        continue;
                    };
                    assert_eq!(em.r[k], tx.range);
                    let d = classify_heard(&sonar, &pose, rx, x, &tx);
                    match (hl.verdict[k], d) {
                        (2, _) => continue,
                        (1, HeardDecision::In(h)) => {
                            ins += 1;
                            assert_eq!(hl.r_rx[k], h.rx.range);
                            assert!((hl.gain[k] - h.gain).abs() <= 1e-13 * h.gain);
                            let n = scene.normals.get(i as usize);
                            let (b, c, s) = bisector_incidence(h.tx.dir, h.rx.dir, n);
                            assert!((hl.beta[k] - b).abs() <= 1e-14, "{} {b}", hl.beta[k]);
                            assert!((hl.cos_beta[k] - c).abs() <= 1e-15);
                            assert!((hl.sin_beta[k] - s).abs() <= 1e-15);
                        }
                        (0, HeardDecision::Out | HeardDecision::TooClose(_)) => {}
                        (v, d) => panic!("lane verdict {v} against {d:?}"),
                    }
                    decided += 1;
                }
            }
        }
    }
    assert!(decided > 20_000 && ins > 2_000, "{decided} {ins}");
}
