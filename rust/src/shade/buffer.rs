//! The light buffer (E. A. Haines, D. P. Greenberg, "The light buffer: a shadow-testing
//! accelerator", IEEE CG&A 6(9), 1986): the directions round the sonar on the six faces of a
//! cube, each face's targets binned in a grid of cells over their box in the face's gnomonic
//! coordinates. An occluder maps to the cells its directions can reach (a leaf disk by the box
//! of its projection, a ball by the box of its), so a ray is tested only against the occluders
//! that reach its cell.
//!
//! The binning is conservative, never exact: a target's cell and an occluder's cells come from
//! the same monotone function of the coordinates, and an occluder's slopes are widened past
//! their rounding. Every candidate then goes through the exact test.
use crate::math::vec3::{dot, V3};
use multiversion::multiversion;
use rayon::prelude::*;

/// A ball this close to the sonar (its distance at most this many radii) can reach any face
/// from a plane it straddles; its occluder is tested against every target.
const NEAR_BALLS: f64 = 4.5;
/// Relative widening of a ball's radius and slopes, far beyond their rounding.
const WIDEN: f64 = 1e-9;

/// One face's grid: its corner in gnomonic coordinates, its size in cells and its first cell.
#[derive(Clone, Copy, Debug, Default)]
struct Face {
    u0: f64,
    v0: f64,
    nu: usize,
    nv: usize,
    first: usize,
}

/// Targets binned by the direction of their rays.
pub(super) struct Buffer {
    faces: [Face; 6],
    /// The faces' grids lane by lane.
    pub(super) lanes: FaceLanes,
    h: f64,
    /// `1 / h`, by which [`Buffer::coord`] scales.
    inv_h: f64,
    n_cells: usize,
    /// The targets in cell order: those of cell `c` hold the positions `start[c]..start[c + 1]`;
    /// cells of one row of one face are consecutive.
    pub(super) start: Vec<u32>,
    /// The position of target `i` (an index into the caller's targets).
    pub(super) slot: Vec<u32>,
}

/// The cube face of a direction `w` (`2 a + [w_a < 0]`, `a` its largest coordinate, the first
/// of equals) and its gnomonic coordinates `(w_b, w_c) / |w_a|`, `(b, c) = (a + 1, a + 2) mod 3`.
#[inline(always)]
fn face_of(w: V3) -> (usize, f64, f64) {
    let (x, y, z) = (w[0].abs(), w[1].abs(), w[2].abs());
    let a = if x >= y && x >= z {
        0
    } else if y >= z {
        1
    } else {
        2
    };
    let d = w[a].abs();
    (
        2 * a + usize::from(w[a] < 0.0),
        w[(a + 1) % 3] / d,
        w[(a + 2) % 3] / d,
    )
}

/// Each face's box `(u_lo, u_hi, v_lo, v_hi)` of the directions `at` on it (empty: infinite
/// bounds the wrong way round). Four boxes per face are kept, for every fourth direction, and
/// merged at the end, so that consecutive directions do not wait on each other's bounds
/// (minima and maxima: the same boxes in any order).
fn face_boxes(at: &[(usize, f64, f64)]) -> [(f64, f64, f64, f64); 6] {
    const EMPTY: (f64, f64, f64, f64) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let grow = |b: &mut (f64, f64, f64, f64), &(_, u, v): &(usize, f64, f64)| {
        *b = (b.0.min(u), b.1.max(u), b.2.min(v), b.3.max(v));
    };
    let mut boxes = [[EMPTY; 6]; 4];
    let mut quads = at.chunks_exact(4);
    for q in &mut quads {
        for (k, a) in q.iter().enumerate() {
            grow(&mut boxes[k][a.0], a);
        }
    }
    for a in quads.remainder() {
        grow(&mut boxes[0][a.0], a);
    }
    let mut out = boxes[0];
    for part in &boxes[1..] {
        for (b, p) in out.iter_mut().zip(part) {
            *b = (b.0.min(p.0), b.1.max(p.1), b.2.min(p.2), b.3.max(p.3));
        }
    }
    out
}

/// The range of slopes `x_b / x_a` over a ball of centre `(vb, z)` and radius `rho` in the
/// `(b, a)` plane (`z > rho`), widened.
#[inline(always)]
fn slopes(vb: f64, z: f64, rho: f64) -> (f64, f64) {
    let den = z * z - rho * rho;
    let root = rho * (vb * vb + den).sqrt();
    let inv = 1.0 / den;
    let (lo, hi) = ((vb * z - root) * inv, (vb * z + root) * inv);
    (lo - WIDEN * (1.0 + lo.abs()), hi + WIDEN * (1.0 + hi.abs()))
}

