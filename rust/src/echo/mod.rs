//! The per-leaf spectrum kernel: adds one leaf's unwindowed `A_k exp(j phi_k)` to every band
//! bin (MODEL.md sections 4-5).
//!
//! A leaf's term at bin k is `F(k) exp(-j 2 pi f_k 2r/v)`, with the smooth leaf factor
//! `F = g G L(c, beta) exp(-j psi(c, beta)) / (k r^2)` (times absorption). The round-trip
//! phase advances by a complex recurrence, re-anchored from the exactly reduced phase
//! ([`crate::physics::phase`]) every [`ANCHOR_BINS`] bins.
//!
//! Paper model, smooth path (the default): `F` is analytic in k, its nearest singularity at
//! k = 0 far from the band, so on each block of [`POLY_BLOCK`] bins it is interpolated by a
//! degree-[`POLY_DEG`] polynomial through the exact values at Chebyshev nodes (error about
//! 1e-16 of the leaf's peak). Each leaf is checked: if the last Chebyshev coefficient of any
//! block exceeds [`SMOOTH_TOL`] of the leaf's peak, the leaf falls back to pointwise evaluation.
//! A kinked leaf (`cos(B(c) beta)` crosses zero in the band, `L = max(0, A cos(B beta))`): its
//! blocks past the kink are skipped (`L = 0`), and the block holding the kink interpolates the
//! smooth extension `g` (the cosine unclamped) and zeroes the bins where `B(c) beta >= pi/2`.
//! Pointwise path: the model evaluated at every bin with polynomial elementary functions
//! accurate to ~1e-16 ([`crate::math::vmath`]).
//! Both are branch-free blocks of [`LANES`] bins, vectorised by the compiler and dispatched at
//! run time to AVX-512 or AVX2+FMA code (`multiversion`); the portable build stays x86-64
//! baseline.
//!
//! Scalar path (libm everywhere): physical optics, and paper leaves so small that `B(c) beta`
//! leaves [0, pi]. `mul_add` is used throughout; on CPUs without FMA it is the correctly
//! rounded libm `fma`, so every CPU gets the same bits.

pub mod impulse;
pub mod prepared;
pub mod spectrum;

use crate::physics::leaf::{self, *};
use crate::physics::phase::CyclesPerBin;
use crate::sonar::LeafModel;
pub use prepared::Prepared;
use crate::echo::spectrum::LeafTerm;
use crate::math::vmath::{
    cos_0_pi, erf_in, erf_interval, exp_nonpos, j1_hankel, j1_interval, jinc_small, sincos_unit,
    J1_EDGES,
};
use multiversion::multiversion;
use std::f64::consts::{FRAC_PI_2, PI};

/// Bins per vector block.
pub const LANES: usize = 8;
/// Bins between exact re-anchoring of the phase recurrence (error growth ~ 128 steps * 1e-16).
pub const ANCHOR_BINS: usize = 1024;
/// Bins per interpolation block of the smooth path (a multiple of [`LANES`]).
pub const POLY_BLOCK: usize = 128;
/// Degree of the interpolating polynomial per block.
pub const POLY_DEG: usize = 6;
const NODES: usize = POLY_DEG + 1;
const _: () = assert!(
    NODES < LANES,
    "a block's nodes and its end fit one vector of lanes"
);
/// A block is interpolated only if its polynomial reproduces the exact factor at the block's
/// end (where Chebyshev interpolation errs most) to this fraction of the block's peak |F|, and
/// its last Chebyshev coefficient is below [`CHEB_TOL`] of that peak; otherwise the block is
/// evaluated pointwise.
pub const SMOOTH_TOL: f64 = 1e-12;
/// See [`SMOOTH_TOL`]: a coarse second check (for the analytic factors of the paper model the
/// last coefficient is ~1e-12 of the peak; a kink or noise makes it ~1e-3).
pub const CHEB_TOL: f64 = 1e-6;

/// Per-bin tables shared by all leaves, padded to a multiple of [`LANES`] by repeating the
/// last bin (padded bins are computed and discarded).
#[derive(Clone, Debug)]
pub struct BandTables {
    pub m: usize,
    pub m_pad: usize,
    /// Index of the first band bin (k0), as f64.
    pub k0: f64,
    pub k: Vec<f64>,
    pub inv_k: Vec<f64>,
    /// `k^-0.9065` and `k^0.3523`: `c^p = k^p a^p` splits the paper's powers per bin and leaf.
    pub kp: Vec<f64>,
    pub kq: Vec<f64>,
    /// Absorption in nepers per metre of range (empty when off).
    pub atten: Vec<f64>,
    /// Smooth path: the local variable `t` in [-1, 1] of each bin within its block.
    pub t: Vec<f64>,
    /// Smooth path: node tables, `LANES` entries per block: the `NODES` Chebyshev nodes, then
    /// the block's end (t = 1) for the error check.
    pub nodes: NodeTables,
    /// Monomial coefficients from node values: `a_p = sum_i vinv[i][p] F_i` (by node, the
    /// coefficients in lanes; the lane past the last coefficient is zero).
    pub vinv: [[f64; LANES]; NODES],
    /// Last Chebyshev coefficient from node values: `c_D = sum_i cheb_last[i] F_i`.
    pub cheb_last: [f64; NODES],
    /// The Chebyshev nodes in a block's local variable `t` (the order of `vinv` and
    /// `cheb_last`).
    pub node_t: [f64; NODES],
    /// The band bin (fractional) at which `k^-0.9065` takes a value, as a cubic through four
    /// points of the table (see [`BinOfKp`]).
    pub bin_of_kp: BinOfKp,
}

/// The inverse of the table `kp[j] = k_j^-0.9065` (which falls with the bin): a cubic in
/// `kp` through four Chebyshev points of its range, in Newton's form, found on the table
/// (linear between bins). For [`first_live_bin`]'s first guess: over a 60-80 kHz band it
/// lands within a bin of the crossing, where a chord and a Newton step on the table cost
/// two dependent divisions and four dependent loads (~1.3 % of a 1e6-leaf pulse).
#[derive(Clone, Copy, Debug, Default)]
pub struct BinOfKp {
    /// The points (in `kp`) and the divided differences of the bin through them.
    u: [f64; 4],
    d: [f64; 4],
}

impl BinOfKp {
    fn new(kp: &[f64]) -> BinOfKp {
        let m = kp.len();
        if m < 8 || !(kp[0] > kp[m - 1]) {
            return BinOfKp::default(); // (bin 0 everywhere; the walk does the rest)
        }
        let (hi, lo) = (kp[0], kp[m - 1]);
        let (mid, half) = (0.5 * (hi + lo), 0.5 * (hi - lo));
        let u: [f64; 4] =
            std::array::from_fn(|i| mid + half * ((2 * i + 1) as f64 * PI / 8.0).cos());
        // the bin at each point: the table's bracketing pair, linear between them
        let at = |x: f64| {
            let j = kp.partition_point(|&v| v > x).clamp(1, m - 1);
            let (a, b) = (kp[j - 1], kp[j]);
            (j - 1) as f64 + (a - x) / (a - b)
        };
        let mut d: [f64; 4] = std::array::from_fn(|i| at(u[i]));
        for level in 1..4 {
            for i in (level..4).rev() {
                d[i] = (d[i] - d[i - 1]) / (u[i] - u[i - level]);
            }
        }
        BinOfKp { u, d }
    }

