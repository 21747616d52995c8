//! The leaf disks' pass over the light buffer: each occluding leaf is tested against the
//! targets of the cells its disk can reach (rows of cells, contiguous in memory), farther than
//! its nearest point, by the exact test of [`Disk::crossed_by`] written lane by lane, in
//! AVX-512 or AVX2 where the CPU has them and in portable code otherwise. The lanes perform the
//! same f64 operations in the same order as [`Disk::crossed_by`] (no FMA), so they decide every
//! ray alike.
use super::buffer::{Buffer, DISKS};
use super::crossing::Disk;
use crate::math::vec3::{dot, V3};
use crate::scene::Scene;
use std::sync::atomic::{AtomicU32, Ordering};

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

/// Lanes of one step of the disk test. [`Rays`] holds this many inert entries past its last
/// ray, so that every step reads whole lanes and vectorises, short rows included.
pub(super) const LANES: usize = 8;

/// Count, for every target, the disks of the leaves `chunk` (stored indices) that its ray
/// crosses, into `crossings` (by position). The chunk's disks and their runs of positions come
/// first (independent scalar work that pipelines), then the tests, then the count.
pub(super) fn leaf_chunk(
    scene: &Scene,
    origin: V3,
    buf: &Buffer,
    rays: &Rays,
    chunk: &[u32],
    crossings: &[AtomicU32],
) {
    let (disks, runs) = occluders_of(scene, origin, buf, chunk);
    let mut hits = Hits::new(rays, crossings, HITS_HELD);
    test_chunk_fastest(&disks, &runs, rays, &mut hits);
    hits.count();
}

/// Steps with a hit that [`Hits`] holds before it counts them.
const HITS_HELD: usize = 4096;

/// The disks of the leaves `chunk` (stored indices) and their runs of positions in the buffer.
fn occluders_of(
    scene: &Scene,
    origin: V3,
    buf: &Buffer,
    chunk: &[u32],
) -> (Vec<Occluder>, Vec<(u32, u32)>) {
    let mut disks: Vec<Occluder> = Vec::with_capacity(chunk.len());
    let mut runs: Vec<(u32, u32)> = Vec::with_capacity(4 * chunk.len());
    for block in chunk.chunks(DISKS) {
        let mut v = [[0.0f64; DISKS]; 3];
        let mut nrm = [[0.0f64; DISKS]; 3];
        let mut a = [0.0f64; DISKS];
        for (k, &j) in block.iter().enumerate() {
            let c = scene.centers.get(j as usize);
            let vk = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
            (v[0][k], v[1][k], v[2][k]) = (vk[0], vk[1], vk[2]);
            a[k] = scene.radii[j as usize];
            let nk = scene.normals.get(j as usize);
            (nrm[0][k], nrm[1][k], nrm[2][k]) = (nk[0], nk[1], nk[2]);
            disks.push(Occluder {
                disk: Disk::new(vk, nk, a[k]),
                // (no crossing of a ray shorter than the disk's nearest distance)
                near: (dot(vk, vk).sqrt() - a[k]) * (1.0 - 1e-12),
                leaf: j,
                runs_end: 0,
            });
        }
        let live = block.len();
        let mut ends = [runs.len() as u32; DISKS];
        // (a disk too near the sonar to bin visits every cell: every target is tested)
        buf.disks_cells(&v, &nrm, &a, |k, c0, c1| {
            let (lo, hi) = (buf.start[c0], buf.start[c1]);
            if k < live && lo < hi {
                runs.push((lo, hi));
                ends[k] = runs.len() as u32;
            }
        });
        let first = disks.len() - live;
        let mut end = 0;
        for (k, d) in disks[first..].iter_mut().enumerate() {
            end = end.max(ends[k]);
            d.runs_end = end;
        }
    }
    (disks, runs)
}

