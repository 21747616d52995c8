//! The runs of the leaf disks' tests: a disk against the consecutive positions of one row of
//! the cells it can reach, held by their number of steps (of [`LANES`] rays), so that the tests
//! of each number run in a loop without a data-dependent branch ([`super::sweep`]).
//!
//! A block of [`DISKS`] disks is listed lane by lane in AVX-512 where the CPU has it: the
//! rectangles of their boxes, the bounds of their rows gathered from the buffer, and the runs
//! compressed into their lists; elsewhere disk by disk. Both list the same runs (in another
//! order, which the counts, integer sums, do not see).
use super::buffer::{Buffer, DiskBoxes, Rect, DISKS};
use crate::math::vec3::V3;

/// Lanes of one step of the disk test.
pub(super) const LANES: usize = 8;

/// The most steps of one run: longer rows are cut into runs of this many steps.
pub(super) const MAX_STEPS: usize = 3;

/// Rows of a disk's rectangle listed without a loop; a taller rectangle's rows are listed one
/// by one.
const ROWS_UNROLLED: usize = 4;

/// A run of the tests: disk `occ` of the chunk against the `len` rays from position `at` (at
/// most [`MAX_STEPS`] steps). Eight bytes, `at` first, so that AVX-512 writes it as one
/// 64-bit lane.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Run {
    pub at: u32,
    pub occ: u16,
    pub len: u16,
}

/// Runs by their number of steps: `runs[s]` holds runs of `s` steps (`runs[0]` takes the
/// empty rows of short rectangles, untested).
pub(super) type Runs = [Vec<Run>; MAX_STEPS + 1];

/// The lanes of step `k` of a run of `len` rays that are in it.
#[inline(always)]
pub(super) fn step_mask(len: u16, k: usize) -> u8 {
    let left = (len as usize).saturating_sub(k * LANES).min(LANES);
    ((1u32 << left) - 1) as u8
}

/// Append the runs of disk `occ` over the positions `lo..hi`: runs of [`MAX_STEPS`] steps,
/// and the rest.
#[inline(always)]
pub(super) fn push_run(runs: &mut Runs, occ: u16, lo: u32, hi: u32) {
    const MOST: u32 = (MAX_STEPS * LANES) as u32;
    let mut at = lo;
    while at < hi {
        let len = (hi - at).min(MOST);
        runs[(len as usize).div_ceil(LANES)].push(Run {
            at,
            occ,
            len: len as u16,
        });
        at += len;
    }
}

/// List the runs of the first `count` disks of the boxes `b` (disk `k` is the chunk's disk
/// `occ0 + k`, of centre `v[..][k]` relative to the sonar and radius `a[k]`), in AVX-512
/// where `wide` (the CPU has AVX-512F, VL and DQ), else disk by disk.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn list_block(
    buf: &Buffer,
    b: &DiskBoxes,
    count: usize,
    occ0: u16,
    v: &[[f64; DISKS]; 3],
    a: &[f64; DISKS],
    runs: &mut Runs,
    wide: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if wide {
        // SAFETY: `wide` says the CPU has AVX-512F, VL and DQ.
        unsafe { list_block_avx512(buf, b, count, occ0, v, a, runs) };
        return;
    }
    let _ = wide;
    for k in 0..count {
        let centre = [v[0][k], v[1][k], v[2][k]];
        list_disk(buf, buf.rect_of(b, k), centre, a[k], occ0 + k as u16, runs);
    }
}