    /// The (fractional) bin where `kp` equals `x`.
    #[inline(always)]
    pub(crate) fn at(&self, x: f64) -> f64 {
        let (u, d) = (&self.u, &self.d);
        let t = d[3].mul_add(x - u[2], d[2]);
        let t = t.mul_add(x - u[1], d[1]);
        t.mul_add(x - u[0], d[0])
    }
}

/// The per-bin tables evaluated at arbitrary (fractional) band-bin positions.
#[derive(Clone, Debug)]
pub struct NodeTables {
    pub n_blocks: usize,
    pub k: Vec<f64>,
    pub inv_k: Vec<f64>,
    pub kp: Vec<f64>,
    pub kq: Vec<f64>,
    pub atten: Vec<f64>,
}

impl BandTables {
    fn tables(&self) -> Tables<'_> {
        (&self.k, &self.inv_k, &self.kp, &self.kq, &self.atten)
    }

    /// `wavenumber(x)` gives k at a (fractional) band-bin position x; `atten_at(f)` the
    /// absorption per metre at the corresponding frequency, when absorption is on.
    pub fn new(
        k0: usize,
        wavenumbers: &[f64],
        atten: &[f64],
        wavenumber: impl Fn(f64) -> f64,
        atten_at: Option<&dyn Fn(f64) -> f64>,
    ) -> Self {
        let m = wavenumbers.len();
        let m_pad = m.div_ceil(LANES) * LANES;
        let pad = |v: &[f64]| -> Vec<f64> {
            let mut out = v.to_vec();
            if let Some(&last) = v.last() {
                out.resize(m_pad, last);
            }
            out
        };
        let k = pad(wavenumbers);

        // Chebyshev nodes of the first kind on each block, and the bins' local variable.
        let tn: [f64; NODES] =
            std::array::from_fn(|i| ((2 * i + 1) as f64 * PI / (2 * NODES) as f64).cos());
        let n_blocks = m.div_ceil(POLY_BLOCK).max(1);
        let block_of = |b: usize| {
            let lo = (b * POLY_BLOCK) as f64;
            let hi = (((b + 1) * POLY_BLOCK).min(m).max(b * POLY_BLOCK + 1) - 1) as f64;
            ((lo + hi) / 2.0, ((hi - lo) / 2.0).max(0.5))
        };
        let t: Vec<f64> = (0..m_pad)
            .map(|j| {
                let (c, h) = block_of((j / POLY_BLOCK).min(n_blocks - 1));
                (j as f64 - c) / h
            })
            .collect();
        let node_x: Vec<f64> = (0..n_blocks * LANES)
            .map(|q| {
                let (c, h) = block_of(q / LANES);
                let i = q % LANES;
                c + h * if i < NODES { tn[i] } else { 1.0 }
            })
            .collect();
        let nodes = NodeTables::at(&node_x, n_blocks, &wavenumber, atten_at);
        // Interpolation matrices: Chebyshev coefficients c_d = (2 - [d=0]) / N sum_i F_i T_d(t_i),
        // then monomials from T_d(t) = sum_p C[d][p] t^p.
        let mut cheb_mono = [[0.0f64; NODES]; NODES];
        cheb_mono[0][0] = 1.0;
        if NODES > 1 {
            cheb_mono[1][1] = 1.0;
        }
        for d in 2..NODES {
            for p in 0..NODES {
                let up = if p > 0 {
                    2.0 * cheb_mono[d - 1][p - 1]
                } else {
                    0.0
                };
                cheb_mono[d][p] = up - cheb_mono[d - 2][p];
            }
        }
        let tdi =
            |d: usize, i: usize| (d as f64 * ((2 * i + 1) as f64 * PI / (2 * NODES) as f64)).cos();
        let mut vinv = [[0.0f64; LANES]; NODES];
        for (i, row) in vinv.iter_mut().enumerate() {
            for (p, v) in row.iter_mut().enumerate().take(NODES) {
                *v = (0..NODES)
                    .map(|d| {
                        (if d == 0 { 1.0 } else { 2.0 }) / NODES as f64
                            * tdi(d, i)
                            * cheb_mono[d][p]
                    })
                    .sum();
            }
        }
        let cheb_last: [f64; NODES] =
            std::array::from_fn(|i| 2.0 / NODES as f64 * tdi(POLY_DEG, i));
        let kp: Vec<f64> = k.iter().map(|&x| x.powf(PAPER_BP)).collect();
        let bin_of_kp = BinOfKp::new(&kp[..m]);
        BandTables {
            t,
            nodes,
            vinv,
            cheb_last,
            node_t: tn,
            m,
            m_pad,
            k0: k0 as f64,
            inv_k: k.iter().map(|&x| 1.0 / x).collect(),
            kp,
            kq: k.iter().map(|&x| x.powf(PAPER_PP)).collect(),
            bin_of_kp,
            atten: pad(atten),
            k,
        }
    }
}

/// `exp(-j 2 pi t)` for `t` in cycles.
#[inline]
pub(crate) fn cis_neg(t: f64) -> (f64, f64) {
    let (s, c) = (2.0 * PI * t).sin_cos();
    (c, -s)
}

#[inline(always)]
fn cmul(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0.mul_add(b.0, -a.1 * b.1), a.0.mul_add(b.1, a.1 * b.0))
}

/// Add one leaf's unwindowed contribution to `re`, `im` (length `m_pad`).
pub fn add_leaf(sonar: &Prepared, t: &LeafTerm, re: &mut [f64], im: &mut [f64]) {
    let tab = &sonar.tables;
    debug_assert!(re.len() == tab.m_pad && im.len() == tab.m_pad);
    let p = &sonar.params;
    let q = CyclesPerBin::new(t.range, p.fs, p.n_samples, p.sound_speed);
    if p.leaf_model == LeafModel::Paper {
        let regime = paper_regime(tab, t);
        if regime == PaperRegime::Zero {
            return; // cos(B beta) <= 0 at every bin: L = 0, the leaf adds nothing
        }
        if regime != PaperRegime::OutOfDomain {
            let leaf = PaperLeaf::new(t);
            // Only a leaf with no zero crossing of the cosine in the band is smooth in k.
            // (kinked leaves: per block, see `paper_blocks`)
            let smooth = regime == PaperRegime::Smooth;
            if tab.atten.is_empty() {
                paper_blocks::<false>(tab, &leaf, &q, smooth, re, im);
            } else {
                paper_blocks::<true>(tab, &leaf, &q, smooth, re, im);
            }
            return;
        }
    }
    if p.leaf_model == LeafModel::PhysicalOptics {
        if tab.atten.is_empty() {
            po_blocks::<false>(tab, t, &q, re, im);
        } else {
            po_blocks::<true>(tab, t, &q, re, im);
        }
        return;
    }
    add_leaf_scalar(sonar, t, &q, re, im);
}

