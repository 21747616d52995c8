//! A counting branch piece as the kernels take it ([`BranchTerm`]), the one or two points its
//! echo is summed as, and the exact kernel that adds a piece to every band bin.
//!
//! A piece's term at bin k is `amp f(k) exp(j pi/4) exp(-j 2 k r)` (times absorption; `amp`
//! holds the near-field factor [`crate::physics::branch::divergence`]), with
//! `f = c0 sqrt(k) sinc(k X)`, `c0 = (l/2) sqrt(a cos(gamma) s / pi)`, `X = l sin(gamma) s`,
//! `s = cos(beta/2)` of the bistatic angle (1 heard at the emitter)
//! ([`crate::physics::branch::cylinder_po`]), and `r` the reference point's range plus the
//! piece's mean Fresnel lag ([`crate::physics::branch::fresnel_lag`]). Where `k X` is small
//! across the band the factor is smooth and the piece is one point at range `r`. Where it is
//! not, the sinc would oscillate across the band; then the identity
//! `sinc(k X) exp(-j 2 k r) = [exp(-j 2 k (r - X/2)) - exp(-j 2 k (r + X/2))] / (2 j k X)`
//! splits the piece into its two edges, points at ranges `r -+ X/2` with the smooth factors
//! `+- c0 exp(-j pi/4) / (2 X sqrt(k))`. Either way each point is a smooth factor times a
//! round-trip phase, summed like a smooth leaf: interpolated per block at Chebyshev nodes,
//! checked, and evaluated bin by bin where a block fails.
use crate::echo::exact::{accumulate_block, block_poly, phase_steps, CHEB_TOL};
use crate::echo::prepared::Prepared;
use crate::echo::receivers::heard_amplitude;
use crate::echo::tables::{lanes, lanes_mut, BandTables, LANES, POLY_BLOCK, POLY_DEG};
use crate::echo::term::leaf_amp;
use crate::lobe::{HeardPiece, PieceMember};
use crate::physics::bistatic::lag_range;
use crate::physics::branch::{divergence, fresnel_lag, sinc, CYLINDER_PSI};
use crate::physics::phase::CyclesPerBin;
use crate::sonar::Sonar;
use multiversion::multiversion;
use std::f64::consts::PI;

/// A counting branch piece, in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchTerm {
    /// `g G D / r^2` (or `g G D` without spreading), `D` the near-field factor
    /// ([`divergence`]), times any shading factor.
    pub amp: f64,
    /// The range of the piece's reference point (m): its spreading and absorption, and, with
    /// the piece's Fresnel lag, its delay.
    pub range: f64,
    pub length: f64,
    pub radius: f64,
    pub cos_gamma: f64,
    pub sin_gamma: f64,
    /// `cos(beta/2)` of the bistatic angle `beta` (1 heard at the emitter): the wavenumber's
    /// projection on the bisector, `k cos(beta/2)`, takes `k`'s place in the cylinder's factor.
    pub k_scale: f64,
    /// The range (m) of the piece's mean Fresnel lag (`range` heard at the emitter; the
    /// harmonic mean of the two ranges heard by a receiver of its own).
    pub lag_range: f64,
}

/// The term of a counting piece.
pub fn branch_term(sonar: &Sonar, m: &PieceMember) -> BranchTerm {
    BranchTerm {
        amp: leaf_amp(sonar, m.gain, m.range) * divergence(m.radius, m.range, 1.0, m.cos_gamma),
        range: m.range,
        length: m.length,
        radius: m.radius,
        cos_gamma: m.cos_gamma,
        sin_gamma: m.sin_gamma,
        k_scale: 1.0,
        lag_range: m.range,
    }
}