/// [`test_chunk`] in the widest lanes the CPU has.
fn test_chunk_fastest(disks: &[Occluder], runs: &[(u32, u32)], rays: &Rays, hits: &mut Hits) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU has AVX-512F.
        unsafe { test_chunk_avx512(disks, runs, rays, hits) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2.
        unsafe { test_chunk_avx2(disks, runs, rays, hits) };
        return;
    }
    test_chunk(disks, runs, rays, hits);
}

/// The steps of a chunk's tests that hit: each step's first position, its lanes that hit (the
/// padding past its run's end cleared) and the occluding leaf. The tests append every step
/// and keep only those with a hit, without a branch, so that the divisions of successive
/// steps overlap; the hits are counted into `crossings` (by position) when the buffer is full
/// and at the end.
struct Hits<'a> {
    at: Vec<u32>,
    own: Vec<u32>,
    bits: Vec<u8>,
    len: usize,
    rays: &'a Rays,
    crossings: &'a [AtomicU32],
}

impl<'a> Hits<'a> {
    /// Room for `held` steps with a hit (at least one).
    fn new(rays: &'a Rays, crossings: &'a [AtomicU32], held: usize) -> Hits<'a> {
        // (one slot more: each append writes past the kept steps)
        let room = held.max(1) + 1;
        Hits {
            at: vec![0; room],
            own: vec![0; room],
            bits: vec![0; room],
            len: 0,
            rays,
            crossings,
        }
    }

    /// Append the step at `at` of a run ending at `hi`, kept when a lane hits.
    #[inline(always)]
    fn push(&mut self, mut bits: u32, at: usize, hi: usize, own: u32) {
        let live = hi - at;
        if live < LANES {
            bits &= (1u32 << live) - 1;
        }
        let k = self.len;
        self.at[k] = at as u32;
        self.own[k] = own;
        self.bits[k] = bits as u8;
        self.len += usize::from(bits != 0);
        if self.len + 1 == self.at.len() {
            self.count();
        }
    }

    /// Count each kept hit into `crossings`, unless the ray is the occluding leaf's own, and
    /// empty the buffer.
    fn count(&mut self) {
        for k in 0..self.len {
            let (at, own) = (self.at[k] as usize, self.own[k]);
            let mut bits = self.bits[k] as u32;
            while bits != 0 {
                let pos = at + bits.trailing_zeros() as usize;
                if self.rays.leaf[pos] != own {
                    self.crossings[pos].fetch_add(1, Ordering::Relaxed);
                }
                bits &= bits - 1;
            }
        }
        self.len = 0;
    }
}

/// An occluding leaf as the tests take it: its disk, the range below which no ray can cross
/// it, its stored index, and the end of its runs in the chunk's list.
struct Occluder {
    disk: Disk,
    near: f64,
    leaf: u32,
    runs_end: u32,
}

/// The exact disk test of every occluder against the rays of its runs, [`LANES`] at a time,
/// in portable code (the same f64 operations, in the same order, as [`Disk::crossed_by`]).
fn test_chunk(disks: &[Occluder], runs: &[(u32, u32)], rays: &Rays, hits: &mut Hits) {
    let lanes = |a: &[f64], at: usize| -> [f64; LANES] {
        a[at..at + LANES].try_into().expect("padded rays")
    };
    let mut first = 0usize;
    for o in disks {
        let Disk { v, n, nv, a2 } = o.disk;
        for &(lo, hi) in &runs[first..o.runs_end as usize] {
            let (mut at, hi) = (lo as usize, hi as usize);
            while at < hi {
                let (x, y, z, range) = (
                    lanes(&rays.x, at),
                    lanes(&rays.y, at),
                    lanes(&rays.z, at),
                    lanes(&rays.range, at),
                );
                let mut bits = 0u32;
                for k in 0..LANES {
                    let (wx, wy, wz) = (x[k], y[k], z[k]);
                    let d = n[0] * wx + n[1] * wy + n[2] * wz;
                    let t = nv / d;
                    let (q0, q1, q2) = (t * wx - v[0], t * wy - v[1], t * wz - v[2]);
                    let qq = q0 * q0 + q1 * q1 + q2 * q2;
                    let yes = (range[k] > o.near) & (d != 0.0) & (t > 0.0) & (t < 1.0) & (qq <= a2);
                    bits |= u32::from(yes) << k;
                }
                hits.push(bits, at, hi, o.leaf);
                at += LANES;
            }
        }
        first = o.runs_end as usize;
    }
}