/// A rectangle of cells: `rows` rows of `width` cells, the first starting at cell `first`
/// and each `stride` cells after the one before (empty without rows); or, with `rows` =
/// `u32::MAX`, a disk whose cells are found apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Rect {
    pub first: u32,
    pub width: u32,
    pub rows: u32,
    pub stride: u32,
}

impl Rect {
    /// No cell.
    const EMPTY: Rect = Rect {
        first: 0,
        width: 0,
        rows: 0,
        stride: 0,
    };
    /// A disk whose cells are found apart.
    pub const APART: Rect = Rect {
        first: 0,
        width: 0,
        rows: u32::MAX,
        stride: 0,
    };
}

/// Disks per call of [`disk_boxes`].
pub(super) const DISKS: usize = 8;

/// Each disk's face (that of its centre) and its slope ranges there (`u` along the face's
/// first coordinate, `w` along its second), and whether they stay inside that face with the
/// disk far enough from the sonar to bin.
pub(super) struct DiskBoxes {
    pub face: [u8; DISKS],
    pub u_lo: [f64; DISKS],
    pub u_hi: [f64; DISKS],
    pub w_lo: [f64; DISKS],
    pub w_hi: [f64; DISKS],
    pub inside: [bool; DISKS],
}

/// The boxes of [`DISKS`] disks (centres `v` relative to the sonar and unit normals `n`, by
/// coordinate; radii `a`), branch-free so that they run lane by lane. The face is chosen as
/// [`face_of`] chooses it, and a disk's near test is a ball's ([`Buffer::ball_cells`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn disk_boxes(v: &[[f64; DISKS]; 3], n: &[[f64; DISKS]; 3], a: &[f64; DISKS]) -> DiskBoxes {
    let mut out = DiskBoxes {
        face: [0; DISKS],
        u_lo: [0.0; DISKS],
        u_hi: [0.0; DISKS],
        w_lo: [0.0; DISKS],
        w_hi: [0.0; DISKS],
        inside: [false; DISKS],
    };
    for k in 0..DISKS {
        let (x, y, z) = (v[0][k], v[1][k], v[2][k]);
        let dist = (x * x + y * y + z * z).sqrt();
        let near_ok = dist > NEAR_BALLS * a[k];
        let r = a[k] * (1.0 + WIDEN);
        // face_of, by selects: the axis of the largest coordinate (the first of equals)
        let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
        let is_x = ax >= ay && ax >= az;
        let is_y = !is_x && ay >= az;
        let (va, vb, vc, na, nb, nc, axis) = if is_x {
            (x, y, z, n[0][k], n[1][k], n[2][k], 0u8)
        } else if is_y {
            (y, z, x, n[1][k], n[2][k], n[0][k], 1)
        } else {
            (z, x, y, n[2][k], n[0][k], n[1][k], 2)
        };
        let zf = va.abs();
        let na = if va < 0.0 { -na } else { na };
        let u = disk_slopes(vb, zf, nb, na, r);
        let w = disk_slopes(vc, zf, nc, na, r);
        let inside = |s: (f64, f64)| s.0 > -1.0 && s.1 < 1.0;
        out.face[k] = 2 * axis + u8::from(va < 0.0);
        (out.u_lo[k], out.u_hi[k]) = u;
        (out.w_lo[k], out.w_hi[k]) = w;
        out.inside[k] = near_ok & (zf > r) & inside(u) & inside(w);
    }
    out
}

/// The faces' grids lane by lane, entry `f` for face `f` (the last two unused), for vector
/// code that looks them up by face: each grid's corner, its far bounds (as
/// [`Buffer::face_rect`] computes them), its size in cells (0 for a face without a grid) and
/// its first cell.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct FaceLanes {
    pub u0: [f64; 8],
    pub v0: [f64; 8],
    pub umax: [f64; 8],
    pub vmax: [f64; 8],
    pub nu: [i64; 8],
    pub nv: [i64; 8],
    pub first: [i64; 8],
}

