//! The light buffer (E. A. Haines, D. P. Greenberg, "The light buffer: a shadow-testing
//! accelerator", IEEE CG&A 6(9), 1986): the directions round the sonar on the six faces of a
//! cube, each face's targets binned in a grid of cells over their box in the face's gnomonic
//! coordinates. A ball bounding an occluder maps to the cells its directions can reach, so a
//! ray is tested only against the occluders whose balls reach its cell.
//!
//! The binning is conservative, never exact: a target's cell and a ball's cells come from the
//! same monotone function of the coordinates, and a ball's slopes are widened past their
//! rounding. Every candidate then goes through the exact test.
use crate::math::vec3::{dot, V3};
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
    h: f64,
    /// `1 / h`, by which [`Buffer::coord`] scales.
    inv_h: f64,
    n_cells: usize,
    /// The targets of cell `c` are `order[start[c]..start[c + 1]]` (indices into the caller's
    /// targets); cells of one row of one face are consecutive.
    pub(super) start: Vec<u32>,
    pub(super) order: Vec<u32>,
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

impl Buffer {
    /// Bin the targets at `w` (their rays, relative to the sonar) in cells about `h_hint`
    /// wide (gnomonic units), at most about two cells per target.
    pub(super) fn new(w: &[V3], h_hint: f64) -> Buffer {
        let n = w.len();
        let at: Vec<(usize, f64, f64)> = w.par_iter().map(|&w| face_of(w)).collect();
        let mut bbox = [(
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ); 6];
        for &(f, u, v) in &at {
            let b = &mut bbox[f];
            *b = (b.0.min(u), b.1.max(u), b.2.min(v), b.3.max(v));
        }
        let area: f64 = bbox
            .iter()
            .filter(|b| b.0 <= b.1)
            .map(|b| (b.1 - b.0) * (b.3 - b.2))
            .sum();
        let max_cells = (2 * n + 4096) as f64;
        let mut h = h_hint.max((area / max_cells).sqrt());
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
        let mut buf = Buffer {
            faces,
            h,
            inv_h: 1.0 / h,
            n_cells,
            start: Vec::new(),
            order: Vec::new(),
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
        let mut order = vec![0u32; n];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        buf.start = start;
        buf.order = order;
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

    /// The cell of the direction `w` (`n_cells` for a face that holds no target), to order
    /// occluders by the cells they reach.
    #[inline(always)]
    pub(super) fn cell_of(&self, w: V3) -> usize {
        self.cell_at(face_of(w))
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

    /// Visit the cells of face `f` within the slope ranges `u`, `w`.
    #[inline(always)]
    fn visit_face(
        &self,
        f: usize,
        u: (f64, f64),
        w: (f64, f64),
        visit: &mut impl FnMut(usize, usize),
    ) {
        let fc = &self.faces[f];
        if fc.nu == 0 {
            return;
        }
        let (umax, vmax) = (fc.u0 + fc.nu as f64 * self.h, fc.v0 + fc.nv as f64 * self.h);
        if u.1 < fc.u0 || w.1 < fc.v0 || u.0 > umax || w.0 > vmax {
            return;
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
            return;
        }
        for j in j0..=j1 {
            let row = fc.first + j * fc.nu;
            visit(row + i0, row + i1 + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::uniforms;

    #[test]
    fn a_ball_reaches_the_cells_of_every_direction_it_holds() {
        let mut u = uniforms(11);
        let mut dir = || {
            let (z, ph) = (2.0 * u() - 1.0, 2.0 * std::f64::consts::PI * u());
            let q = (1.0 - z * z).sqrt();
            [q * ph.cos(), q * ph.sin(), z]
        };
        let targets: Vec<V3> = (0..4000).map(|_| dir().map(|x| 3.0 * x)).collect();
        for h in [0.01, 0.05, 0.3] {
            let buf = Buffer::new(&targets, h);
            let mut cell_of = vec![0usize; targets.len()];
            for c in 0..buf.n_cells() {
                for k in buf.start[c]..buf.start[c + 1] {
                    cell_of[buf.order[k as usize] as usize] = c;
                }
            }
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