/// Largest last Chebyshev coefficient (of 7, relative to the block's peak) of an interpolated
/// physical-optics block: `g` oscillates, so it is held far below the paper factor's
/// [`CHEB_TOL`] (the interpolant's error then stays ~1e-12 of the block's peak).
const PO_CHEB_TOL: f64 = 1e-10;
/// Bins per physical-optics sub-block, tried where a whole block fails.
const PO_SUB_BLOCK: usize = 32;

/// Physical optics' smooth extension `g = amp (c^2/2) cos(beta) jinc(2 c sin(beta)) / k
/// [exp(-atten r)]` at wavenumber `k` (rad/m): the leaf's factor is `j |g|` (`psi = -pi/2`).
#[inline(always)]
fn po_extension(t: &LeafTerm, k: f64, atten: f64) -> f64 {
    let c = k * t.radius;
    let g = t.amp * (c * c / 2.0) * t.cos_beta * leaf::jinc(2.0 * c * t.sin_beta) / k;
    if atten == 0.0 {
        g
    } else {
        g * (-atten * t.range).exp()
    }
}

/// [`po_extension`] at an interpolation block's `LANES` nodes, wavenumbers `k` (with `1/k`
/// and the absorption `atten`, Np/m): vectorised where every lane's `x = 2 c sin(beta)` lies
/// in one of the C library's intervals for `J1` ([`j1_interval`]: the same rationals,
/// [`jinc_small`] below 2 and the Hankel form [`j1_hankel`] above); lanes that straddle two
/// intervals take libm's `j1` one by one.
#[inline(always)]
fn po_extension_nodes<const ATTEN: bool>(
    t: &LeafTerm,
    k: &[f64; LANES],
    inv_k: &[f64; LANES],
    atten: &[f64; LANES],
) -> [f64; LANES] {
    let mut x = [0.0; LANES];
    for i in 0..LANES {
        x[i] = 2.0 * (k[i] * t.radius) * t.sin_beta;
    }
    // (loops, not `array::from_fn`: its closure was compiled outside the multiversioned caller,
    // where `mul_add` is a library call)
    let mut jinc = [0.0; LANES];
    if x.iter().all(|&x| x >= J1_EDGES[0]) {
        // leaves whose `g` oscillates across the band (the common case of `j1` per bin)
        jinc_hankel::<0>(&x, &mut jinc);
    } else {
        // (the intervals are contiguous: the lanes' least and greatest `x` decide)
        let (lo, hi) = x.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
        match (j1_interval(lo), j1_interval(hi)) {
            (1, 1) => jinc_hankel::<1>(&x, &mut jinc),
            (2, 2) => jinc_hankel::<2>(&x, &mut jinc),
            (3, 3) => jinc_hankel::<3>(&x, &mut jinc),
            (4, 4) => {
                for i in 0..LANES {
                    jinc[i] = jinc_small(x[i]);
                }
            }
            _ => {
                return std::array::from_fn(|i| {
                    po_extension(t, k[i], if ATTEN { atten[i] } else { 0.0 })
                })
            }
        }
    }
    let mut g = [0.0; LANES];
    for i in 0..LANES {
        let c = k[i] * t.radius;
        // g = amp (c^2 / 2) cos(beta) (2 J1(x) / x) / k
        g[i] = t.amp * (c * c / 2.0) * t.cos_beta * jinc[i] * inv_k[i];
    }
    if ATTEN {
        for i in 0..LANES {
            g[i] *= exp_nonpos(-atten[i] * t.range);
        }
    }
    g
}

/// `|g|` ([`po_extension`]) at the bins `j0..j0 + LANES` of a block that failed its checks:
/// vectorised ([`j1_hankel`]) where every lane's `x` is at least 8 (the leaves whose `g`
/// oscillates across the band), otherwise libm's `j1` lane by lane. (Apart from
/// [`po_extension_nodes`]: with its other intervals inlined here, this loop ran 20 % slower
/// for 2 cm leaves.)
#[inline(always)]
fn po_extension_bins<const ATTEN: bool>(tab: &BandTables, t: &LeafTerm, j0: usize) -> [f64; LANES] {
    let (k, inv_k): (&[f64; LANES], &[f64; LANES]) = (lanes(&tab.k, j0), lanes(&tab.inv_k, j0));
    let mut x = [0.0; LANES];
    for i in 0..LANES {
        x[i] = 2.0 * (k[i] * t.radius) * t.sin_beta;
    }
    if !x.iter().all(|&x| x >= J1_EDGES[0]) {
        return std::array::from_fn(|i| {
            let a = if ATTEN { tab.atten[j0 + i] } else { 0.0 };
            po_extension(t, k[i], a).abs()
        });
    }
    let mut g = [0.0; LANES];
    for i in 0..LANES {
        let c = k[i] * t.radius;
        let inv_x = 1.0 / x[i];
        // g = amp (c^2 / 2) cos(beta) (2 J1(x) / x) / k
        g[i] = t.amp * (c * c) * t.cos_beta * (j1_hankel::<0>(x[i], inv_x) * inv_x) * inv_k[i];
    }
    if ATTEN {
        for (v, a) in g.iter_mut().zip(lanes(&tab.atten, j0)) {
            *v *= exp_nonpos(-a * t.range);
        }
    }
    for v in g.iter_mut() {
        *v = v.abs();
    }
    g
}

/// `2 J1(x) / x` on lanes in fdlibm's interval `IV` (0 to 3, `x >= 2`).
#[inline(always)]
fn jinc_hankel<const IV: usize>(x: &[f64; LANES], out: &mut [f64; LANES]) {
    for i in 0..LANES {
        let inv_x = 1.0 / x[i];
        out[i] = 2.0 * j1_hankel::<IV>(x[i], inv_x) * inv_x;
    }
}