/// The term of a piece heard by a receiver of its own (docs/model.md §9): the bistatic
/// amplitude `g S_tx S_rx D / (r_tx r_rx)` (`D` at the harmonic mean of the two ranges), the
/// delay range `(r_tx + r_rx)/2` (absorption over `r_tx + r_rx`), the tilt from the
/// bisector's broadside, `k cos(beta/2)` in the factor.
pub fn heard_branch_term(sonar: &Sonar, m: &HeardPiece) -> BranchTerm {
    let h = &m.heard;
    let lag_range = lag_range(h.tx.range, h.rx.range);
    let d = divergence(m.radius, lag_range, m.cos_half_bistatic, m.cos_gamma);
    BranchTerm {
        amp: heard_amplitude(sonar, h) * d,
        range: h.range(),
        length: m.length,
        radius: m.radius,
        cos_gamma: m.cos_gamma,
        sin_gamma: m.sin_gamma,
        k_scale: m.cos_half_bistatic,
        lag_range,
    }
}

/// A piece is split into its two edges where `k X` at the band's lowest wavenumber is at
/// least this (then `k X` grows by a third or more across a 60-80 kHz band, and the sinc is
/// far from its smooth centre).
pub const EDGE_MIN_KX: f64 = 2.0;

/// The smooth factor of a point, without its constant phase and absorption.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointForm {
    /// `c sqrt(k) sinc(k x)`.
    Sinc { c: f64, x: f64 },
    /// `c / sqrt(k)`.
    Edge { c: f64 },
}

impl PointForm {
    #[inline(always)]
    pub fn at(&self, k: f64) -> f64 {
        match *self {
            PointForm::Sinc { c, x } => c * k.sqrt() * sinc(k * x),
            PointForm::Edge { c } => c / k.sqrt(),
        }
    }
}

/// One point of a piece's echo: its round-trip delay as a range (m), the range of its
/// absorption (the reference point's, m), its smooth factor and its constant phase
/// `(cos, sin)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BranchPoint {
    pub delay: f64,
    pub range: f64,
    pub form: PointForm,
    pub phase: (f64, f64),
}

/// The points of a piece's echo (one, or its two edges; see the module's comment) for a band
/// whose lowest wavenumber is `k_min`.
pub fn branch_points(t: &BranchTerm, k_min: f64) -> ([BranchPoint; 2], usize) {
    // (k_scale = 1 heard at the emitter: the products below keep their bits)
    let c0 = t.amp * 0.5 * t.length * (t.radius * t.cos_gamma * t.k_scale / PI).sqrt();
    let x = t.length * t.sin_gamma * t.k_scale;
    // exp(-j psi) = exp(j pi/4)
    let (s, c) = (-CYLINDER_PSI).sin_cos();
    let r = t.range + fresnel_lag(t.length, t.cos_gamma, t.lag_range);
    if k_min * x < EDGE_MIN_KX {
        let p = BranchPoint {
            delay: r,
            range: t.range,
            form: PointForm::Sinc { c: c0, x },
            phase: (c, s),
        };
        return ([p; 2], 1);
    }
    // c0 exp(j pi/4) / (2 j X) = (c0 / (2 X)) exp(-j pi/4)
    let e = PointForm::Edge { c: c0 / (2.0 * x) };
    let near = BranchPoint {
        delay: r - 0.5 * x,
        range: t.range,
        form: e,
        phase: (c, -s),
    };
    let far = BranchPoint {
        delay: r + 0.5 * x,
        phase: (-c, s),
        ..near
    };
    ([near, far], 2)
}

/// Add one piece's unwindowed echo to `re`, `im` (length `m_pad`).
pub fn add_branch(sonar: &Prepared, t: &BranchTerm, re: &mut [f64], im: &mut [f64]) {
    let tab = &sonar.tables;
    let p = &sonar.params;
    let (pts, n) = branch_points(t, tab.k[0]);
    for pt in &pts[..n] {
        let q = CyclesPerBin::new(pt.delay, p.fs, p.n_samples, p.sound_speed);
        if tab.atten.is_empty() {
            point_blocks::<false>(tab, pt, &q, re, im);
        } else {
            point_blocks::<true>(tab, pt, &q, re, im);
        }
    }
}

