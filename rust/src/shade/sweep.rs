//! The leaf disks' pass over the light buffer: each occluding leaf is tested against the
//! targets of the cells its bounding ball reaches (rows of cells, contiguous in memory),
//! farther than its nearest point, by the exact test of [`Disk::crossed_by`] written lane by
//! lane so that it vectorises. The lanes
//! perform the same f64 operations in the same order as [`Disk::crossed_by`] (no FMA), so
//! they decide every ray alike.
use super::buffer::Buffer;
use super::crossing::Disk;
use crate::math::vec3::{dot, V3};
use crate::scene::Scene;
use multiversion::multiversion;
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
/// crosses, into `crossings` (by position).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(super) fn leaf_chunk(
    scene: &Scene,
    origin: V3,
    buf: &Buffer,
    rays: &Rays,
    chunk: &[u32],
    crossings: &[AtomicU32],
) {
    for &j in chunk {
        let c = scene.centers.get(j as usize);
        let v = [c[0] - origin[0], c[1] - origin[1], c[2] - origin[2]];
        let a = scene.radii[j as usize];
        let disk = Disk::new(v, scene.normals.get(j as usize), a);
        // (no crossing of a ray shorter than the disk's nearest distance)
        let near = (dot(v, v).sqrt() - a) * (1.0 - 1e-12);
        let mut visit = |c0: usize, c1: usize| {
            let (lo, hi) = (buf.start[c0] as usize, buf.start[c1] as usize);
            test_disk(&disk, near, j, rays, lo, hi, crossings);
        };
        if !buf.ball_cells(v, a, &mut visit) {
            visit(0, buf.n_cells());
        }
    }
}

/// The exact disk test against the rays at positions `lo..hi` longer than `near`, [`LANES`]
/// at a time: the lanes' verdicts first (vectorised, all in f64), then, for each hit of a
/// lane before `hi`, a count unless the ray is the disk's own leaf's.
#[inline(always)]
fn test_disk(
    disk: &Disk,
    near: f64,
    own: u32,
    rays: &Rays,
    lo: usize,
    hi: usize,
    crossings: &[AtomicU32],
) {
    let (n0, n1, n2) = (disk.n[0], disk.n[1], disk.n[2]);
    let (v0, v1, v2) = (disk.v[0], disk.v[1], disk.v[2]);
    let (nv, a2) = (disk.nv, disk.a2);
    let lanes = |a: &[f64], at: usize| -> [f64; LANES] {
        a[at..at + LANES].try_into().expect("padded rays")
    };
    let mut at = lo;
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
            let d = n0 * wx + n1 * wy + n2 * wz;
            let t = nv / d;
            let (q0, q1, q2) = (t * wx - v0, t * wy - v1, t * wz - v2);
            let qq = q0 * q0 + q1 * q1 + q2 * q2;
            let yes = (range[k] > near) & (d != 0.0) & (t > 0.0) & (t < 1.0) & (qq <= a2);
            bits |= u32::from(yes) << k;
        }
        let live = hi - at;
        if live < LANES {
            bits &= (1u32 << live) - 1;
        }
        while bits != 0 {
            let pos = at + bits.trailing_zeros() as usize;
            if rays.leaf[pos] != own {
                crossings[pos].fetch_add(1, Ordering::Relaxed);
            }
            bits &= bits - 1;
        }
        at += LANES;
    }
}