/// Physical optics over all bins, per block of [`POLY_BLOCK`] bins: the smooth `g`
/// ([`po_extension`], the C library's Bessel `j1` at the block's nodes only) interpolated and
/// its magnitude taken bin by bin (`||p| - |g|| <= |p - g|`, so the diffraction nulls' corners
/// cost nothing); where a block fails the checks (large leaves: `g` oscillates within it),
/// `|g|` at every bin. The factor is `j |g|`.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn po_blocks<const ATTEN: bool>(
    tab: &BandTables,
    t: &LeafTerm,
    q: &CyclesPerBin,
    re: &mut [f64],
    im: &mut [f64],
) {
    let nt = &tab.nodes;
    let (pw, w8) = phase_steps(q);
    let (mut zr, mut zi) = ([0.0; LANES], [0.0; LANES]);
    let zero = [0.0; LANES];
    // `|p(t)|` at the lanes' local variables `tl`, times `exp(-atten r)` per bin (`scale`).
    // (a loop, not `array::from_fn`, whose closure can be compiled outside this function)
    let interpolated = |cr: &[f64; NODES], tl: &[f64; LANES], j0: usize, scale: bool| {
        let mut out = [0.0; LANES];
        for i in 0..LANES {
            let mut r = cr[POLY_DEG];
            for p in (0..POLY_DEG).rev() {
                r = r.mul_add(tl[i], cr[p]);
            }
            out[i] = if ATTEN && scale {
                r.abs() * (-tab.atten[j0 + i] * t.range).exp()
            } else {
                r.abs()
            };
        }
        out
    };
    for b in 0..nt.n_blocks {
        let j_start = b * POLY_BLOCK;
        let j_end = if b + 1 == nt.n_blocks {
            tab.m_pad
        } else {
            j_start + POLY_BLOCK
        };
        let at = b * LANES;
        let nodes = po_extension_nodes::<ATTEN>(
            t,
            lanes(&nt.k, at),
            lanes(&nt.inv_k, at),
            if ATTEN { lanes(&nt.atten, at) } else { &zero },
        );
        let poly = block_poly(tab, &nodes, &zero, PO_CHEB_TOL);
        // Sub-blocks a quarter as wide shrink the last coefficient ~4^6-fold: try them only
        // where that can pass (with a factor 4 to spare).
        let try_sub = poly.is_none() && {
            let (last, peak) = last_coefficient(tab, &nodes, &zero);
            last <= 4.0 * 4096.0 * PO_CHEB_TOL * peak
        };
        for s0 in (j_start..j_end).step_by(PO_SUB_BLOCK) {
            // Where the block fails, its sub-blocks of PO_SUB_BLOCK bins are tried (`g`
            // without absorption at their own nodes; `exp(-atten r)` per bin), then `j1` per
            // bin.
            let s1 = (s0 + PO_SUB_BLOCK).min(j_end);
            let sub = try_sub.then(|| {
                let (c, h) = (
                    (s0 + s1 - 1) as f64 / 2.0,
                    ((s1 - s0 - 1) as f64 / 2.0).max(0.5),
                );
                let k_at = |x: f64| tab.k[0] * (tab.k0 + x) / tab.k0;
                let k: [f64; LANES] = std::array::from_fn(|i| {
                    k_at(if i < NODES {
                        c + h * tab.node_t[i]
                    } else {
                        c + h
                    })
                });
                let nodes = po_extension_nodes::<false>(t, &k, &k.map(|k| 1.0 / k), &zero);
                (block_poly(tab, &nodes, &zero, PO_CHEB_TOL), c, h)
            });
            for j0 in (s0..s1).step_by(LANES) {
                let fi: [f64; LANES] = match (&poly, &sub) {
                    (Some((cr, _)), _) => interpolated(cr, lanes(&tab.t, j0), j0, false),
                    (None, Some((Some((cr, _)), c, h))) => {
                        let tl = std::array::from_fn(|i| ((j0 + i) as f64 - c) / h);
                        interpolated(cr, &tl, j0, true)
                    }
                    _ => po_extension_bins::<ATTEN>(tab, t, j0),
                };
                accumulate_block(
                    false,
                    j0,
                    tab.k0,
                    q,
                    &pw,
                    w8,
                    &zero,
                    &fi,
                    &mut zr,
                    &mut zi,
                    lanes_mut(re, j0),
                    lanes_mut(im, j0),
                );
            }
        }
    }
}

/// The straightforward per-bin evaluation with libm (any leaf model, any size).
pub fn add_leaf_scalar(
    sonar: &Prepared,
    t: &LeafTerm,
    q: &CyclesPerBin,
    re: &mut [f64],
    im: &mut [f64],
) {
    let model = |c: f64| match sonar.params.leaf_model {
        LeafModel::Paper => leaf::paper(c, t.beta),
        LeafModel::PhysicalOptics => leaf::physical_optics(c, t.cos_beta, t.sin_beta),
    };
    let tab = &sonar.tables;
    for j in 0..tab.m {
        let k = tab.k[j];
        let (l, psi) = model(k * t.radius);
        let mut amp = t.amp * l / k;
        if !tab.atten.is_empty() {
            amp *= (-tab.atten[j] * t.range).exp();
        }
        let phase = -2.0 * PI * q.frac_at(tab.k0 + j as f64) - psi;
        let (s, c) = phase.sin_cos();
        re[j] += amp * c;
        im[j] += amp * s;
    }
}

impl NodeTables {
    fn tables(&self) -> Tables<'_> {
        (&self.k, &self.inv_k, &self.kp, &self.kq, &self.atten)
    }

    /// Tables at band-bin positions `x` (padded by the caller to a multiple of [`LANES`]).
    pub fn at(
        x: &[f64],
        n_blocks: usize,
        wavenumber: &dyn Fn(f64) -> f64,
        atten_at: Option<&dyn Fn(f64) -> f64>,
    ) -> Self {
        let k: Vec<f64> = x.iter().map(|&x| wavenumber(x)).collect();
        NodeTables {
            n_blocks,
            inv_k: k.iter().map(|&v| 1.0 / v).collect(),
            kp: k.iter().map(|&v| v.powf(PAPER_BP)).collect(),
            kq: k.iter().map(|&v| v.powf(PAPER_PP)).collect(),
            atten: match atten_at {
                Some(f) => x.iter().map(|&x| f(x)).collect(),
                None => Vec::new(),
            },
            k,
        }
    }
}

/// Per-leaf constants of the paper model's vector paths.
struct PaperLeaf {
    amp: f64,
    range: f64,
    beta: f64,
    a: f64,
    ap: f64,
    aq: f64,
}

impl PaperLeaf {
    fn new(t: &LeafTerm) -> Self {
        PaperLeaf {
            amp: t.amp,
            range: t.range,
            beta: t.beta,
            a: t.radius,
            ap: t.radius_pow_b,
            aq: t.radius_pow_p,
        }
    }
}

/// The first bin in `lo..=hi` where the paper model's `L` is nonzero (`B(c) beta < pi/2`;
/// `B` falls with k, so the dead bins come first), for `ap = radius^-0.9065`; `lo` when `L > 0`
/// there already, `hi + 1` when `L = 0` throughout. (Inlined into the multiversioned kernels:
/// compiled apart, its `mul_add` and `ceil` were library calls.)
#[inline(always)]
pub(crate) fn first_live_bin(tab: &BandTables, ap: f64, beta: f64, lo: usize, hi: usize) -> usize {
    let x = |j: usize| PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) * beta;
    let (x_lo, x_hi) = (x(lo), x(hi));
    if x_lo < FRAC_PI_2 {
        return lo;
    }
    if x_hi >= FRAC_PI_2 {
        return hi + 1;
    }
    // Bin `lo` is dead and bin `hi` live. `x` falls smoothly with the bin (as k^-0.9065). The
    // first guess is the bin after the table's inverse at the crossing's `kp` (within a bin
    // of it over a 60-80 kHz band); where that is not the answer, one Newton step on the local
    // slope (within a bin or two); then a walk finds the first bin the predicate calls live
    // (the same as bisection, in fewer steps).
    let guess = |j: f64| (j.max(0.0) as usize).clamp(lo + 1, hi);
    let crossing = (FRAC_PI_2 - PAPER_B0 * beta) / (PAPER_B1 * ap * beta);
    let mut j = guess(tab.bin_of_kp.at(crossing).ceil());
    if !(x(j) < FRAC_PI_2 && x(j - 1) >= FRAC_PI_2) && j < hi {
        let (xj, slope) = (x(j), x(j) - x(j + 1));
        if slope > 0.0 {
            j = guess(j as f64 + ((xj - FRAC_PI_2) / slope).ceil());
        }
    }
    while x(j) >= FRAC_PI_2 {
        j += 1; // (ends by `hi`: live)
    }
    while x(j - 1) < FRAC_PI_2 {
        j -= 1; // (ends by `lo + 1`: `lo` dead)
    }
    j
}