/// A point's factor `F = form(k) [exp(-atten r)]` (real; its constant phase apart) at the
/// `LANES` wavenumbers `k` with absorption `atten` (Np/m, read only with `ATTEN`).
#[inline(always)]
fn factor_lanes<const ATTEN: bool>(pt: &BranchPoint, k: &[f64], atten: &[f64]) -> [f64; LANES] {
    let mut g = [0.0; LANES];
    for i in 0..LANES {
        g[i] = pt.form.at(k[i]);
        if ATTEN {
            g[i] *= (-atten[i] * pt.range).exp();
        }
    }
    g
}

/// One point over all bins, per block of [`POLY_BLOCK`] bins: its factor interpolated from
/// the block's Chebyshev nodes (checked as a smooth leaf's), else evaluated at every bin; times
/// its constant phase and the round-trip phase.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn point_blocks<const ATTEN: bool>(
    tab: &BandTables,
    pt: &BranchPoint,
    q: &CyclesPerBin,
    re: &mut [f64],
    im: &mut [f64],
) {
    let nt = &tab.nodes;
    let (pw, w8) = phase_steps(q);
    let (mut zr, mut zi) = ([0.0; LANES], [0.0; LANES]);
    let zero = [0.0; LANES];
    let (pc, ps) = pt.phase;
    for b in 0..nt.n_blocks {
        let j_start = b * POLY_BLOCK;
        let j_end = if b + 1 == nt.n_blocks {
            tab.m_pad
        } else {
            j_start + POLY_BLOCK
        };
        let at = b * LANES;
        let nodes = factor_lanes::<ATTEN>(
            pt,
            lanes(&nt.k, at),
            if ATTEN { lanes(&nt.atten, at) } else { &zero },
        );
        let poly = block_poly(tab, &nodes, &zero, CHEB_TOL);
        for j0 in (j_start..j_end).step_by(LANES) {
            let g = match &poly {
                Some((cr, _)) => {
                    let t = lanes(&tab.t, j0);
                    let mut g = [0.0; LANES];
                    for i in 0..LANES {
                        let mut r = cr[POLY_DEG];
                        for p in (0..POLY_DEG).rev() {
                            r = r.mul_add(t[i], cr[p]);
                        }
                        g[i] = r;
                    }
                    g
                }
                None => factor_lanes::<ATTEN>(
                    pt,
                    lanes(&tab.k, j0),
                    if ATTEN { lanes(&tab.atten, j0) } else { &zero },
                ),
            };
            let (mut fr, mut fi) = ([0.0; LANES], [0.0; LANES]);
            for i in 0..LANES {
                fr[i] = g[i] * pc;
                fi[i] = g[i] * ps;
            }
            accumulate_block(
                false,
                j0,
                tab.k0,
                q,
                &pw,
                w8,
                &fr,
                &fi,
                &mut zr,
                &mut zi,
                lanes_mut(re, j0),
                lanes_mut(im, j0),
            );
        }
    }
}

/// The windowed band spectrum of branch terms, summed in their order in fixed chunks (see
/// [`crate::echo::spectrum::sum_chunked`]).
pub fn sum_branch_terms(sonar: &Prepared, terms: &[BranchTerm]) -> (Vec<f64>, Vec<f64>) {
    let (mut re, mut im) = sum_branch_terms_unwindowed(sonar, terms);
    for j in 0..re.len() {
        re[j] *= sonar.window[j];
        im[j] *= sonar.window[j];
    }
    (re, im)
}

/// [`sum_branch_terms`] without the window.
pub fn sum_branch_terms_unwindowed(sonar: &Prepared, terms: &[BranchTerm]) -> (Vec<f64>, Vec<f64>) {
    crate::echo::spectrum::sum_chunked(sonar, add_branch, terms)
}