/// [`test_chunk`] in AVX2: two registers of four lanes per step, each operation the IEEE f64
/// operation of the portable code (no FMA), and the comparisons' NaN cases alike (`d != 0` is
/// true for NaN, the others false).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn test_chunk_avx2(disks: &[Occluder], runs: &[(u32, u32)], rays: &Rays, hits: &mut Hits) {
    use std::arch::x86_64::*;
    let mut first = 0usize;
    for o in disks {
        let Disk { v, n, nv, a2 } = o.disk;
        let (n0, n1, n2) = (
            _mm256_set1_pd(n[0]),
            _mm256_set1_pd(n[1]),
            _mm256_set1_pd(n[2]),
        );
        let (v0, v1, v2) = (
            _mm256_set1_pd(v[0]),
            _mm256_set1_pd(v[1]),
            _mm256_set1_pd(v[2]),
        );
        let (nv, a2, near) = (
            _mm256_set1_pd(nv),
            _mm256_set1_pd(a2),
            _mm256_set1_pd(o.near),
        );
        let (zero, one) = (_mm256_setzero_pd(), _mm256_set1_pd(1.0));
        let half = |at: usize| -> i32 {
            // SAFETY: `at + 4 <= len` for every step: the rays are padded by LANES.
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
        for &(lo, hi) in &runs[first..o.runs_end as usize] {
            assert!(hi as usize + LANES <= rays.x.len());
            let (mut at, hi) = (lo as usize, hi as usize);
            while at < hi {
                let bits = (half(at) | (half(at + 4) << 4)) as u32;
                hits.push(bits, at, hi, o.leaf);
                at += LANES;
            }
        }
        first = o.runs_end as usize;
    }
}