/// Whether this CPU lists in AVX-512 ([`list_block`]'s `wide`).
pub(super) fn wide_listing() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx512dq")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// List the runs of disk `occ` (centre `v` relative to the sonar, radius `a`) over the rows of
/// its rectangle `rect` ([`Buffer::rect_of`]), or over its cells found apart.
#[inline(always)]
fn list_disk(buf: &Buffer, rect: Rect, v: V3, a: f64, occ: u16, runs: &mut Runs) {
    let start = &buf.start[..];
    if rect == Rect::APART {
        buf.disk_cells_apart(v, a, |c0, c1| push_run(runs, occ, start[c0], start[c1]));
        return;
    }
    let (rows, width, stride) = (
        rect.rows as usize,
        rect.width as usize,
        rect.stride as usize,
    );
    if rows > ROWS_UNROLLED {
        for q in 0..rows {
            let c0 = rect.first as usize + q * stride;
            push_run(runs, occ, start[c0], start[c0 + width]);
        }
        return;
    }
    // Every unrolled row is listed; those past the rectangle's (its first row again) as
    // empty, in `runs[0]`, so that no branch depends on the number of rows.
    for q in 0..ROWS_UNROLLED {
        let c0 = rect.first as usize + if q < rows { q * stride } else { 0 };
        let (lo, hi) = (start[c0], start[c0 + width]);
        let len = if q < rows { hi - lo } else { 0 };
        let s = (len as usize).div_ceil(LANES);
        if s > MAX_STEPS {
            push_run(runs, occ, lo, hi);
        } else {
            runs[s].push(Run {
                at: lo,
                occ,
                len: len as u16,
            });
        }
    }
}

