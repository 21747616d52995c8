//! The leaf disks' pass over the light buffer: each occluding leaf is tested against the
//! targets of the cells its disk can reach (rows of cells, contiguous in memory), farther than
//! its nearest point, by the exact test of [`Disk::crossed_by`] written lane by lane, in
//! AVX-512 or AVX2 where the CPU has them and in portable code otherwise. The lanes perform the
//! same f64 operations in the same order as [`Disk::crossed_by`] (no FMA), so they decide every
//! ray alike. The tests are listed first as runs ([`super::runs`]: a disk against up to three
//! steps of eight consecutive targets), and the runs of each length then go in one loop, so
//! that the CPU predicts its branches and overlaps the steps' divisions; each step adds its
//! crossings to the task's counts lane by lane.
use super::buffer::{Buffer, DISKS};
use super::crossing::Disk;
use super::runs::{list_block, step_mask, wide_listing, Run, Runs, LANES, MAX_STEPS};
use crate::math::vec3::{dot, V3};
use crate::scene::Scene;

/// The targets as the occluder loops read them, one entry per position of the buffer's order
/// (cell by cell): ray components, range, own leaf
/// (`u32::MAX` for none) and segment (`u32::MAX` for none).
pub(super) struct Rays {
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<f64>,
    pub range: Vec<f64>,
    pub leaf: Vec<u32>,
    pub segment: Vec<u32>,
}

impl Rays {
    /// `n` inert entries (no ray, no length, no leaf or segment) and [`LANES`] more past them,
    /// which the disk test's last lanes may read: to be filled with `n` rays.
    pub fn inert(n: usize) -> Rays {
        Rays {
            x: vec![0.0; n + LANES],
            y: vec![0.0; n + LANES],
            z: vec![0.0; n + LANES],
            range: vec![f64::NEG_INFINITY; n + LANES],
            leaf: vec![u32::MAX; n + LANES],
            segment: vec![u32::MAX; n + LANES],
        }
    }

    /// The ray `position`.
    #[inline(always)]
    pub fn w(&self, pos: usize) -> V3 {
        [self.x[pos], self.y[pos], self.z[pos]]
    }
}

/// Count, for every target, the disks of the leaves `chunk` (stored indices, at most
/// [`u16::MAX`] + 1) that its ray crosses, into the task's `work` (by position): a block of
/// disks and their runs at a time (independent scalar work that pipelines), then, once
/// [`RUNS_HELD`] runs are held and at the end, the tests and counts in flat loops over the
/// runs of one, two and three steps, whose branches the CPU predicts.
pub(super) fn leaf_chunk(
    scene: &Scene,
    origin: V3,
    buf: &Buffer,
    rays: &Rays,
    chunk: &[u32],
    work: &mut Work,
) {
    assert!(
        chunk.len() <= usize::from(u16::MAX) + 1,
        "a chunk's disks are u16"
    );
    work.disks.clear();
    work.clear_runs();
    for block in chunk.chunks(DISKS) {
        work.push_block(scene, origin, buf, block);
        if work.runs.iter().map(Vec::len).sum::<usize>() >= RUNS_HELD {
            work.test(rays);
        }
    }
    work.test(rays);
}

/// Runs held before they are tested (a disk too near the sonar to bin has a run for every
/// [`MAX_STEPS`] steps of targets).
const RUNS_HELD: usize = 1 << 15;

/// One task's working space: its chunk's disks and their runs, its counts of crossings by
/// position (padded by [`LANES`]; the tasks' counts are added at the end, so that the sums
/// are the same for any split of the work), and whether it lists runs in AVX-512.
pub(super) struct Work {
    disks: Vec<Occluder>,
    runs: Runs,
    pub crossings: Vec<u32>,
    wide: bool,
    kernel: Kernel,
}

impl Work {
    /// Working space for `n` targets.
    pub fn new(n: usize) -> Work {
        Work {
            disks: Vec::new(),
            runs: Default::default(),
            crossings: vec![0; n + LANES],
            wide: wide_listing(),
            kernel: Kernel::fastest(),
        }
    }

