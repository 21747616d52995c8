//! The per-leaf spectrum kernel: adds one leaf's `A_k exp(j phi_k)` (unwindowed) to every band
//! bin. This is the straightforward scalar form, exact to rounding (libm for every function).

use crate::leaf_model;
use crate::phase::CyclesPerBin;
use crate::sonar::{LeafModel, Sonar};
use crate::spectrum::LeafTerm;
use std::f64::consts::PI;

/// Scratch space reused across leaves.
pub struct Workspace {
    _m: usize,
}

impl Workspace {
    pub fn new(m: usize) -> Self {
        Workspace { _m: m }
    }
}

/// Add one leaf's unwindowed contribution to `re`, `im`.
pub fn add_leaf(sonar: &Sonar, t: &LeafTerm, _ws: &mut Workspace, re: &mut [f64], im: &mut [f64]) {
    let p = &sonar.params;
    let q = CyclesPerBin::new(t.range, p.fs, p.n_samples, p.sound_speed);
    let model = match p.leaf_model {
        LeafModel::Paper => leaf_model::paper,
        LeafModel::PhysicalOptics => leaf_model::physical_optics,
    };
    for j in 0..sonar.n_bins() {
        let k = sonar.wavenumbers[j];
        let (l, psi) = model(k * t.radius, t.beta);
        let mut amp = t.amp * l / k;
        if !sonar.atten_per_m.is_empty() {
            amp *= (-sonar.atten_per_m[j] * t.range).exp();
        }
        let phase = -2.0 * PI * q.frac_at((sonar.k0 + j) as f64) - psi;
        let (s, c) = phase.sin_cos();
        re[j] += amp * c;
        im[j] += amp * s;
    }
}