/// [`list_block`] in AVX-512: each lane one disk. Its rectangle is [`Buffer::face_rect`]'s,
/// by the same f64 operations and the same clamps (the faces' grids looked up by face); the
/// bounds of each of its first [`ROWS_UNROLLED`] rows are gathered from the buffer, and each
/// row's run is compressed into the list of its number of steps. Disks apart, taller
/// rectangles and rows of more than [`MAX_STEPS`] steps are listed one by one.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512dq")]
unsafe fn list_block_avx512(
    buf: &Buffer,
    b: &DiskBoxes,
    count: usize,
    occ0: u16,
    v: &[[f64; DISKS]; 3],
    a: &[f64; DISKS],
    runs: &mut Runs,
) {
    use std::arch::x86_64::*;
    let t = &buf.lanes;
    let live = ((1u32 << count.min(DISKS)) - 1) as u8;
    let inside = (0..DISKS).fold(0u8, |m, k| m | (u8::from(b.inside[k]) << k));
    // SAFETY: eight bytes of an eight-byte array.
    let face = unsafe { _mm512_cvtepu8_epi64(_mm_loadl_epi64(b.face.as_ptr() as *const __m128i)) };
    // SAFETY (each load): eight lanes of an eight-lane array.
    let load = |x: &[f64; 8]| unsafe { _mm512_loadu_pd(x.as_ptr()) };
    let pick = |x: &[f64; 8]| _mm512_permutexvar_pd(face, load(x));
    let pick_i = |x: &[i64; 8]| {
        _mm512_permutexvar_epi64(face, unsafe {
            _mm512_loadu_si512(x.as_ptr() as *const __m512i)
        })
    };
    let (ulo, uhi, wlo, whi) = (load(&b.u_lo), load(&b.u_hi), load(&b.w_lo), load(&b.w_hi));
    let (u0, v0, umax, vmax) = (pick(&t.u0), pick(&t.v0), pick(&t.umax), pick(&t.vmax));
    let (nu, nv, first_cell) = (pick_i(&t.nu), pick_i(&t.nv), pick_i(&t.first));
    let grid = _mm512_cmpneq_epi64_mask(nu, _mm512_setzero_si512());
    let beside = _mm512_cmp_pd_mask::<_CMP_LT_OQ>(uhi, u0)
        | _mm512_cmp_pd_mask::<_CMP_LT_OQ>(whi, v0)
        | _mm512_cmp_pd_mask::<_CMP_GT_OQ>(ulo, umax)
        | _mm512_cmp_pd_mask::<_CMP_GT_OQ>(wlo, vmax);
    let inv_h = _mm512_set1_pd(buf.inv_h());
    let zero = _mm512_setzero_pd();
    // Buffer::coord: (x - x0) / h truncated where positive, else (NaN included) 0; clamped
    // above at `top`, a whole number, before the truncation, which commutes with it.
    let coord = |x: __m512d, x0: __m512d, top: __m512d| {
        let c = _mm512_mul_pd(_mm512_sub_pd(x, x0), inv_h);
        _mm512_cvttpd_epi64(_mm512_min_pd(_mm512_max_pd(c, zero), top))
    };
    let one = _mm512_set1_pd(1.0);
    let (nu_f, nv_f) = (_mm512_cvtepi64_pd(nu), _mm512_cvtepi64_pd(nv));
    let i0 = coord(ulo, u0, nu_f);
    let i1 = coord(uhi, u0, _mm512_sub_pd(nu_f, one));
    let j0 = coord(wlo, v0, nv_f);
    let j1 = coord(whi, v0, _mm512_sub_pd(nv_f, one));
    let inverted = _mm512_cmpgt_epi64_mask(i0, i1) | _mm512_cmpgt_epi64_mask(j0, j1);
    let ok = live & inside & grid & !beside & !inverted;
    let one_i = _mm512_set1_epi64(1);
    let width = _mm512_sub_epi64(_mm512_add_epi64(i1, one_i), i0);
    let rows = _mm512_sub_epi64(_mm512_add_epi64(j1, one_i), j0);
    let first = _mm512_add_epi64(first_cell, _mm512_add_epi64(_mm512_mullo_epi64(j0, nu), i0));
    let tall = ok & _mm512_cmpgt_epi64_mask(rows, _mm512_set1_epi64(ROWS_UNROLLED as i64));
    let fast = ok & !tall;
    let (first, width, rows, stride) = (
        _mm512_cvtepi64_epi32(first),
        _mm512_cvtepi64_epi32(width),
        _mm512_cvtepi64_epi32(rows),
        _mm512_cvtepi64_epi32(nu),
    );
    let occ = _mm256_add_epi32(
        _mm256_set1_epi32(i32::from(occ0)),
        _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
    );
    let occ_bits = _mm512_slli_epi64::<32>(_mm512_cvtepu32_epi64(occ));
    let start_u = &buf.start[..];
    for q in 0..ROWS_UNROLLED {
        let row = _mm256_set1_epi32(q as i32);
        let act = fast & _mm256_cmpgt_epi32_mask(rows, row);
        if act == 0 {
            // (no lane has this row, nor any later one)
            break;
        }
        let c0 = _mm256_add_epi32(first, _mm256_mullo_epi32(row, stride));
        let c1 = _mm256_add_epi32(c0, width);
        // An active lane's cells c0 and c1 = c0 + width are within the rectangle's row of a
        // face's grid, or one past its last cell: below `start.len()` (others read cell 0).
        let (mut i0, mut i1) = ([0u32; DISKS], [0u32; DISKS]);
        // SAFETY: eight 32-bit lanes into eight u32.
        unsafe {
            _mm256_storeu_si256(
                i0.as_mut_ptr() as *mut __m256i,
                _mm256_maskz_mov_epi32(act, c0),
            );
            _mm256_storeu_si256(
                i1.as_mut_ptr() as *mut __m256i,
                _mm256_maskz_mov_epi32(act, c1),
            );
        }
        let (l, h): ([u32; DISKS], [u32; DISKS]) = (
            std::array::from_fn(|k| start_u[i0[k] as usize]),
            std::array::from_fn(|k| start_u[i1[k] as usize]),
        );
        // SAFETY: as above.
        let (lo, hi) = unsafe {
            (
                _mm256_loadu_si256(l.as_ptr() as *const __m256i),
                _mm256_loadu_si256(h.as_ptr() as *const __m256i),
            )
        };
        let len = _mm256_sub_epi32(hi, lo);
        let steps = _mm256_srli_epi32::<3>(_mm256_add_epi32(len, _mm256_set1_epi32(7)));
        const _: () = assert!(LANES == 8, "steps of eight lanes");
        let long = act & _mm256_cmpgt_epi32_mask(steps, _mm256_set1_epi32(MAX_STEPS as i32));
        let packed = _mm512_or_si512(
            _mm512_or_si512(_mm512_cvtepu32_epi64(lo), occ_bits),
            _mm512_slli_epi64::<48>(_mm512_cvtepu32_epi64(len)),
        );
        for (s, list) in runs.iter_mut().enumerate().skip(1) {
            let m = act & !long & _mm256_cmpeq_epi32_mask(steps, _mm256_set1_epi32(s as i32));
            list.reserve(DISKS);
            let n = list.len();
            // SAFETY: the list has room for DISKS more runs (reserved); a Run is the 64-bit
            // lane `at | occ << 32 | len << 48` (repr(C), little-endian), and the first
            // `m.count_ones()` lanes stored are the runs compressed.
            unsafe {
                _mm512_storeu_si512(
                    list.as_mut_ptr().add(n) as *mut __m512i,
                    _mm512_maskz_compress_epi64(m, packed),
                );
                list.set_len(n + m.count_ones() as usize);
            }
        }
        if long != 0 {
            let (mut l, mut h) = ([0u32; DISKS], [0u32; DISKS]);
            // SAFETY: eight 32-bit lanes into eight u32.
            unsafe {
                _mm256_storeu_si256(l.as_mut_ptr() as *mut __m256i, lo);
                _mm256_storeu_si256(h.as_mut_ptr() as *mut __m256i, hi);
            }
            for k in (0..DISKS).filter(|k| long >> k & 1 == 1) {
                push_run(runs, occ0 + k as u16, l[k], h[k]);
            }
        }
    }
    let rest = (live & !inside) | tall;
    for k in (0..DISKS).filter(|k| rest >> k & 1 == 1) {
        let centre = [v[0][k], v[1][k], v[2][k]];
        list_disk(buf, buf.rect_of(b, k), centre, a[k], occ0 + k as u16, runs);
    }
}