/// Where `B(c) beta` (which decreases with k) lies over the band: `L = max(0, A cos(B beta))`
/// is zero at every bin (`Zero`), analytic in k (`Smooth`, no zero crossing of the cosine), or
/// kinked where the cosine crosses zero inside the band (`Kinked`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PaperRegime {
    Zero,
    Smooth,
    Kinked,
    /// `B beta` exceeds pi somewhere: outside the polynomial cosine's domain (tiny leaves).
    OutOfDomain,
}

pub(crate) fn paper_regime(tab: &BandTables, t: &LeafTerm) -> PaperRegime {
    paper_regime_of(tab, t.radius_pow_b, t.beta)
}

/// [`paper_regime`] of a leaf with `radius^-0.9065 = ap` at incidence `beta`.
#[inline(always)]
pub(crate) fn paper_regime_of(tab: &BandTables, ap: f64, beta: f64) -> PaperRegime {
    // (`paper_regime_bits` is the same, branch-free; keep the two in step)
    let x_lo = PAPER_B1.mul_add(tab.kp[tab.m - 1] * ap, PAPER_B0) * beta;
    let x_hi = PAPER_B1.mul_add(tab.kp[0] * ap, PAPER_B0) * beta;
    if x_lo >= FRAC_PI_2 {
        PaperRegime::Zero
    } else if x_hi > PI {
        PaperRegime::OutOfDomain
    } else if x_hi < FRAC_PI_2 {
        PaperRegime::Smooth
    } else {
        PaperRegime::Kinked
    }
}

/// [`paper_regime_of`] as a bit set, branch-free (for a block's lanes at once): one of
/// [`REGIME_ZERO`], [`REGIME_SMOOTH`], [`REGIME_KINKED`]; 0 when out of the domain (or NaN).
#[inline(always)]
pub(crate) fn paper_regime_bits(tab: &BandTables, ap: f64, beta: f64) -> u8 {
    // (the same operations as `paper_regime_of`; keep the two in step)
    let x_lo = PAPER_B1.mul_add(tab.kp[tab.m - 1] * ap, PAPER_B0) * beta;
    let x_hi = PAPER_B1.mul_add(tab.kp[0] * ap, PAPER_B0) * beta;
    let zero = x_lo >= FRAC_PI_2;
    let smooth = !zero & (x_hi < FRAC_PI_2);
    let kinked = !zero & (FRAC_PI_2..=PI).contains(&x_hi);
    (u8::from(zero) * REGIME_ZERO)
        | (u8::from(smooth) * REGIME_SMOOTH)
        | (u8::from(kinked) * REGIME_KINKED)
}

/// [`paper_regime_bits`]' values.
pub(crate) const REGIME_ZERO: u8 = 1;
pub(crate) const REGIME_SMOOTH: u8 = 2;
pub(crate) const REGIME_KINKED: u8 = 4;

/// The leaf factor `F = amp L exp(-j psi) / k [exp(-atten r)]` of the paper model on one block
/// of lanes, from the per-bin tables `k`, `1/k`, `k^-0.9065`, `k^0.3523` (and `atten`); without
/// `CLAMP`, its smooth extension `g` (`L = A cos(B beta)` unclamped: negative past the kink).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn paper_factor<const ATTEN: bool, const CLAMP: bool>(
    lf: &PaperLeaf,
    k: &[f64; LANES],
    inv_k: &[f64; LANES],
    kp: &[f64; LANES],
    kq: &[f64; LANES],
    atten: &[f64],
    fr: &mut [f64; LANES],
    fi: &mut [f64; LANES],
) {
    // exp(-j psi) = exp(-j psi0) (cos e - j sin e), psi = e + psi0, e = erf(P(c)(1.57 - beta))
    let (h0r, h0i) = (PAPER_PSI0.cos(), -PAPER_PSI0.sin());
    let s_ref = PAPER_BETA_REF - lf.beta;
    let mut zz = [0.0; LANES];
    for i in 0..LANES {
        zz[i] = PAPER_P1.mul_add(kq[i] * lf.aq, PAPER_P0) * s_ref;
    }
    // One erf polynomial for the block when all lanes share an interval.
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &z in &zz {
        lo = lo.min(z.abs());
        hi = hi.max(z.abs());
    }
    let (i_lo, i_hi) = (erf_interval(lo), erf_interval(hi));
    let mut e = [0.0; LANES];
    if i_lo == i_hi {
        for i in 0..LANES {
            e[i] = erf_in(i_lo, zz[i]);
        }
    } else {
        for i in 0..LANES {
            e[i] = erf_in(erf_interval(zz[i]), zz[i]);
        }
    }
    for i in 0..LANES {
        let c = k[i] * lf.a;
        let ac = (PAPER_A2 * c).mul_add(c, PAPER_A0);
        let bc = PAPER_B1.mul_add(kp[i] * lf.ap, PAPER_B0);
        let l = ac * cos_0_pi(bc * lf.beta);
        let l = if CLAMP { l.max(0.0) } else { l };
        let (se, ce) = sincos_unit(e[i]);
        let hr = h0r.mul_add(ce, h0i * se);
        let hi_ = h0i.mul_add(ce, -h0r * se);
        let mut amp = lf.amp * l * inv_k[i];
        if ATTEN {
            amp *= exp_nonpos(-atten[i] * lf.range);
        }
        fr[i] = amp * hr;
        fi[i] = amp * hi_;
    }
}

/// Per-position tables: `k`, `1/k`, `k^-0.9065`, `k^0.3523`, absorption (empty when off).
type Tables<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);

/// [`paper_factor`] at the `LANES` table positions from `at`.
#[inline(always)]
fn factor_at<const ATTEN: bool, const CLAMP: bool>(
    lf: &PaperLeaf,
    (k, inv_k, kp, kq, atten): Tables,
    at: usize,
    fr: &mut [f64; LANES],
    fi: &mut [f64; LANES],
) {
    let atten = if ATTEN {
        &atten[at..at + LANES]
    } else {
        &[][..]
    };
    let (k, inv_k, kp, kq) = (lanes(k, at), lanes(inv_k, at), lanes(kp, at), lanes(kq, at));
    paper_factor::<ATTEN, CLAMP>(lf, k, inv_k, kp, kq, atten, fr, fi);
}