    /// The disks of the leaves `block` (stored indices, at most [`DISKS`]) and the runs of
    /// their tests over the positions of the cells they reach.
    fn push_block(&mut self, scene: &Scene, origin: V3, buf: &Buffer, block: &[u32]) {
        let mut v = [[0.0f64; DISKS]; 3];
        let mut nrm = [[0.0f64; DISKS]; 3];
        let mut a = [0.0f64; DISKS];
        let first = self.disks.len();
        for (k, &j) in block.iter().enumerate() {
            let c = scene.centers.get(j as usize);
            let vk = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
            (v[0][k], v[1][k], v[2][k]) = (vk[0], vk[1], vk[2]);
            a[k] = scene.radii[j as usize];
            let nk = scene.normals.get(j as usize);
            (nrm[0][k], nrm[1][k], nrm[2][k]) = (nk[0], nk[1], nk[2]);
            self.disks
                .push(Occluder::new(Disk::new(vk, nk, a[k]), a[k], j));
        }
        let b = buf.disk_boxes(&v, &nrm, &a);
        list_block(
            buf,
            &b,
            block.len(),
            first as u16,
            &v,
            &a,
            &mut self.runs,
            self.wide,
        );
    }

    /// Test and count the runs held, and drop them.
    fn test(&mut self, rays: &Rays) {
        test_all_runs(
            self.kernel,
            &self.disks,
            &self.runs,
            rays,
            &mut self.crossings,
        );
        self.clear_runs();
    }

    fn clear_runs(&mut self) {
        self.runs.iter_mut().for_each(Vec::clear);
    }
}

/// An occluding leaf as the steps broadcast it: its disk's centre `v` (relative to the
/// sonar), unit normal `n`, `n . v` and `a^2`, the range below which no ray can cross the
/// disk, and its leaf's stored index.
#[derive(Clone, Copy, Debug)]
struct Occluder {
    v: V3,
    n: V3,
    nv: f64,
    a2: f64,
    near: f64,
    leaf: u32,
}

impl Occluder {
    fn new(d: Disk, radius: f64, leaf: u32) -> Occluder {
        Occluder {
            v: d.v,
            n: d.n,
            nv: d.nv,
            a2: d.a2,
            // (no crossing of a ray shorter than the disk's nearest distance)
            near: (dot(d.v, d.v).sqrt() - radius) * (1.0 - 1e-12),
            leaf,
        }
    }

    /// The disk as the scalar test takes it.
    #[cfg(test)]
    fn disk(&self) -> Disk {
        Disk {
            v: self.v,
            n: self.n,
            nv: self.nv,
            a2: self.a2,
        }
    }
}

/// The lanes that test the runs: portable code, AVX2, or AVX-512.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kernel {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

impl Kernel {
    /// The best this CPU has.
    pub fn fastest() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
            {
                return Kernel::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Kernel::Avx2;
            }
        }
        Kernel::Portable
    }
}

/// Test and count the runs of every number of steps with `kernel`, which the CPU must have.
fn test_all_runs(
    kernel: Kernel,
    disks: &[Occluder],
    runs: &Runs,
    rays: &Rays,
    crossings: &mut [u32],
) {
    /// Each number of steps' runs by `test::<S>`.
    macro_rules! by_steps {
        ($test:ident) => {{
            $test::<1>(disks, &runs[1], rays, crossings);
            $test::<2>(disks, &runs[2], rays, crossings);
            $test::<3>(disks, &runs[3], rays, crossings);
        }};
    }
    const _: () = assert!(MAX_STEPS == 3, "one call per number of steps");
    match kernel {
        Kernel::Portable => by_steps!(test_runs),
        // SAFETY: the caller's CPU has AVX2.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { by_steps!(test_runs_avx2) },
        // SAFETY: the caller's CPU has AVX-512F and VL.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { by_steps!(test_runs_avx512) },
    }
}