#[cfg(test)]
mod tests {
    use super::super::buffer::tests::disk_lanes;
    use super::*;
    use crate::math::vec3::dot;
    use crate::test_util::{uniforms, unit_vector};

    /// The runs of every block of `disks` by both listings, each sorted, without the empty.
    fn both_listings(buf: &Buffer, disks: &[(V3, V3, f64)]) -> (Vec<Run>, Vec<Run>) {
        let (mut narrow, mut wide): (Runs, Runs) = Default::default();
        for (c, batch) in disks.chunks(DISKS).enumerate() {
            let (v, n, a) = disk_lanes(batch);
            let b = buf.disk_boxes(&v, &n, &a);
            let occ0 = (c * DISKS) as u16;
            list_block(buf, &b, batch.len(), occ0, &v, &a, &mut narrow, false);
            list_block(buf, &b, batch.len(), occ0, &v, &a, &mut wide, true);
        }
        let flat = |r: Runs| {
            let mut all: Vec<Run> = r.into_iter().skip(1).flatten().collect();
            all.sort_unstable();
            all
        };
        (flat(narrow), flat(wide))
    }

    /// Disks near and far, facing the sonar, edge-on and at random, on every face, across
    /// faces' edges and beside the targets' grids, some too near the sonar to bin, and blocks
    /// of fewer than eight.
    #[test]
    fn the_avx512_listing_lists_the_runs_of_the_disk_by_disk_listing() {
        if !wide_listing() {
            return;
        }
        let mut u = uniforms(21);
        let mut dir = || unit_vector(&mut u);
        // targets over part of the sphere: some faces without a grid, grids with edges
        let targets: Vec<V3> = (0..6000)
            .map(|_| dir())
            .filter(|d| d[0] > -0.3 && d[2] < 0.8)
            .map(|d| d.map(|x| 4.0 * x))
            .collect();
        let mut disks = Vec::new();
        for k in 0..3001 {
            let c = dir().map(|x| (0.2 + 6.0 * (k % 11) as f64 / 11.0) * x);
            let dist = dot(c, c).sqrt();
            let n = if k % 4 == 0 {
                c.map(|x| x / dist)
            } else {
                dir()
            };
            let a = dist / [3.0, 5.0, 20.0, 80.0, 300.0][k % 5];
            disks.push((c, n, a));
        }
        for h in [0.004, 0.02, 0.1] {
            let buf = Buffer::new(&targets, h);
            let (narrow, wide) = both_listings(&buf, &disks);
            assert!(narrow.len() > 3000, "runs listed ({})", narrow.len());
            assert_eq!(wide, narrow, "at h {h}");
        }
    }
}