/// The range of slopes `x_b / x_a` over a disk of centre `(vb, z)` (`z > a`), normal
/// components `(nb, na)` and radius `a`, in the `(b, a)` plane, widened past its rounding:
/// the slopes `s` whose plane `x_b = s x_a` meets the disk, `|vb - s z| <= a |m - (m . n) n|`
/// with `m = (-s, 1)` in `(a, b)`, which is `A s^2 - 2 P s + C <= 0`.
#[inline(always)]
fn disk_slopes(vb: f64, z: f64, nb: f64, na: f64, a: f64) -> (f64, f64) {
    let a2 = a * a;
    let big_a = z * z - a2 * (1.0 - na * na);
    let p = z * vb + a2 * na * nb;
    let c = vb * vb - a2 * (1.0 - nb * nb);
    // (the discriminant raised by far more than its rounding, which is largest where the
    // interval is thin)
    let scale = (z * vb.abs() + a2) * (z * vb.abs() + a2) + big_a * (vb * vb + a2);
    let root = (p * p - big_a * c + 1e-12 * scale).max(0.0).sqrt();
    let inv = 1.0 / big_a;
    let (lo, hi) = ((p - root) * inv, (p + root) * inv);
    (lo - WIDEN * (1.0 + lo.abs()), hi + WIDEN * (1.0 + hi.abs()))
}