/// Lane offsets `w1^i` and the block step `w1^LANES` of the round-trip phase.
#[inline(always)]
fn phase_steps(q: &CyclesPerBin) -> ([(f64, f64); LANES], (f64, f64)) {
    let w1 = cis_neg(q.frac_at(1.0));
    let mut pw = [(1.0, 0.0); LANES];
    for i in 1..LANES {
        pw[i] = cmul(pw[i - 1], w1);
    }
    (pw, cis_neg(q.frac_at(LANES as f64)))
}

/// Accumulate `F z` over one block and advance `z` (re-anchoring at `ANCHOR_BINS`, or here
/// when `anchor`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn accumulate_block(
    anchor: bool,
    j0: usize,
    k0: f64,
    q: &CyclesPerBin,
    pw: &[(f64, f64); LANES],
    w8: (f64, f64),
    fr: &[f64; LANES],
    fi: &[f64; LANES],
    zr: &mut [f64; LANES],
    zi: &mut [f64; LANES],
    re_b: &mut [f64; LANES],
    im_b: &mut [f64; LANES],
) {
    if anchor || j0.is_multiple_of(ANCHOR_BINS) {
        let z0 = cis_neg(q.frac_at(k0 + j0 as f64));
        for i in 0..LANES {
            (zr[i], zi[i]) = cmul(z0, pw[i]);
        }
    }
    for i in 0..LANES {
        re_b[i] = fr[i].mul_add(zr[i], (-fi[i]).mul_add(zi[i], re_b[i]));
        im_b[i] = fr[i].mul_add(zi[i], fi[i].mul_add(zr[i], im_b[i]));
        let nr = zr[i].mul_add(w8.0, -zi[i] * w8.1);
        let ni = zr[i].mul_add(w8.1, zi[i] * w8.0);
        zr[i] = nr;
        zi[i] = ni;
    }
}

fn lanes(v: &[f64], j0: usize) -> &[f64; LANES] {
    v[j0..j0 + LANES]
        .try_into()
        .expect("tables are padded to LANES")
}

fn lanes_mut(v: &mut [f64], j0: usize) -> &mut [f64; LANES] {
    (&mut v[j0..j0 + LANES])
        .try_into()
        .expect("accumulators are padded to LANES")
}

/// The magnitude of a block's last Chebyshev coefficient from its node lanes, and the peak of
/// its node values.
#[inline(always)]
fn last_coefficient(tab: &BandTables, fr: &[f64; LANES], fi: &[f64; LANES]) -> (f64, f64) {
    let mut peak = 0.0f64;
    for i in 0..NODES {
        peak = peak.max(fr[i].abs()).max(fi[i].abs());
    }
    let (mut lr, mut li) = (0.0, 0.0);
    for i in 0..NODES {
        lr = tab.cheb_last[i].mul_add(fr[i], lr);
        li = tab.cheb_last[i].mul_add(fi[i], li);
    }
    (lr.abs().max(li.abs()), peak)
}

/// Interpolate one block's factor from its node lanes: monomial coefficients in t, or None
/// when the block fails the smoothness checks (its last Chebyshev coefficient above
/// `cheb_tol` of its peak, or its end value off).
#[inline(always)]
fn block_poly(
    tab: &BandTables,
    fr: &[f64; LANES],
    fi: &[f64; LANES],
    cheb_tol: f64,
) -> Option<([f64; NODES], [f64; NODES])> {
    let (last, peak) = last_coefficient(tab, fr, fi);
    if !(last <= cheb_tol * peak) {
        return None;
    }
    // (a whole vector of coefficients per node, the nodes in order)
    let mut cr_l = [0.0f64; LANES];
    let mut ci_l = [0.0f64; LANES];
    for i in 0..NODES {
        for p in 0..LANES {
            cr_l[p] = tab.vinv[i][p].mul_add(fr[i], cr_l[p]);
            ci_l[p] = tab.vinv[i][p].mul_add(fi[i], ci_l[p]);
        }
    }
    let cr: [f64; NODES] = std::array::from_fn(|p| cr_l[p]);
    let ci: [f64; NODES] = std::array::from_fn(|p| ci_l[p]);
    // At t = 1 the polynomial is the sum of its coefficients; compare with the exact end value.
    let (er, ei) = (
        cr.iter().sum::<f64>() - fr[NODES],
        ci.iter().sum::<f64>() - fi[NODES],
    );
    if !(er.abs().max(ei.abs()) <= SMOOTH_TOL * peak.max(fr[NODES].abs()).max(fi[NODES].abs())) {
        return None;
    }
    Some((cr, ci))
}

/// Blocks whose node values and interpolants are computed together before their bins (their
/// dependent chains overlap; one block at a time, each waited on the last).
const STAGE: usize = 8;