/// [`test_chunk`] in AVX-512: one register of eight lanes per step, each operation the IEEE
/// f64 operation of the portable code (no FMA), and the comparisons' NaN cases alike.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn test_chunk_avx512(disks: &[Occluder], runs: &[(u32, u32)], rays: &Rays, hits: &mut Hits) {
    use std::arch::x86_64::*;
    let mut first = 0usize;
    for o in disks {
        let Disk { v, n, nv, a2 } = o.disk;
        let (n0, n1, n2) = (
            _mm512_set1_pd(n[0]),
            _mm512_set1_pd(n[1]),
            _mm512_set1_pd(n[2]),
        );
        let (v0, v1, v2) = (
            _mm512_set1_pd(v[0]),
            _mm512_set1_pd(v[1]),
            _mm512_set1_pd(v[2]),
        );
        let (nv, a2, near) = (
            _mm512_set1_pd(nv),
            _mm512_set1_pd(a2),
            _mm512_set1_pd(o.near),
        );
        let (zero, one) = (_mm512_setzero_pd(), _mm512_set1_pd(1.0));
        for &(lo, hi) in &runs[first..o.runs_end as usize] {
            assert!(hi as usize + LANES <= rays.x.len());
            let (mut at, hi) = (lo as usize, hi as usize);
            while at < hi {
                // SAFETY: `at + LANES <= len` for every step: the rays are padded by LANES.
                let (x, y, z, range) = unsafe {
                    (
                        _mm512_loadu_pd(rays.x.as_ptr().add(at)),
                        _mm512_loadu_pd(rays.y.as_ptr().add(at)),
                        _mm512_loadu_pd(rays.z.as_ptr().add(at)),
                        _mm512_loadu_pd(rays.range.as_ptr().add(at)),
                    )
                };
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
                hits.push(u32::from(m), at, hi, o.leaf);
                at += LANES;
            }
        }
        first = o.runs_end as usize;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::uniforms;

    /// Rays (padded) and disks with hard cases: rays through a disk's rim, rays in a disk's
    /// plane, rays shorter than a disk's nearest point, and a disk's own leaf's ray.
    fn hard_cases() -> (Vec<Occluder>, Vec<(u32, u32)>, Rays) {
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
            disks.push(Occluder {
                disk: Disk::new(v, n, a),
                near: (dot(v, v).sqrt() - a) * (1.0 - 1e-12),
                leaf: j,
                runs_end: 0,
            });
        }
        // Exact decisions in binary: the disk at (2, 0, 0) facing x with radius 0.5; a ray
        // meeting its rim exactly (t = 1/2, |q|^2 = a^2, crossed), one ending exactly on its
        // plane (t = 1, not crossed) and one just outside its rim.
        let (v, n, a) = ([2.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.5);
        disks.push(Occluder {
            disk: Disk::new(v, n, a),
            near: (dot(v, v).sqrt() - a) * (1.0 - 1e-12),
            leaf: 40,
            runs_end: 0,
        });
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
        let mut runs = Vec::new();
        for (j, d) in disks.iter_mut().enumerate() {
            let lo = (7 * j) % m;
            runs.push((lo as u32, (lo + 1 + j % 13).min(m) as u32));
            runs.push((0, m as u32));
            d.runs_end = runs.len() as u32;
        }
        (disks, runs, rays)
    }

    /// The crossings counted from the hits that `test` keeps (a few at a time, so that the
    /// buffer fills and is counted many times over).
    fn counts(test: impl FnOnce(&mut Hits)) -> Vec<u32> {
        let (_, _, rays) = hard_cases();
        let c: Vec<AtomicU32> = (0..rays.x.len()).map(|_| AtomicU32::new(0)).collect();
        let mut hits = Hits::new(&rays, &c, 3);
        test(&mut hits);
        hits.count();
        c.iter().map(|x| x.load(Ordering::Relaxed)).collect()
    }

    #[test]
    fn the_lanes_count_what_the_scalar_disk_test_decides() {
        let (disks, runs, rays) = hard_cases();
        let got = counts(|h| test_chunk(&disks, &runs, &rays, h));
        let mut want = vec![0u32; rays.x.len()];
        let mut first = 0;
        for o in &disks {
            for &(lo, hi) in &runs[first..o.runs_end as usize] {
                let (lo, hi) = (lo as usize, hi as usize);
                for (pos, count) in want.iter_mut().enumerate().take(hi).skip(lo) {
                    let w = rays.w(pos);
                    if rays.range[pos] > o.near && rays.leaf[pos] != o.leaf && o.disk.crossed_by(w)
                    {
                        *count += 1;
                    }
                }
            }
            first = o.runs_end as usize;
        }
        assert!(want.iter().sum::<u32>() > 100, "the cases cross disks");
        assert_eq!(got, want);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx512_lanes_count_what_the_portable_lanes_count() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            return;
        }
        let (disks, runs, rays) = hard_cases();
        let portable = counts(|h| test_chunk(&disks, &runs, &rays, h));
        // SAFETY: the CPU has AVX-512F.
        let avx512 = counts(|h| unsafe { test_chunk_avx512(&disks, &runs, &rays, h) });
        assert_eq!(avx512, portable);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_lanes_count_what_the_portable_lanes_count() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let (disks, runs, rays) = hard_cases();
        let portable = counts(|h| test_chunk(&disks, &runs, &rays, h));
        // SAFETY: the CPU has AVX2.
        let avx2 = counts(|h| unsafe { test_chunk_avx2(&disks, &runs, &rays, h) });
        assert_eq!(avx2, portable);
    }
}