impl Buffer {
    /// Bin the targets at `w` (their rays, relative to the sonar) in cells about `h_hint`
    /// wide (gnomonic units), at most about four cells per target (and 8,198 more).
    pub(super) fn new(w: &[V3], h_hint: f64) -> Buffer {
        let n = w.len();
        let at: Vec<(usize, f64, f64)> = w.par_iter().map(|&w| face_of(w)).collect();
        let bbox = face_boxes(&at);
        let area: f64 = bbox
            .iter()
            .filter(|b| b.0 <= b.1)
            .map(|b| (b.1 - b.0) * (b.3 - b.2))
            .sum();
        let sides: f64 = bbox
            .iter()
            .filter(|b| b.0 <= b.1)
            .map(|b| (b.1 - b.0) + (b.3 - b.2))
            .sum();
        // A face has at most (du / h + 1)(dv / h + 1) = du dv / h^2 + (du + dv) / h + 1 cells:
        // h bounded below by both the area's and the sides' share keeps the cells within
        // 2 max_cells + 6, a box flat or thin (targets in a plane through the sonar) included.
        let max_cells = (2 * n + 4096) as f64;
        let mut h = h_hint.max((area / max_cells).sqrt()).max(sides / max_cells);
        if !(h > 0.0 && h.is_finite()) {
            h = 1.0;
        }
        let mut faces = [Face::default(); 6];
        let mut n_cells = 0usize;
        for (f, b) in bbox.iter().enumerate() {
            if b.0 > b.1 {
                continue;
            }
            let nu = ((b.1 - b.0) / h).floor() as usize + 1;
            let nv = ((b.3 - b.2) / h).floor() as usize + 1;
            faces[f] = Face {
                u0: b.0,
                v0: b.2,
                nu,
                nv,
                first: n_cells,
            };
            n_cells += nu * nv;
        }
        let mut lanes = FaceLanes::default();
        for (f, fc) in faces.iter().enumerate() {
            lanes.u0[f] = fc.u0;
            lanes.v0[f] = fc.v0;
            lanes.umax[f] = fc.u0 + fc.nu as f64 * h;
            lanes.vmax[f] = fc.v0 + fc.nv as f64 * h;
            (lanes.nu[f], lanes.nv[f]) = (fc.nu as i64, fc.nv as i64);
            lanes.first[f] = fc.first as i64;
        }
        let mut buf = Buffer {
            faces,
            lanes,
            h,
            inv_h: 1.0 / h,
            n_cells,
            start: Vec::new(),
            slot: Vec::new(),
        };
        // counting sort of the targets by cell
        let cells: Vec<u32> = at.par_iter().map(|&a| buf.cell_at(a) as u32).collect();
        let mut start = vec![0u32; n_cells + 1];
        for &c in &cells {
            start[c as usize + 1] += 1;
        }
        for c in 0..n_cells {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut slot = vec![0u32; n];
        for (s, &c) in slot.iter_mut().zip(&cells) {
            let pos = &mut fill[c as usize];
            *s = *pos;
            *pos += 1;
        }
        buf.start = start;
        buf.slot = slot;
        buf
    }

    /// The cell of a direction on face `f` at gnomonic `(u, v)`: the nearest cell of the
    /// face's grid (`n_cells` for a face without one).
    #[inline(always)]
    fn cell_at(&self, (f, u, v): (usize, f64, f64)) -> usize {
        let fc = &self.faces[f];
        if fc.nu == 0 {
            return self.n_cells;
        }
        let i = self.coord(u, fc.u0).min(fc.nu - 1);
        let j = self.coord(v, fc.v0).min(fc.nv - 1);
        fc.first + j * fc.nu + i
    }

    /// The number of cells.
    pub(super) fn n_cells(&self) -> usize {
        self.n_cells
    }

    /// The width of a cell (gnomonic units: radians near a face's centre, less towards its
    /// edges).
    pub(super) fn cell_width(&self) -> f64 {
        self.h
    }

    /// The cell coordinate of `x` on an axis starting at `x0` (clamped below at 0). The same
    /// function bins targets and balls, so that it is monotone across both.
    #[inline(always)]
    fn coord(&self, x: f64, x0: f64) -> usize {
        // (the cast truncates, which is the floor where c > 0; NaN and c <= 0 give 0)
        let c = (x - x0) * self.inv_h;
        if c > 0.0 {
            c as usize
        } else {
            0
        }
    }

    /// Calls `visit(c0, c1)` for runs of cells `c0..c1` (one row of one face at a time) that
    /// hold every target whose ray the ball of centre `v` (relative to the sonar) and radius
    /// `rho` can reach; false (nothing visited) when the ball is too near the sonar to bin, and
    /// every target must be tested.
    #[inline(always)]
    pub(super) fn ball_cells(&self, v: V3, rho: f64, mut visit: impl FnMut(usize, usize)) -> bool {
        let dist = dot(v, v).sqrt();
        if !(dist > NEAR_BALLS * rho) {
            return false;
        }
        let rho = rho * (1.0 + WIDEN);
        // The face of the centre first: if the ball's slopes stay inside it, no other face
        // holds any of its directions.
        let (f, _, _) = face_of(v);
        if let Some((u, w)) = self.face_slopes(v, rho, f) {
            let inside = |s: (f64, f64)| s.0 > -1.0 && s.1 < 1.0;
            if inside(u) && inside(w) {
                self.visit_face(f, u, w, &mut visit);
                return true;
            }
        }
        for f in 0..6 {
            if let Some((u, w)) = self.face_slopes(v, rho, f) {
                self.visit_face(f, u, w, &mut visit);
            }
        }
        true
    }

    /// The boxes of [`DISKS`] disks (centres `v` relative to the sonar and unit normals `n`, by
    /// coordinate; radii `a`) on the faces of their centres: see [`Buffer::rect_of`].
    #[inline(always)]
    pub(super) fn disk_boxes(
        &self,
        v: &[[f64; DISKS]; 3],
        n: &[[f64; DISKS]; 3],
        a: &[f64; DISKS],
    ) -> DiskBoxes {
        disk_boxes(v, n, a)
    }

    /// The cells that can hold a target whose ray crosses disk `k` of the boxes `b`: the
    /// rectangle of the cells of the disk's box on the face of its centre, or, for the rare
    /// disk whose box leaves that face or that lies too near the sonar, [`Rect::APART`]: its
    /// cells are found by [`Buffer::disk_cells_apart`].
    #[inline(always)]
    pub(super) fn rect_of(&self, b: &DiskBoxes, k: usize) -> Rect {
        if b.inside[k] {
            self.face_rect(
                b.face[k] as usize,
                (b.u_lo[k], b.u_hi[k]),
                (b.w_lo[k], b.w_hi[k]),
            )
        } else {
            Rect::APART
        }
    }

    /// The reciprocal of the cell width, by which cell coordinates are scaled.
    pub(super) fn inv_h(&self) -> f64 {
        self.inv_h
    }

    /// Calls `visit(c0, c1)` for the runs of cells `c0..c1` of a disk (centre `v` relative to
    /// the sonar, radius `a`) that [`Buffer::rect_of`] marks apart: those of its ball
    /// ([`Buffer::ball_cells`]), or every cell if that is too near the sonar to bin.
    pub(super) fn disk_cells_apart(&self, v: V3, a: f64, mut visit: impl FnMut(usize, usize)) {
        if !self.ball_cells(v, a, &mut visit) {
            visit(0, self.n_cells);
        }
    }

    /// The ball's slope ranges on face `f`, if it lies wholly in front of the face's plane.
    #[inline(always)]
    fn face_slopes(&self, v: V3, rho: f64, f: usize) -> Option<((f64, f64), (f64, f64))> {
        let a = f / 2;
        let z = if f.is_multiple_of(2) { v[a] } else { -v[a] };
        if !(z > rho) {
            return None;
        }
        Some((
            slopes(v[(a + 1) % 3], z, rho),
            slopes(v[(a + 2) % 3], z, rho),
        ))
    }

    /// Visit the cells of face `f` within the slope ranges `u`, `w`, row by row.
    #[inline(always)]
    fn visit_face(
        &self,
        f: usize,
        u: (f64, f64),
        w: (f64, f64),
        visit: &mut impl FnMut(usize, usize),
    ) {
        let r = self.face_rect(f, u, w);
        for q in 0..r.rows as usize {
            let c0 = r.first as usize + q * r.stride as usize;
            visit(c0, c0 + r.width as usize);
        }
    }

    /// The rectangle of cells of face `f` within the slope ranges `u`, `w`: from the cell
    /// coordinates of their bounds ([`Buffer::coord`]), the upper ones clamped to the grid;
    /// empty for a face without a grid or ranges beside it.
    #[inline(always)]
    fn face_rect(&self, f: usize, u: (f64, f64), w: (f64, f64)) -> Rect {
        let fc = &self.faces[f];
        if fc.nu == 0 {
            return Rect::EMPTY;
        }
        let (umax, vmax) = (fc.u0 + fc.nu as f64 * self.h, fc.v0 + fc.nv as f64 * self.h);
        if u.1 < fc.u0 || w.1 < fc.v0 || u.0 > umax || w.0 > vmax {
            return Rect::EMPTY;
        }
        let (i0, i1) = (
            self.coord(u.0, fc.u0),
            self.coord(u.1, fc.u0).min(fc.nu - 1),
        );
        let (j0, j1) = (
            self.coord(w.0, fc.v0),
            self.coord(w.1, fc.v0).min(fc.nv - 1),
        );
        if i0 > i1 || j0 > j1 {
            return Rect::EMPTY;
        }
        Rect {
            first: (fc.first + j0 * fc.nu + i0) as u32,
            width: (i1 + 1 - i0) as u32,
            rows: (j1 + 1 - j0) as u32,
            stride: fc.nu as u32,
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::test_util::{uniforms, unit_vector};

    /// A block of at most [`DISKS`] disks (centre relative to the sonar, unit normal, radius)
    /// lane by lane, as [`Buffer::disk_boxes`] takes them (unused lanes 0).
    pub(in crate::shade) fn disk_lanes(
        batch: &[(V3, V3, f64)],
    ) -> ([[f64; DISKS]; 3], [[f64; DISKS]; 3], [f64; DISKS]) {
        let (mut v, mut n, mut a) = ([[0.0; DISKS]; 3], [[0.0; DISKS]; 3], [0.0; DISKS]);
        for (k, &(c, nn, r)) in batch.iter().enumerate() {
            for d in 0..3 {
                (v[d][k], n[d][k]) = (c[d], nn[d]);
            }
            a[k] = r;
        }
        (v, n, a)
    }

    /// The cell of each of the `n` targets binned in `buf` (the last whose positions start
    /// at or before the target's).
    fn cells_of_targets(buf: &Buffer, n: usize) -> Vec<usize> {
        (0..n)
            .map(|i| buf.start.partition_point(|&s| s <= buf.slot[i]) - 1)
            .collect()
    }

    /// Disks facing the sonar, edge-on to it and at random, near and far, on every face and
    /// across faces' edges.
    #[test]
    fn a_disk_reaches_the_cells_of_every_ray_that_crosses_it() {
        use super::super::crossing::Disk;
        let mut u = uniforms(12);
        let mut dir = || unit_vector(&mut u);
        let targets: Vec<V3> = (0..4000).map(|_| dir().map(|x| 3.0 * x)).collect();
        let mut disks = Vec::new();
        for k in 0..600 {
            let c = dir().map(|x| (0.3 + 2.0 * (k % 7) as f64 / 7.0) * x);
            let dist = dot(c, c).sqrt();
            let n = match k % 3 {
                0 => c.map(|x| x / dist),
                1 => {
                    let e = dir();
                    let p = [0, 1, 2].map(|d| e[d] - dot(e, c) / (dist * dist) * c[d]);
                    let l = dot(p, p).sqrt();
                    p.map(|x| x / l)
                }
                _ => dir(),
            };
            let a = dist / (4.6 + 20.0 * (k % 5) as f64);
            disks.push((c, n, a));
        }
        for h in [0.01, 0.05, 0.3] {
            let buf = Buffer::new(&targets, h);
            let cell_of = cells_of_targets(&buf, targets.len());
            let mut crossed = 0;
            for batch in disks.chunks(DISKS) {
                let (v, n, a) = disk_lanes(batch);
                let mut reached = vec![vec![false; buf.n_cells()]; DISKS];
                let b = buf.disk_boxes(&v, &n, &a);
                for (k, rect) in (0..DISKS).map(|k| (k, buf.rect_of(&b, k))) {
                    let mut mark = |c0: usize, c1: usize| {
                        reached[k][c0..c1].iter_mut().for_each(|r| *r = true)
                    };
                    if rect == Rect::APART {
                        buf.disk_cells_apart([v[0][k], v[1][k], v[2][k]], a[k], mark);
                    } else {
                        for q in 0..rect.rows as usize {
                            let c0 = rect.first as usize + q * rect.stride as usize;
                            mark(c0, c0 + rect.width as usize);
                        }
                    }
                }
                for (k, &(c, nn, r)) in batch.iter().enumerate() {
                    let disk = Disk::new(c, nn, r);
                    for (i, t) in targets.iter().enumerate() {
                        if disk.crossed_by(*t) {
                            crossed += 1;
                            assert!(reached[k][cell_of[i]], "target {i} missed at h {h}");
                        }
                    }
                }
            }
            assert!(crossed > 1000, "the disks are crossed ({crossed})");
        }
    }

    #[test]
    fn the_faces_boxes_are_those_of_the_directions_taken_one_by_one() {
        let mut u = uniforms(13);
        for n in [0, 1, 3, 4, 5, 7, 1001] {
            let at: Vec<(usize, f64, f64)> = (0..n)
                .map(|_| face_of(unit_vector(&mut u).map(|x| 2.0 * x)))
                .collect();
            let mut want = [(
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ); 6];
            for &(f, u, v) in &at {
                let b = &mut want[f];
                *b = (b.0.min(u), b.1.max(u), b.2.min(v), b.3.max(v));
            }
            assert_eq!(face_boxes(&at), want, "{n} directions");
        }
    }

    #[test]
    fn targets_in_a_plane_through_the_sonar_get_few_cells_however_fine_the_hint() {
        // a line of targets at x = 3, z = 0: their box on the +x face has no area
        let n = 1000;
        let targets: Vec<V3> = (0..n)
            .map(|i| [3.0, -1.0 + 2.0 * i as f64 / n as f64, 0.0])
            .collect();
        let buf = Buffer::new(&targets, 1e-12);
        assert!(
            buf.n_cells() <= 2 * (2 * n + 4096) + 6,
            "{} cells",
            buf.n_cells()
        );
        assert_eq!(cells_of_targets(&buf, n).len(), n);
    }

    #[test]
    fn a_ball_reaches_the_cells_of_every_direction_it_holds() {
        let mut u = uniforms(11);
        let mut dir = || unit_vector(&mut u);
        let targets: Vec<V3> = (0..4000).map(|_| dir().map(|x| 3.0 * x)).collect();
        for h in [0.01, 0.05, 0.3] {
            let buf = Buffer::new(&targets, h);
            let cell_of = cells_of_targets(&buf, targets.len());
            for _ in 0..300 {
                let centre = dir().map(|x| 2.0 * x);
                let rho = 0.4 * (centre.iter().map(|x| x * x).sum::<f64>()).sqrt() / 4.6;
                let mut reached = vec![false; buf.n_cells()];
                assert!(buf.ball_cells(centre, rho, |c0, c1| {
                    reached[c0..c1].iter_mut().for_each(|r| *r = true)
                }));
                for (i, t) in targets.iter().enumerate() {
                    // the direction of target i passes through the ball
                    let tt = dot(*t, *t);
                    let along = dot(centre, *t) / tt;
                    let q = [0, 1, 2].map(|d| along * t[d] - centre[d]);
                    if along > 0.0 && dot(q, q) <= rho * rho {
                        assert!(reached[cell_of[i]], "target {i} missed at h {h}");
                    }
                }
            }
        }
    }
}