/// The paper model over all bins: per block of [`POLY_BLOCK`] bins, the interpolated factor
/// (`smooth`) or the factor at every bin (pointwise), then the phase and the accumulation.
/// Blocks go in stages of [`STAGE`]: first every block's node values, then its interpolant,
/// then its bins.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn paper_blocks<const ATTEN: bool>(
    tab: &BandTables,
    lf: &PaperLeaf,
    q: &CyclesPerBin,
    smooth: bool,
    re: &mut [f64],
    im: &mut [f64],
) {
    let nt = &tab.nodes;
    let (pw, w8) = phase_steps(q);
    let (mut zr, mut zi) = ([0.0; LANES], [0.0; LANES]);
    let (mut fr, mut fi) = ([0.0; LANES], [0.0; LANES]);
    let mut anchor = false;
    let x_at = |j: usize| PAPER_B1.mul_add(tab.kp[j] * lf.ap, PAPER_B0) * lf.beta;
    for b0 in (0..nt.n_blocks).step_by(STAGE) {
        let nb = STAGE.min(nt.n_blocks - b0);
        // Per block of the stage: its bins, its first live bin (None: L = 0 throughout), and
        // whether it is interpolated (then its node values).
        let mut span = [(0usize, 0usize, None::<usize>, false); STAGE];
        let (mut nr, mut ni) = ([[0.0; LANES]; STAGE], [[0.0; LANES]; STAGE]);
        for (s, sp) in span.iter_mut().enumerate().take(nb) {
            let b = b0 + s;
            let j_start = b * POLY_BLOCK;
            let j_end = if b + 1 == nt.n_blocks {
                tab.m_pad
            } else {
                j_start + POLY_BLOCK
            };
            // For a kinked leaf, decide per block: x = B(c) beta decreases with k, so a block
            // whose smallest x is >= pi/2 holds only L = 0, and one whose largest x is < pi/2
            // is smooth.
            let last = j_end.min(tab.m) - 1;
            let (block_smooth, block_zero) = if smooth {
                (true, false)
            } else {
                (x_at(j_start) < FRAC_PI_2, x_at(last) >= FRAC_PI_2)
            };
            if block_zero {
                *sp = (j_start, j_end, None, false);
                continue;
            }
            // The first bin where L > 0 (x falls with k; in a smooth block, the first).
            let live = if block_smooth {
                j_start
            } else {
                first_live_bin(tab, lf.ap, lf.beta, j_start, last)
            };
            // The block's interpolant; in a block holding the kink, that of the smooth
            // extension g (its bins before `live` zeroed), when at least a quarter of the block
            // is live (then the interpolant's error, a fraction of |g| over the block, stays
            // within a few times that of the live part). Otherwise the live bins are evaluated
            // pointwise.
            let interpolate = block_smooth || last + 1 - live >= POLY_BLOCK / 4;
            *sp = (j_start, j_end, Some(live), interpolate);
            if interpolate {
                let q0 = b * LANES;
                factor_at::<ATTEN, false>(lf, nt.tables(), q0, &mut nr[s], &mut ni[s]);
            }
        }
        let polys: [Option<([f64; NODES], [f64; NODES])>; STAGE] = std::array::from_fn(|s| {
            if s < nb && span[s].3 {
                block_poly(tab, &nr[s], &ni[s], CHEB_TOL)
            } else {
                None
            }
        });
        for (&(j_start, j_end, live, _), poly) in span.iter().zip(&polys).take(nb) {
            let Some(live) = live else {
                // L = 0 here: nothing to add; the phase is anchored afresh at the next block
                anchor = true;
                continue;
            };
            for j0 in (j_start..j_end).step_by(LANES) {
                if j0 + LANES <= live {
                    // all zero: skip, and anchor the phase afresh at the next lanes
                    anchor = true;
                    continue;
                }
                match poly {
                    Some((cr, ci)) => {
                        let t = lanes(&tab.t, j0);
                        for i in 0..LANES {
                            let (mut r, mut m) = (cr[POLY_DEG], ci[POLY_DEG]);
                            for p in (0..POLY_DEG).rev() {
                                r = r.mul_add(t[i], cr[p]);
                                m = m.mul_add(t[i], ci[p]);
                            }
                            fr[i] = r;
                            fi[i] = m;
                        }
                        if j0 < live {
                            for i in 0..live - j0 {
                                (fr[i], fi[i]) = (0.0, 0.0);
                            }
                        }
                    }
                    None => {
                        factor_at::<ATTEN, true>(lf, tab.tables(), j0, &mut fr, &mut fi);
                    }
                }
                accumulate_block(
                    std::mem::take(&mut anchor),
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::absorption::Atmosphere;
        use crate::test_util::prepared_with as sonar_with;

    fn sonar(atmosphere: Option<Atmosphere>, min_ka: f64) -> Prepared {
        sonar_with(|p| {
            p.atmosphere = atmosphere;
            p.min_ka = min_ka;
        })
    }

    /// Spectra of one leaf by each path: (smooth, pointwise, scalar libm).
    fn paths(s: &Prepared, t: &LeafTerm) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let tab = &s.tables;
        let q = CyclesPerBin::new(
            t.range,
            s.params.fs,
            s.params.n_samples,
            s.params.sound_speed,
        );
        let lf = PaperLeaf {
            amp: t.amp,
            range: t.range,
            beta: t.beta,
            a: t.radius,
            ap: t.radius.powf(PAPER_BP),
            aq: t.radius.powf(PAPER_PP),
        };
        let z = || (vec![0.0; tab.m_pad], vec![0.0; tab.m_pad]);
        let join = |(r, i): (Vec<f64>, Vec<f64>)| {
            r[..tab.m]
                .iter()
                .chain(&i[..tab.m])
                .copied()
                .collect::<Vec<f64>>()
        };
        let atten = !tab.atten.is_empty();
        let run = |smooth: bool| {
            let (mut r, mut i) = z();
            if atten {
                paper_blocks::<true>(tab, &lf, &q, smooth, &mut r, &mut i)
            } else {
                paper_blocks::<false>(tab, &lf, &q, smooth, &mut r, &mut i)
            };
            join((r, i))
        };
        let (r1, r2) = (run(true), run(false));
        let (mut r3, mut i3) = z();
        add_leaf_scalar(s, t, &q, &mut r3, &mut i3);
        (r1, r2, join((r3, i3)))
    }

    fn max_rel(a: &[f64], b: &[f64]) -> f64 {
        let peak = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        if peak == 0.0 {
            return if a.iter().all(|&x| x == 0.0) {
                0.0
            } else {
                f64::INFINITY
            };
        }
        a.iter()
            .zip(b)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            / peak
    }

    fn leaves() -> Vec<LeafTerm> {
        let mut out = Vec::new();
        for &radius in &[1e-3, 3e-3, 0.01, 0.025, 0.05, 0.2, 1.0] {
            for &beta in &[
                0.0,
                1e-8,
                0.3,
                0.8,
                1.2,
                1.5,
                1.57,
                std::f64::consts::FRAC_PI_2,
            ] {
                for &range in &[0.05, 1.0, 3.3, 10.19] {
                    out.push(term(0.2 / (range * range), range, beta, radius));
                }
            }
        }
        out
    }

    fn term(amp: f64, range: f64, beta: f64, radius: f64) -> LeafTerm {
        LeafTerm::new(amp, range, beta, radius)
    }

    fn kink_free(s: &Prepared, t: &LeafTerm) -> bool {
        (PAPER_B1 * (s.tables.kp[0] * t.radius.powf(PAPER_BP)) + PAPER_B0) * t.beta < FRAC_PI_2
    }

    #[test]
    fn physical_optics_blocks_match_libm_at_every_bin() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar_with(|p| {
                p.atmosphere = atm;
                p.leaf_model = LeafModel::PhysicalOptics;
                p.min_ka = 0.01;
            });
            let tab = &s.tables;
            let mut u = crate::test_util::uniforms(13);
            for n in 0..600 {
                // radii 0.1 mm - 30 cm; normal, grazing and oblique incidence; near and far
                let radius = 1e-4 * 3000f64.powf(u());
                let beta = match n % 5 {
                    0 => 0.0,
                    1 => std::f64::consts::FRAC_PI_2 * (1.0 - 1e-9 * u()),
                    _ => u() * std::f64::consts::FRAC_PI_2,
                };
                let range = 0.05 + 10.0 * u();
                let t = LeafTerm::new(0.2 / (range * range), range, beta, radius);
                let q =
                    CyclesPerBin::new(range, s.params.fs, s.params.n_samples, s.params.sound_speed);
                let z = || (vec![0.0; tab.m_pad], vec![0.0; tab.m_pad]);
                let ((mut ar, mut ai), (mut br, mut bi)) = (z(), z());
                add_leaf(&s, &t, &mut ar, &mut ai);
                add_leaf_scalar(&s, &t, &q, &mut br, &mut bi);
                // (the bound of the paper model's paths, `max_rel`)
                let m = tab.m;
                let e = max_rel(
                    &[&ar[..m], &ai[..m]].concat(),
                    &[&br[..m], &bi[..m]].concat(),
                );
                assert!(e < 3e-12, "{t:?}: {e:e}");
            }
        }
    }

    #[test]
    fn paper_regime_bits_name_the_regime_exactly() {
        let mut u = crate::test_util::uniforms(11);
        for f_lo in [60e3, 20e3] {
            let s = sonar_with(|p| p.f_lo = f_lo);
            let tab = &s.tables;
            let mut seen = [0usize; 4];
            for _ in 0..200_000 {
                let radius = 1e-4 * 3000f64.powf(u());
                let beta = u() * std::f64::consts::FRAC_PI_2;
                let ap = radius.powf(PAPER_BP);
                let regime = paper_regime_of(tab, ap, beta);
                seen[regime as usize] += 1;
                let want = match regime {
                    PaperRegime::Zero => REGIME_ZERO,
                    PaperRegime::Smooth => REGIME_SMOOTH,
                    PaperRegime::Kinked => REGIME_KINKED,
                    PaperRegime::OutOfDomain => 0,
                };
                assert_eq!(paper_regime_bits(tab, ap, beta), want, "{radius} {beta}");
            }
            assert!(seen.iter().all(|&n| n > 0) || f_lo > 50e3, "{seen:?}");
        }
        let tab = &sonar_with(|_| ()).tables;
        assert_eq!(paper_regime_bits(tab, f64::NAN, 1.0), 0);
        assert_eq!(paper_regime_bits(tab, 1.0, f64::NAN), 0);
    }

    #[test]
    fn first_live_bin_is_the_first_bin_the_predicate_calls_live() {
        // the default band, and a wide one (where the first guess is far off)
        let wide = sonar_with(|p| {
            p.min_ka = 0.01;
            (p.f_lo, p.f_hi) = (15e3, 150e3);
        });
        for s in [sonar(None, 0.01), wide] {
            first_live_bin_matches_the_predicate(&s);
        }
    }

    fn first_live_bin_matches_the_predicate(s: &Prepared) {
        let tab = &s.tables;
        let x = |ap: f64, beta: f64, j: usize| PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) * beta;
        let mut u = crate::test_util::uniforms(11);
        let (mut kinked, m) = (0, tab.m);
        for _ in 0..20_000 {
            let radius = 0.0005 * 600f64.powf(u());
            let (ap, beta) = (radius.powf(PAPER_BP), FRAC_PI_2 * u().sqrt());
            let (lo, hi) = if u() < 0.5 {
                (0, m - 1)
            } else {
                let lo = (u() * m as f64) as usize;
                (lo, lo + ((u() * (m - lo) as f64) as usize).min(m - 1 - lo))
            };
            let want = (lo..=hi)
                .find(|&j| x(ap, beta, j) < FRAC_PI_2)
                .unwrap_or(hi + 1);
            assert_eq!(
                first_live_bin(tab, ap, beta, lo, hi),
                want,
                "{radius} {beta} {lo} {hi}"
            );
            kinked += usize::from(want > lo && want <= hi);
        }
        assert!(kinked > 200, "{kinked}");
    }

    #[test]
    fn the_tables_inverse_of_kp_is_within_a_bin_over_the_default_band() {
        let s = sonar(None, 0.01);
        let tab = &s.tables;
        let worst = (0..tab.m)
            .map(|j| (tab.bin_of_kp.at(tab.kp[j]) - j as f64).abs())
            .fold(0.0f64, f64::max);
        assert!(worst < 0.5, "{worst}");
    }

    #[test]
    fn kinked_leaves_match_libm_with_the_kink_anywhere_in_a_block() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, 0.5);
            let tab = &s.tables;
            for &radius in &[3e-3f64, 0.01, 0.025, 0.05] {
                let ap = radius.powf(PAPER_BP);
                for frac in [0.013, 0.1, 0.37, 0.5, 0.61, 0.83, 0.995] {
                    // beta that puts B(c) beta = pi/2 just past band bin frac * M
                    let j = (frac * tab.m as f64) as usize;
                    let beta = FRAC_PI_2 / PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0) + 1e-12;
                    let t = term(0.2 / 9.0, 3.0, beta, radius);
                    assert_eq!(paper_regime(tab, &t), PaperRegime::Kinked);
                    let (_, blocks, exact) = paths(&s, &t);
                    let e = max_rel(&blocks, &exact);
                    assert!(e < 3e-12, "radius {radius}, kink at {frac}: {e:e}");
                }
            }
        }
    }

    #[test]
    fn smooth_and_pointwise_paths_match_libm_per_leaf() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, 0.5);
            for t in leaves() {
                // Relative to the leaf's peak; where cos(B beta) ~ 0 over the whole band, rounding
                // of B beta alone moves the factor by ~1e-13 of its (small) peak.
                let (smooth, point, exact) = paths(&s, &t);
                let e = max_rel(&point, &exact);
                assert!(e < 3e-12, "pointwise {t:?}: {e:e}");
                if kink_free(&s, &t) {
                    let e = max_rel(&smooth, &exact);
                    assert!(e < 3e-12, "smooth {t:?}: {e:e}");
                }
            }
        }
    }

    fn node_t() -> [f64; LANES] {
        std::array::from_fn(|i| {
            if i < NODES {
                ((2 * i + 1) as f64 * PI / (2 * NODES) as f64).cos()
            } else {
                1.0
            }
        })
    }

    #[test]
    fn block_interpolation_reproduces_polynomials_of_its_degree() {
        let s = sonar(None, 0.5);
        let f = |t: f64| 0.3 - 1.2 * t + 0.5 * t.powi(3) + 1e-8 * t.powi(6);
        let t = node_t();
        let fr: [f64; LANES] = std::array::from_fn(|i| f(t[i]));
        let fi: [f64; LANES] = std::array::from_fn(|i| -2.0 * f(t[i]));
        let (cr, ci) =
            block_poly(&s.tables, &fr, &fi, CHEB_TOL).expect("a degree-6 polynomial is smooth");
        for j in 0..=100 {
            let x = -1.0 + j as f64 / 50.0;
            let horner = |c: &[f64; NODES]| c.iter().rev().fold(0.0, |acc, &a| acc * x + a);
            assert!(
                (horner(&cr) - f(x)).abs() < 1e-14,
                "{x}: {}",
                horner(&cr) - f(x)
            );
            assert!((horner(&ci) + 2.0 * f(x)).abs() < 2e-14);
        }
    }

    #[test]
    fn block_interpolation_is_refused_for_a_kinked_factor() {
        let s = sonar(None, 0.5);
        let t = node_t();
        let fr: [f64; LANES] = std::array::from_fn(|i| t[i].abs());
        assert!(block_poly(&s.tables, &fr, &[0.0; LANES], CHEB_TOL).is_none());
    }

    #[test]
    fn smooth_path_handles_records_with_many_bins() {
        let s = sonar_with(|p| p.n_samples = 1_000_000);
        let t = term(1.0, 3.0, 0.4, 0.02);
        let (smooth, _point, exact) = paths(&s, &t);
        assert!(s.tables.nodes.n_blocks > 300);
        assert!(max_rel(&smooth, &exact) < 1e-12);
    }
}