/// The exact disk test of every run of `S` steps, [`LANES`] rays at a time, in portable code
/// (the same f64 operations, in the same order, as [`Disk::crossed_by`]); each ray crossed,
/// unless it is the occluding leaf's own, counts one in `crossings` (by position).
fn test_runs<const S: usize>(disks: &[Occluder], runs: &[Run], rays: &Rays, crossings: &mut [u32]) {
    let lanes = |a: &[f64], at: usize| -> [f64; LANES] {
        a[at..at + LANES].try_into().expect("padded rays")
    };
    for r in runs {
        let Occluder {
            v,
            n,
            nv,
            a2,
            near,
            leaf,
        } = disks[r.occ as usize];
        for step in 0..S {
            let (at, mask) = (r.at as usize + step * LANES, step_mask(r.len, step));
            let (x, y, z, range) = (
                lanes(&rays.x, at),
                lanes(&rays.y, at),
                lanes(&rays.z, at),
                lanes(&rays.range, at),
            );
            for k in 0..LANES {
                let (wx, wy, wz) = (x[k], y[k], z[k]);
                let d = n[0] * wx + n[1] * wy + n[2] * wz;
                let t = nv / d;
                let (q0, q1, q2) = (t * wx - v[0], t * wy - v[1], t * wz - v[2]);
                let qq = q0 * q0 + q1 * q1 + q2 * q2;
                let yes = (range[k] > near) & (d != 0.0) & (t > 0.0) & (t < 1.0) & (qq <= a2);
                let live = mask >> k & 1 == 1 && rays.leaf[at + k] != leaf;
                crossings[at + k] += u32::from(yes & live);
            }
        }
    }
}

/// [`test_runs`] in AVX2: two registers of four lanes per step, each operation the IEEE f64
/// operation of the portable code (no FMA), and the comparisons' NaN cases alike (`d != 0` is
/// true for NaN, the others false).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn test_runs_avx2<const S: usize>(
    disks: &[Occluder],
    runs: &[Run],
    rays: &Rays,
    crossings: &mut [u32],
) {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm256_setzero_pd(), _mm256_set1_pd(1.0));
    assert!(crossings.len() >= rays.x.len());
    for r in runs {
        let o = &disks[r.occ as usize];
        assert!(r.at as usize + S * LANES <= rays.x.len());
        let b = _mm256_set1_pd;
        let (n0, n1, n2) = (b(o.n[0]), b(o.n[1]), b(o.n[2]));
        let (v0, v1, v2) = (b(o.v[0]), b(o.v[1]), b(o.v[2]));
        let (nv, a2, near) = (b(o.nv), b(o.a2), b(o.near));
        let half = |at: usize| -> i32 {
            // SAFETY: `at + 4 <= len` (asserted for the run's steps).
            let (x, y, z, range) = unsafe {
                (
                    _mm256_loadu_pd(rays.x.as_ptr().add(at)),
                    _mm256_loadu_pd(rays.y.as_ptr().add(at)),
                    _mm256_loadu_pd(rays.z.as_ptr().add(at)),
                    _mm256_loadu_pd(rays.range.as_ptr().add(at)),
                )
            };
            let d = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(n0, x), _mm256_mul_pd(n1, y)),
                _mm256_mul_pd(n2, z),
            );
            let t = _mm256_div_pd(nv, d);
            let q0 = _mm256_sub_pd(_mm256_mul_pd(t, x), v0);
            let q1 = _mm256_sub_pd(_mm256_mul_pd(t, y), v1);
            let q2 = _mm256_sub_pd(_mm256_mul_pd(t, z), v2);
            let qq = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(q0, q0), _mm256_mul_pd(q1, q1)),
                _mm256_mul_pd(q2, q2),
            );
            let yes = _mm256_and_pd(
                _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(range, near),
                    _mm256_cmp_pd::<_CMP_NEQ_UQ>(d, zero),
                ),
                _mm256_and_pd(
                    _mm256_and_pd(
                        _mm256_cmp_pd::<_CMP_GT_OQ>(t, zero),
                        _mm256_cmp_pd::<_CMP_LT_OQ>(t, one),
                    ),
                    _mm256_cmp_pd::<_CMP_LE_OQ>(qq, a2),
                ),
            );
            _mm256_movemask_pd(yes)
        };
        for step in 0..S {
            let at = r.at as usize + step * LANES;
            let mut bits = (half(at) | (half(at + 4) << 4)) as u32 & step_mask(r.len, step) as u32;
            while bits != 0 {
                let pos = at + bits.trailing_zeros() as usize;
                crossings[pos] += u32::from(rays.leaf[pos] != o.leaf);
                bits &= bits - 1;
            }
        }
    }
}

