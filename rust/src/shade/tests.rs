//! The light buffer's sights against brute force: every occluder tested against every ray.
use super::crossing::Disk;
use super::*;
use crate::scene::Branches;
use crate::test_util::{uniforms, unit_vector};

/// Every leaf and segment against every target, by the same exact tests.
fn brute_force(scene: &Scene, origin: V3, targets: &[Target], branches_block: bool) -> Vec<Sight> {
    let rel = |c: V3| [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
    targets
        .iter()
        .map(|t| {
            let w = rel(t.point());
            let mut s = Sight::default();
            for j in 0..scene.len() {
                if matches!(t, Target::Leaf { leaf, .. } if *leaf as usize == j) {
                    continue;
                }
                let d = Disk::new(
                    rel(scene.centers.get(j)),
                    scene.normals.get(j),
                    scene.radii[j],
                );
                s.crossings += u32::from(d.crossed_by(w));
            }
            if branches_block {
                let br = &scene.branches;
                for j in 0..br.len() {
                    if let Target::Piece { segment, .. } = t {
                        if *segment as usize == j
                            || br.joined_to(*segment as usize).contains(&(j as u32))
                        {
                            continue;
                        }
                    }
                    let c =
                        Cylinder::new(rel(br.starts[j]), br.axes[j], br.lengths[j], br.radii[j]);
                    s.blocked |= c.crossed_by(w);
                }
            }
            s
        })
        .collect()
}

/// `n` leaves in clumps in front of the origin, radii 5 mm - 5 cm.
fn clumped(n: usize, seed: u64, branches: Branches) -> Scene {
    let mut u = uniforms(seed);
    let clumps: Vec<V3> = (0..8)
        .map(|_| [1.0 + 6.0 * u(), -2.0 + 4.0 * u(), -2.0 + 4.0 * u()])
        .collect();
    let (mut c, mut nv, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..n {
        let k = clumps[i % clumps.len()];
        c.push([
            k[0] + 0.6 * (u() - 0.5),
            k[1] + 0.6 * (u() - 0.5),
            k[2] + 0.6 * (u() - 0.5),
        ]);
        nv.push(unit_vector(&mut u));
        r.push(0.005 * 10f64.powf(u()));
    }
    Scene::with_branches(c, nv, r, branches).unwrap()
}

fn leaf_targets(scene: &Scene, every: usize) -> Vec<Target> {
    (0..scene.len())
        .step_by(every)
        .map(|i| Target::Leaf {
            point: scene.centers.get(i),
            leaf: i as u32,
        })
        .collect()
}

#[test]
fn leaf_crossings_equal_brute_force_in_clumped_scenes() {
    for (seed, origin) in [
        (1, [0.0, 0.0, 0.0]),
        (2, [3.0, 0.5, -0.2]),
        (3, [9.0, 3.0, 2.0]),
    ] {
        let scene = clumped(6000, seed, Branches::default());
        let targets = leaf_targets(&scene, 3);
        let got = cast(&scene, origin, &targets, false);
        let want = brute_force(&scene, origin, &targets, false);
        assert_eq!(got, want, "seed {seed}");
        assert!(
            got.iter().any(|s| s.crossings > 1),
            "seed {seed}: no shading to test"
        );
    }
}

#[test]
fn a_row_of_leaves_each_behind_the_last_counts_every_one_in_front() {
    let n = 3000;
    let c: Vec<V3> = (0..n).map(|i| [1.0 + 0.003 * i as f64, 0.0, 0.0]).collect();
    let scene = Scene::new(c, vec![[1.0, 0.0, 0.0]; n], vec![0.01; n]).unwrap();
    let targets = leaf_targets(&scene, 1);
    let got = cast(&scene, [0.0; 3], &targets, false);
    for (t, s) in targets.iter().zip(&got) {
        let Target::Leaf { leaf, .. } = t else {
            unreachable!()
        };
        // stored order may differ from the row's: count the leaves nearer than this one
        let x = scene.centers.get(*leaf as usize)[0];
        let nearer = (0..n).filter(|&j| scene.centers.get(j)[0] < x).count() as u32;
        assert_eq!(s.crossings, nearer);
    }
}

#[test]
fn coincident_leaves_do_not_shade_each_other_and_a_leaf_behind_one_is_shaded() {
    let c = vec![
        [2.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [3.0, 0.0, 0.0],
        [2.0, 0.05, 0.0],
    ];
    let n = vec![
        [1.0, 0.0, 0.0],
        [0.6, 0.8, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let scene = Scene::new(c, n, vec![0.02, 0.02, 0.02, 0.02]).unwrap();
    let targets = leaf_targets(&scene, 1);
    let got = cast(&scene, [0.0; 3], &targets, false);
    assert_eq!(got, brute_force(&scene, [0.0; 3], &targets, false));
    let by_x = |x: f64, y: f64| {
        let i = (0..4)
            .find(|&i| scene.centers.get(i) == [x, y, 0.0])
            .unwrap();
        got[targets.iter().position(|t| *t == targets[i]).unwrap()].crossings
    };
    assert_eq!(by_x(3.0, 0.0), 2);
    assert_eq!(by_x(2.0, 0.05), 0);
}

#[test]
fn branch_blocking_equals_brute_force_and_spares_a_pieces_own_skeleton() {
    let mut u = uniforms(7);
    let (mut s, mut e, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..150 {
        let a = [1.0 + 6.0 * u(), -2.0 + 4.0 * u(), -2.0 + 4.0 * u()];
        let d = unit_vector(&mut u);
        let l = 0.05 + 0.8 * u();
        s.push(a);
        e.push([a[0] + l * d[0], a[1] + l * d[1], a[2] + l * d[2]]);
        r.push(0.003 + 0.1 * u() * u());
    }
    // a joined pair: a trunk and a thinner piece continuing it
    s.push([4.0, 0.0, -2.0]);
    e.push([4.0, 0.0, 0.0]);
    r.push(0.15);
    s.push([4.0, 0.0, 0.0]);
    e.push([4.0, 0.0, 2.0]);
    r.push(0.1);
    let branches = Branches::new(s, e, r).unwrap();
    let scene = clumped(3000, 8, branches);
    let br = &scene.branches;
    let mut targets = leaf_targets(&scene, 2);
    for j in 0..br.len() {
        let m = br.mids[j];
        targets.push(Target::Piece {
            point: [m[0] - br.radii[j], m[1], m[2]],
            segment: j as u32,
        });
    }
    // a piece of the thin part near the joint, lit from below: the trunk does not block it
    targets.push(Target::Piece {
        point: [3.9, 0.0, 0.01],
        segment: (br.len() - 1) as u32,
    });
    for origin in [[0.0, 0.0, 0.0], [0.0, 0.0, -0.5]] {
        let got = cast(&scene, origin, &targets, true);
        assert_eq!(got, brute_force(&scene, origin, &targets, true));
        assert!(got.iter().filter(|s| s.blocked).count() > 10);
        assert!(!got.last().unwrap().blocked);
    }
    let open = cast(&scene, [0.0; 3], &targets, false);
    assert!(open.iter().all(|s| !s.blocked));
}

#[test]
fn branch_blocking_of_a_narrow_cone_of_rays_equals_brute_force_among_many_segments() {
    // Targets in a 6 degree cone along +x among segments all round the sonar, long ones
    // across the cone's edge among them: the segments found on their BVH block what every
    // segment tested one by one blocks.
    let mut u = uniforms(12);
    let (mut s, mut e, mut r) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..4000 {
        let a = [-10.0 + 20.0 * u(), -10.0 + 20.0 * u(), -10.0 + 20.0 * u()];
        let d = unit_vector(&mut u);
        let l = if k % 10 == 0 {
            2.0 + 6.0 * u()
        } else {
            0.05 + 0.6 * u()
        };
        s.push(a);
        e.push([a[0] + l * d[0], a[1] + l * d[1], a[2] + l * d[2]]);
        r.push(0.005 + 0.08 * u() * u());
    }
    let branches = Branches::new(s, e, r).unwrap();
    let scene = Scene::with_branches(Vec::new(), Vec::new(), Vec::new(), branches).unwrap();
    let half = 6f64.to_radians();
    let targets: Vec<Target> = (0..3000)
        .map(|_| {
            let (th, ph, range) = (
                half * u().sqrt(),
                std::f64::consts::TAU * u(),
                1.0 + 9.0 * u(),
            );
            // (points as leaf targets of no stored leaf: no segment is their own)
            Target::Leaf {
                point: [
                    range * th.cos(),
                    range * th.sin() * ph.cos(),
                    range * th.sin() * ph.sin(),
                ],
                leaf: u32::MAX,
            }
        })
        .collect();
    let got = cast(&scene, [0.0; 3], &targets, true);
    assert_eq!(got, brute_force(&scene, [0.0; 3], &targets, true));
    assert!(got.iter().filter(|s| s.blocked).count() > 100);
}

#[test]
fn sights_are_the_same_for_one_and_two_threads() {
    let scene = clumped(20_000, 4, Branches::default());
    let targets = leaf_targets(&scene, 1);
    let a = cast(&scene, [0.0, 0.1, 0.0], &targets, false);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let b = pool.install(|| cast(&scene, [0.0, 0.1, 0.0], &targets, false));
    assert_eq!(a, b);
}