/// [`test_runs`] in AVX-512: one register of eight lanes per step, each operation the IEEE f64
/// operation of the portable code (no FMA), and the comparisons' NaN cases alike; the counts
/// are added lane by lane under a mask, without a branch.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl")]
unsafe fn test_runs_avx512<const S: usize>(
    disks: &[Occluder],
    runs: &[Run],
    rays: &Rays,
    crossings: &mut [u32],
) {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm512_setzero_pd(), _mm512_set1_pd(1.0));
    let ones = _mm256_set1_epi32(1);
    assert!(crossings.len() >= rays.x.len() && rays.leaf.len() == rays.x.len());
    for r in runs {
        let o = &disks[r.occ as usize];
        assert!(r.at as usize + S * LANES <= rays.x.len());
        let b = _mm512_set1_pd;
        let (n0, n1, n2) = (b(o.n[0]), b(o.n[1]), b(o.n[2]));
        let (v0, v1, v2) = (b(o.v[0]), b(o.v[1]), b(o.v[2]));
        let (nv, a2, near) = (b(o.nv), b(o.a2), b(o.near));
        let own = _mm256_set1_epi32(o.leaf as i32);
        for step in 0..S {
            let at = r.at as usize + step * LANES;
            // SAFETY: `at + LANES` is within the rays and the counts (asserted).
            unsafe {
                let (x, y, z, range) = (
                    _mm512_loadu_pd(rays.x.as_ptr().add(at)),
                    _mm512_loadu_pd(rays.y.as_ptr().add(at)),
                    _mm512_loadu_pd(rays.z.as_ptr().add(at)),
                    _mm512_loadu_pd(rays.range.as_ptr().add(at)),
                );
                let d = _mm512_add_pd(
                    _mm512_add_pd(_mm512_mul_pd(n0, x), _mm512_mul_pd(n1, y)),
                    _mm512_mul_pd(n2, z),
                );
                let t = _mm512_div_pd(nv, d);
                let q0 = _mm512_sub_pd(_mm512_mul_pd(t, x), v0);
                let q1 = _mm512_sub_pd(_mm512_mul_pd(t, y), v1);
                let q2 = _mm512_sub_pd(_mm512_mul_pd(t, z), v2);
                let qq = _mm512_add_pd(
                    _mm512_add_pd(_mm512_mul_pd(q0, q0), _mm512_mul_pd(q1, q1)),
                    _mm512_mul_pd(q2, q2),
                );
                let m = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(range, near);
                let m = _mm512_mask_cmp_pd_mask::<_CMP_NEQ_UQ>(m, d, zero);
                let m = _mm512_mask_cmp_pd_mask::<_CMP_GT_OQ>(m, t, zero);
                let m = _mm512_mask_cmp_pd_mask::<_CMP_LT_OQ>(m, t, one);
                let m = _mm512_mask_cmp_pd_mask::<_CMP_LE_OQ>(m, qq, a2);
                let leaves = _mm256_loadu_si256(rays.leaf.as_ptr().add(at) as *const __m256i);
                let m = m & step_mask(r.len, step) & !_mm256_cmpeq_epi32_mask(leaves, own);
                let p = crossings.as_mut_ptr().add(at) as *mut __m256i;
                let cur = _mm256_loadu_si256(p);
                _mm256_storeu_si256(p, _mm256_mask_add_epi32(cur, m, cur, ones));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::runs::{push_run, MAX_STEPS};
    use super::*;
    use crate::test_util::uniforms;

    /// Rays (padded) and disks with hard cases: rays through a disk's rim, rays in a disk's
    /// plane, rays shorter than a disk's nearest point, and a disk's own leaf's ray.
    fn hard_cases() -> (Vec<Occluder>, Runs, Rays) {
        let mut u = uniforms(5);
        let mut w: Vec<(V3, u32)> = Vec::new();
        let mut disks = Vec::new();
        for j in 0..40u32 {
            let v = [2.0 + 3.0 * u(), u() - 0.5, u() - 0.5];
            let n = {
                let n = [u() - 0.5, u() - 0.5, u() - 0.5];
                let l = dot(n, n).sqrt();
                n.map(|x| x / l)
            };
            let a = 0.01 + 0.05 * u();
            // a unit vector in the disk's plane
            let e = {
                let p = [n[1], -n[0], 0.0];
                let l = dot(p, p).sqrt();
                p.map(|x| x / l)
            };
            for k in 0..13 {
                let s = match k {
                    0..=7 => 1.0 + 2.0 * u(), // through the rim, beyond the disk
                    8 => 1.0,                 // ending on the rim
                    9 => 0.99,                // ending before the rim
                    _ => 1.0 + u(),
                };
                let rim = [v[0] + a * e[0], v[1] + a * e[1], v[2] + a * e[2]];
                let target = match k {
                    10 => [v[0] + 3.0 * e[0], v[1] + 3.0 * e[1], v[2] + 3.0 * e[2]], // in plane
                    11 => v.map(|x| 1.5 * x), // straight through the centre
                    12 => v.map(|x| 0.5 * x), // short of the disk's nearest point
                    _ => rim.map(|x| s * x),
                };
                w.push((target, if k == 11 && j % 2 == 0 { j } else { u32::MAX }));
            }
            disks.push((Disk::new(v, n, a), a, j));
        }
        // Exact decisions in binary: the disk at (2, 0, 0) facing x with radius 0.5; a ray
        // meeting its rim exactly (t = 1/2, |q|^2 = a^2, crossed), one ending exactly on its
        // plane (t = 1, not crossed) and one just outside its rim.
        let (v, n, a) = ([2.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.5);
        disks.push((Disk::new(v, n, a), a, 40));
        for target in [[4.0, 1.0, 0.0], [2.0, 0.25, 0.0], [4.0, 1.0 + 1e-15, 0.0]] {
            w.push((target, u32::MAX));
        }
        let m = w.len();
        let mut rays = Rays::inert(m);
        for (i, (p, leaf)) in w.iter().enumerate() {
            (rays.x[i], rays.y[i], rays.z[i]) = (p[0], p[1], p[2]);
            rays.range[i] = dot(*p, *p).sqrt();
            rays.leaf[i] = *leaf;
        }
        // every disk against runs of every length and alignment, the whole list included
        let mut out = Vec::new();
        let mut runs: Runs = Default::default();
        for (j, &(d, a, leaf)) in disks.iter().enumerate() {
            out.push(Occluder::new(d, a, leaf));
            let lo = (7 * j) % m;
            for (lo, hi) in [(lo, (lo + 1 + j % 29).min(m)), (0, m)] {
                push_run(&mut runs, j as u16, lo as u32, hi as u32);
            }
        }
        assert!(
            (1..=MAX_STEPS).all(|s| !runs[s].is_empty()),
            "runs of every length"
        );
        (out, runs, rays)
    }

    /// The crossings that `test` counts.
    fn counts(test: impl FnOnce(&mut [u32])) -> Vec<u32> {
        let (_, _, rays) = hard_cases();
        let mut c = vec![0u32; rays.x.len()];
        test(&mut c);
        c
    }

    /// The counts of the runs' tests with `kernel`.
    fn counts_with(kernel: Kernel, disks: &[Occluder], runs: &Runs, rays: &Rays) -> Vec<u32> {
        counts(|c| test_all_runs(kernel, disks, runs, rays, c))
    }

    #[test]
    fn the_lanes_count_what_the_scalar_disk_test_decides() {
        let (disks, runs, rays) = hard_cases();
        let got = counts_with(Kernel::Portable, &disks, &runs, &rays);
        let mut want = vec![0u32; rays.x.len()];
        for r in runs.iter().skip(1).flatten() {
            let o = &disks[r.occ as usize];
            let (lo, len) = (r.at as usize, r.len as usize);
            for (pos, count) in want.iter_mut().enumerate().skip(lo).take(len) {
                let crossed = rays.range[pos] > o.near
                    && rays.leaf[pos] != o.leaf
                    && o.disk().crossed_by(rays.w(pos));
                *count += u32::from(crossed);
            }
        }
        assert!(want.iter().sum::<u32>() > 100, "the cases cross disks");
        assert_eq!(got, want);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx512_lanes_count_what_the_portable_lanes_count() {
        if Kernel::fastest() != Kernel::Avx512 {
            return;
        }
        let (disks, runs, rays) = hard_cases();
        assert_eq!(
            counts_with(Kernel::Avx512, &disks, &runs, &rays),
            counts_with(Kernel::Portable, &disks, &runs, &rays)
        );
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_lanes_count_what_the_portable_lanes_count() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let (disks, runs, rays) = hard_cases();
        assert_eq!(
            counts_with(Kernel::Avx2, &disks, &runs, &rays),
            counts_with(Kernel::Portable, &disks, &runs, &rays)
        );
    }
}
