//! The fast spectrum (`method = "fast"`): a type-1 NUFFT in the round-trip delays, with each
//! leaf's smooth frequency factor interpolated across the band.
//!
//! With `f_k = (k0 + m) fs / n` and `q_i = fs 2 r_i / (n v)` (delay in cycles per bin), a leaf's
//! term is `F_i(m) exp(-2 pi j (k0 + m) q_i)`. The factor `F_i` (beampattern, leaf model, 1/k,
//! absorption) is analytic across the band for all but kinked leaves, so it is replaced by its
//! polynomial interpolant through `P` Chebyshev nodes of the band: `F_i(m) = sum_q F_i(t_q)
//! l_q(t_m)` (Lagrange basis). Then
//!
//! `Y_m = w_m sum_q l_q(t_m) U_q(m - m_c)`,
//! `U_q(k) = sum_i [F_i(t_q) exp(-2 pi j (k0 + m_c) q_i)] exp(-2 pi j k frac(q_i))`,
//!
//! `P` type-1 NUFFTs that share their points, so each leaf's kernel weights are computed once
//! and reused for every channel. The error budget: the interpolation error of each leaf and the
//! NUFFT error are each held to `tol / 5`. (Below [`K_FACTOR_TOL`] the channels carry `k F`,
//! which is smoother across the band, and the Lagrange rows divide by `k` per bin; the check
//! on `k F`'s coefficients then bounds `F`'s error to within `k_max / k_min = 4/3` of that.)
//! A leaf whose last Chebyshev coefficient says its interpolant may err more (physical-optics leaves with diffraction nulls in the band, a few
//! others) is summed exactly instead.
//!
//! Kinked paper-model leaves, where `cos(B(c) beta)` crosses zero inside the band so that the
//! factor `max(0, g)` has a corner, need not be summed exactly: `g` itself is smooth, so when
//! the factor's zero side is the shorter, `g` goes through the NUFFT like any leaf and its
//! interpolant is subtracted, bin by bin, on the zero side; when the live side is the
//! shorter, the interpolant is added there instead. See [`paper_batch`]. Kinked leaves that
//! fail a first pass's check go to sub-bands ([`crate::fast::subband`]), where they need far fewer
//! nodes: in the first pass's own tasks where it has few ([`KINKED_IN_TASKS_UP_TO`]), else in
//! a later pass ([`leftover_pass`]).

pub mod nufft;
pub mod prepared;
pub mod pulse;
pub mod subband;

use crate::error::{invalid, Result};
use crate::echo::{
    cis_neg, first_live_bin, paper_regime, paper_regime_bits, NodeTables, PaperRegime, LANES,
    REGIME_KINKED, REGIME_ZERO,
};
use crate::physics::leaf;
use crate::physics::leaf::{
    PAPER_A0, PAPER_A2, PAPER_B0, PAPER_B1, PAPER_BETA_REF, PAPER_P0, PAPER_P1, PAPER_PSI0,
};
use crate::lobe::Member;
use crate::fast::nufft::{Type1Plan, MAX_W};
use crate::physics::phase::CyclesPerBin;
use crate::scene::Scene;
use crate::sonar::LeafModel;
pub use prepared::FastSonar;
use crate::echo::spectrum::{leaf_term, sum_terms, LeafTerm};
use crate::fast::subband::{KinkPass, KinkedLeaf, KinkedShare};
use crate::math::vmath::{
    cis_neg_cycles, cos_0_pi_k, erf_cheb_lanes, erf_exp_cheb_lanes, exp_nonpos_d, sincos_unit_k,
};
use multiversion::multiversion;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use std::f64::consts::PI;

/// First positive zero of the Bessel function J1.
const J1_FIRST_ZERO: f64 = 3.831_705_970_207_512;

/// Largest number of interpolation nodes.
pub const MAX_NODES: usize = 16;
/// The most leaves per parallel task (each task spreads into its own grid; grids are added in
/// order).
pub const FAST_CHUNK: usize = 65_536;
/// Second-pass chunk lengths are whole multiples of this.
const SUB_CHUNK: usize = 1024;

/// Leaves per task per point of its spread grid, at least (where there are leaves enough for
/// four tasks): each task zeroes its own grid and the grids are summed, which at fewer leaves
/// per point costs more than a few percent of the spreading (at 1e5 leaves and the default
/// record, 14 tasks of 7168 leaves took 2.48 ms, 4 tasks of 25,600 2.32 ms on 2 threads).
const LEAVES_PER_GRID_POINT: usize = 10;

/// Leaves per parallel task for `n` leaves spread onto grids of `grid_points` points: 4 to 16
/// tasks, as many as keep [`LEAVES_PER_GRID_POINT`], of about 4096 to [`FAST_CHUNK`] leaves (a
/// function of `n` and the grid only, so that results do not depend on the thread count).
/// The tasks are of equal length but for the last, which is at most one leaf per task
/// shorter: a short last task leaves a thread idle at the end (16 tasks of 63,488 for 1e6
/// leaves, the last 47,680, left one thread idle ~0.6 ms of a 25 ms pulse).
pub fn chunk_len(n: usize, grid_points: usize) -> usize {
    let tasks = (n / (LEAVES_PER_GRID_POINT * grid_points.max(1))).clamp(4, 16);
    let len = n.div_ceil(tasks).clamp(4096, FAST_CHUNK);
    n.div_ceil(n.div_ceil(len).max(1)).max(1)
}
/// Spread grids kept for reuse between calls, and their total size in bytes. A fresh grid
/// per task (about 200 KB at the default record) cost page faults and the kernel's zeroing:
/// ~12% of a 1e5-leaf spectrum on one thread. Zeroing a reused grid in place is cheaper.
static GRID_POOL: std::sync::Mutex<(Vec<Vec<f64>>, usize)> = std::sync::Mutex::new((Vec::new(), 0));
/// The most bytes of grids kept in [`GRID_POOL`].
const GRID_POOL_BYTES: usize = 64 << 20;

/// A zeroed spread grid of `len` values (reused when one is kept).
pub(crate) fn take_grid(len: usize) -> Vec<f64> {
    let reused = {
        // (the latest kept grid that is long enough: the pool holds grids of several sizes,
        // band and sub-band, and growing a short one reallocates, copies and page-faults)
        let mut pool = GRID_POOL.lock().unwrap_or_else(|e| e.into_inner());
        let at = pool.0.iter().rposition(|g| g.capacity() >= len);
        let g = at.map(|i| pool.0.swap_remove(i));
        if let Some(g) = &g {
            pool.1 -= g.capacity() * 8;
        }
        g
    };
    match reused {
        Some(mut g) => {
            g.clear();
            g.resize(len, 0.0);
            g
        }
        None => vec![0.0; len],
    }
}

/// Keep a grid for [`take_grid`] (dropped when the pool is full).
pub(crate) fn give_grid(g: Vec<f64>) {
    let bytes = g.capacity() * 8;
    let mut pool = GRID_POOL.lock().unwrap_or_else(|e| e.into_inner());
    if pool.1 + bytes <= GRID_POOL_BYTES {
        pool.1 += bytes;
        pool.0.push(g);
    }
}

/// The tightest tolerance the fast path accepts (the interpolants' floor is ~2e-14).
pub const MIN_TOL: f64 = 1e-13;

/// Worst-case Chebyshev coefficient `|c_p| / max|F|` of the paper model's leaf factor over the
/// 60-80 kHz band, measured over radii 0.45 mm - 30 cm, all kink-free incidence angles, with and
/// without absorption (decay ~10x per degree).
const WORST_CHEB: [f64; 17] = [
    1.0, 4.8e-1, 2.2e-1, 5.3e-2, 1.0e-2, 1.6e-3, 2.1e-4, 2.5e-5, 2.8e-6, 2.9e-7, 2.9e-8, 2.7e-9,
    2.3e-10, 2.0e-11, 1.5e-12, 1.1e-13, 1.7e-14,
];

/// Below this tolerance the channels carry `k F` instead of the leaf factor `F`: across the
/// 60-80 kHz band `k F` needs fewer nodes for leaves of a few centimetres (at 1e-6 nearly all
/// pass the check at five nodes, against 95% for `F`); at 1e-3 `F` needs one node fewer.
pub const K_FACTOR_TOL: f64 = 1e-4;

/// Number of Chebyshev nodes for a tolerance: the last coefficient of the worst leaf is at
/// most `2 tol` (its interpolation error, about a tenth of that, stays below `tol / 5`).
pub fn nodes_for_tol(tol: f64) -> usize {
    (2..=MAX_NODES)
        .find(|&p| WORST_CHEB[p - 1] <= 2.0 * tol)
        .unwrap_or(MAX_NODES)
}

/// Everything the fast path needs for one sonar and tolerance.
pub struct FastPlan {
    pub tol: f64,
    /// Number of Chebyshev nodes (channels).
    pub p: usize,
    /// Tables at the nodes (band-bin positions), padded to a multiple of `LANES`.
    pub(crate) nodes: NodeTables,
    /// `c_{P-1} = sum_q cheb_last[q] F_q`.
    cheb_last: Vec<f64>,
    /// `l_q(t_m)`, divided by `k_m` where the channels carry `k F`, by node: row-major
    /// (P, M + LB), zero past the band (whole vectors of bins).
    lagrange_t: Vec<f64>,
    /// The nodes' band-bin positions.
    node_x: Vec<f64>,
    /// What the node values are multiplied by: 1 where the channels carry `k F`, `1/k_q`
    /// where they carry `F` itself (see [`K_FACTOR_TOL`]).
    node_scale: Vec<f64>,
    pub nufft: Type1Plan,
    /// `m_c = M / 2`: output mode `k` is band bin `m = k + m_c`.
    m_c: usize,
    /// The largest node wavenumber and node scale (a bound of a kinked leaf's scale; see
    /// [`KINK_FLOOR`]).
    k_top: f64,
    scale_top: f64,
}

impl FastPlan {
    pub fn new(sonar: &FastSonar, tol: f64) -> Result<FastPlan> {
        FastPlan::with_nodes(sonar, tol, nodes_for_tol(tol))
    }

    /// A plan with `p` Chebyshev nodes (at most [`MAX_NODES`]).
    pub fn with_nodes(sonar: &FastSonar, tol: f64, p: usize) -> Result<FastPlan> {
        if !(MIN_TOL..1.0).contains(&tol) {
            return invalid(format!(
                "tol must be in [{MIN_TOL:e}, 1) for the fast method, got {tol:e} (use method='exact' for exact sums)"
            ));
        }
        let m = sonar.n_bins();
        let p = p.clamp(1, MAX_NODES).min(m.max(1));
        let tn: Vec<f64> = (0..p)
            .map(|q| ((2 * q + 1) as f64 * PI / (2 * p) as f64).cos())
            .collect();
        let half = (m as f64 - 1.0) / 2.0;
        let node_x: Vec<f64> = tn.iter().map(|&t| half * (1.0 + t)).collect();
        let padded = p.div_ceil(LANES) * LANES;
        let mut padded_x = node_x.clone();
        padded_x.resize(padded, node_x[0]);
        let atten = |x: f64| sonar.atten_at(x);
        let nodes = NodeTables::at(
            &padded_x,
            1,
            &|x| sonar.wavenumber_at(x),
            if sonar.params.atmosphere.is_some() {
                Some(&atten)
            } else {
                None
            },
        );
        let cheb = |d: usize, t: f64| (d as f64 * t.clamp(-1.0, 1.0).acos()).cos();
        let cheb_last = tn
            .iter()
            .map(|&t| 2.0 / p as f64 * cheb(p - 1, t))
            .collect();
        let times_k = tol < K_FACTOR_TOL;
        let node_scale: Vec<f64> = (0..p)
            .map(|q| if times_k { 1.0 } else { nodes.inv_k[q] })
            .collect();
        let mut lagrange = Vec::with_capacity(m * p);
        for j in 0..m {
            let t = if m > 1 {
                2.0 * j as f64 / (m - 1) as f64 - 1.0
            } else {
                0.0
            };
            // channels of `k F`: the Lagrange rows take the 1/k back, bin by bin
            let inv_k = if times_k {
                1.0 / sonar.tables.k[j]
            } else {
                1.0
            };
            for &tq in &tn {
                let mut l = 1.0 / p as f64;
                for d in 1..p {
                    l += 2.0 / p as f64 * cheb(d, tq) * cheb(d, t);
                }
                lagrange.push(l * inv_k);
            }
        }
        let row = m + LB;
        let mut lagrange_t = vec![0.0; p * row];
        for j in 0..m {
            for q in 0..p {
                lagrange_t[q * row + j] = lagrange[j * p + q];
            }
        }
        let nufft = Type1Plan::new(m, tol / 5.0)?;
        let k_top = (0..p).fold(0.0f64, |mx, q| mx.max(nodes.k[q]));
        let scale_top = node_scale.iter().fold(0.0f64, |mx, &x| mx.max(x));
        Ok(FastPlan {
            tol,
            p,
            nodes,
            cheb_last,
            lagrange_t,
            node_x,
            k_top,
            scale_top,
            node_scale,
            nufft,
            m_c: m / 2,
        })
    }
}

/// Fast plans of one sonar, by tolerance (building one costs a few milliseconds: quadrature of
/// the kernel's transform, FFT planning, the Lagrange table).
#[derive(Default)]
pub struct PlanCache(std::sync::Mutex<Vec<(u64, std::sync::Arc<FastPlan>)>>);

impl Clone for PlanCache {
    fn clone(&self) -> Self {
        PlanCache::default()
    }
}

impl std::fmt::Debug for PlanCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PlanCache")
    }
}

impl PlanCache {
    /// The plan for `tol`, built on first use.
    pub fn get(&self, sonar: &FastSonar, tol: f64) -> Result<std::sync::Arc<FastPlan>> {
        self.get_with_nodes(sonar, tol, nodes_for_tol(tol))
    }

    /// The plan for `tol` with `p` nodes, built on first use.
    pub fn get_with_nodes(
        &self,
        sonar: &FastSonar,
        tol: f64,
        p: usize,
    ) -> Result<std::sync::Arc<FastPlan>> {
        let key = tol.to_bits() ^ ((p as u64) << 56);
        if let Some((_, p)) = self
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .iter()
            .find(|(k, _)| *k == key)
        {
            return Ok(p.clone());
        }
        let plan = std::sync::Arc::new(FastPlan::with_nodes(sonar, tol, p)?);
        let mut guard = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if guard.len() >= 32 {
            guard.remove(0);
        }
        guard.push((key, plan.clone()));
        Ok(plan)
    }
}

/// How one leaf enters the fast sum.
enum Route {
    Skip,
    Direct,
    Spread,
}

/// The physical-optics leaf factor at the nodes, into `fr`, `fi`; decides the route. (The
/// paper model goes through [`paper_batch`], eight leaves at a time.)
#[inline(always)]
fn po_node_values(
    sonar: &FastSonar,
    plan: &FastPlan,
    t: &LeafTerm,
    fr: &mut [f64; MAX_NODES],
    fi: &mut [f64; MAX_NODES],
) -> Route {
    let nt = &plan.nodes;
    let p = plan.p;
    // |2 J1(x)/x| is analytic and bell-shaped only before J1's first zero (x = 3.8317);
    // past it the factor has kinks and oscillates across the band: sum such leaves exactly.
    let x_hi = 2.0 * sonar.tables.k[sonar.tables.m - 1] * t.radius * t.sin_beta;
    if !(x_hi < J1_FIRST_ZERO) {
        return Route::Direct;
    }
    for q in 0..p {
        let k = nt.k[q];
        let (l, psi) = leaf::physical_optics(k * t.radius, t.cos_beta, t.sin_beta);
        let mut amp = t.amp * l * plan.node_scale[q];
        if !nt.atten.is_empty() {
            amp *= (-nt.atten[q] * t.range).exp();
        }
        let (s, c) = (-psi).sin_cos();
        fr[q] = amp * c;
        fi[q] = amp * s;
    }
    let mut peak = 0.0f64;
    let (mut lr, mut li) = (0.0, 0.0);
    for q in 0..p {
        peak = peak.max(fr[q].abs()).max(fi[q].abs());
        lr = plan.cheb_last[q].mul_add(fr[q], lr);
        li = plan.cheb_last[q].mul_add(fi[q], li);
    }
    if peak == 0.0 {
        return Route::Skip;
    }
    if !(lr.abs().max(li.abs()) <= 2.0 * plan.tol * peak) {
        return Route::Direct;
    }
    Route::Spread
}

/// Spread one physical-optics leaf; false when its factor cannot be interpolated to tol (the
/// caller sums it exactly).
#[inline(always)]
pub(crate) fn po_leaf(sonar: &FastSonar, plan: &FastPlan, t: &LeafTerm, grid: &mut [f64]) -> bool {
    let p = plan.p;
    let sp = &sonar.params;
    let (mut fr, mut fi) = ([0.0; MAX_NODES], [0.0; MAX_NODES]);
    match po_node_values(sonar, plan, t, &mut fr, &mut fi) {
        Route::Skip => true,
        Route::Direct => false,
        Route::Spread => {
            let q = CyclesPerBin::new(t.range, sp.fs, sp.n_samples, sp.sound_speed);
            let mut x = q.frac_at(1.0);
            if x < 0.0 {
                x += 1.0;
            }
            let (pr, pi) = cis_neg(q.frac_at(sonar.tables.k0 + plan.m_c as f64));
            let (l0, u) = plan.nufft.offset(x);
            let mut sc = [[0.0; 2]; MAX_NODES];
            for c in 0..p {
                sc[c] = [fr[c] * pr - fi[c] * pi, fr[c] * pi + fi[c] * pr];
            }
            spread_one(plan, grid, u, l0, &sc);
            true
        }
    }
}

/// One task's share: spread grids (P channels, each a run of complex values), the terms
/// added bin by bin, and the leaves deferred to a later pass.
struct Partial {
    grid: Vec<f64>,
    /// Terms added straight to band bins (kinked leaves' sides).
    direct: Direct,
    /// Leaves (indices into the chunk, ascending) the interpolation cannot represent to tol,
    /// but kinked paper-model ones, which go to `kinked` (in order).
    deferred: Vec<usize>,
    kinked: Vec<KinkedLeaf>,
    /// Leaves (indices into the chunk, ascending) routed to the exact sum: outside the paper
    /// model's domain.
    exact: Vec<usize>,
}

/// The most lanes that add nothing in a block of leaves batched whole: each costs a lane of
/// the batch's vector work, about three times what routing a counting leaf alone costs (an
/// estimate from a 1e6-leaf profile: ~12 ns against ~4 ns).
const MAX_SKIP: usize = 4;

/// How far ahead (in terms) a first pass prefetches its terms. Without it the batches waited
/// on memory for the 64-byte terms (`PaperLanes::push` was 28 % of a single-thread profile at
/// 1e5 leaves); with it `fast_sum_terms` ran 16 % (1e5 leaves) and 25 % (1e6) faster on two
/// threads. 64 and 256 measured the same as 128.
const TERMS_AHEAD: usize = 128;

/// Leaves per vector batch of the fast path (16: two AVX-512 vectors per operation, for
/// overlapping dependent chains).
pub(crate) const LB: usize = 16;

/// Add one leaf's weighted strengths to every channel. Channel `c` is a run of complex values
/// (real, imaginary interleaved) at `grid[2 c glen..]`; the leaf adds `w_j s(c)` (`s(c)`: its
/// strength there as `[re, im]`) to its points `l0 + j`: one contiguous run of `WS2` values per
/// channel.
#[inline(always)]
fn spread_channels<const WS2: usize>(
    grid: &mut [f64],
    glen: usize,
    p: usize,
    l0: usize,
    w2: &[f64; WS2],
    s: impl Fn(usize) -> [f64; 2],
) {
    let a = 2 * l0;
    let p = p.min(MAX_NODES);
    // One bounds check per leaf: every channel's run lies in its plane and the grid.
    assert!(a + WS2 <= 2 * glen && 2 * glen * p <= grid.len());
    let base = grid.as_mut_ptr();
    for c in 0..p {
        let [r, i] = s(c);
        let sv: [f64; WS2] = std::array::from_fn(|t| if t % 2 == 0 { r } else { i });
        // SAFETY: `2 c glen + a + WS2 <= 2 (c + 1) glen <= grid.len()` (asserted above), and
        // `grid` is borrowed mutably for the whole call.
        let run = unsafe { &mut *(base.add(2 * c * glen + a) as *mut [f64; WS2]) };
        for t in 0..WS2 {
            run[t] = w2[t].mul_add(sv[t], run[t]);
        }
    }
}

/// Spread one leaf at grid index `l0`, offset `u`: its strengths `sc` (one `[re, im]` per
/// channel) times its kernel weights.
#[inline(always)]
fn spread_one(plan: &FastPlan, grid: &mut [f64], u: f64, l0: usize, sc: &[[f64; 2]; MAX_NODES]) {
    let (p, glen, h) = (plan.p, plan.nufft.grid_len(), &plan.nufft.horner[..]);
    let s = |c: usize| sc[c];
    match plan.nufft.w {
        w @ 0..=8 => {
            let w = &if w == 8 {
                weights4_mirror(&plan.nufft.mirror, [u; 4])
            } else {
                weights4::<8>(h, [u; 4])
            }[0];
            spread_channels::<16>(grid, glen, p, l0, &std::array::from_fn(|t| w[t / 2]), s)
        }
        _ => {
            let w = &weights4::<16>(h, [u; 4])[0];
            spread_channels::<32>(grid, glen, p, l0, &std::array::from_fn(|t| w[t / 2]), s)
        }
    }
}

/// The kernel weights of four points at offsets `u` in [0, 1) (zero past the kernel's width):
/// four independent Horner chains, eight taps at a time (the shape the compiler keeps in
/// vector registers; a loop over all `WS` taps was scalarised at sixteen).
#[inline(always)]
fn weights4<const WS: usize>(h: &[[f64; MAX_W]], u: [f64; 4]) -> [[f64; WS]; 4] {
    let mut a = [[0.0f64; WS]; 4];
    let [u0, u1, u2, u3] = u;
    for t0 in (0..WS).step_by(8) {
        let mut b = [[0.0f64; 8]; 4];
        for c in h.iter().rev() {
            let c: &[f64; 8] = c[t0..t0 + 8].try_into().unwrap();
            for t in 0..8 {
                b[0][t] = b[0][t].mul_add(u0, c[t]);
                b[1][t] = b[1][t].mul_add(u1, c[t]);
                b[2][t] = b[2][t].mul_add(u2, c[t]);
                b[3][t] = b[3][t].mul_add(u3, c[t]);
            }
        }
        for k in 0..4 {
            a[k][t0..t0 + 8].copy_from_slice(&b[k]);
        }
    }
    a
}

/// [`weights4`] for an eight-tap kernel from its mirror form ([`Type1Plan::mirror`]): one
/// Horner chain in `v^2` gives the even and odd parts of taps 0-3 side by side, and
/// `E + v O`, `E - v O` are taps `j` and `7 - j`.
#[inline(always)]
fn weights4_mirror(m: &[[f64; 8]], u: [f64; 4]) -> [[f64; 8]; 4] {
    let v: [f64; 4] = std::array::from_fn(|k| u[k] - 0.5);
    let v2 = v.map(|x| x * x);
    let mut b = [[0.0f64; 8]; 4];
    for c in m.iter().rev() {
        for k in 0..4 {
            for t in 0..8 {
                b[k][t] = b[k][t].mul_add(v2[k], c[t]);
            }
        }
    }
    std::array::from_fn(|k| {
        std::array::from_fn(|t| {
            if t < 4 {
                b[k][t + 4].mul_add(v[k], b[k][t])
            } else {
                (-b[k][11 - t]).mul_add(v[k], b[k][7 - t])
            }
        })
    })
}

/// Spread a batch of leaves (lanes): each live lane's strengths (`sc[c][2 i..2 i + 2]`, real
/// and imaginary) times its kernel weights at offset `u[i]`, from grid index `l0[i]`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spread_lanes(
    plan: &FastPlan,
    grid: &mut [f64],
    u: &[f64; LB],
    l0: &[usize; LB],
    sc: &[[f64; 2 * LB]; MAX_NODES],
    live: &[bool; LB],
) {
    match plan.nufft.w {
        8 => spread_lanes_ws::<8, 16, true>(plan, grid, u, l0, sc, live),
        0..=7 => spread_lanes_ws::<8, 16, false>(plan, grid, u, l0, sc, live),
        _ => spread_lanes_ws::<16, 32, false>(plan, grid, u, l0, sc, live),
    }
}

/// [`spread_lanes`] with `WS` taps (`WS2 = 2 WS` values per channel): the weights of four
/// lanes at a time first (four independent Horner chains), then their spreading.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spread_lanes_ws<const WS: usize, const WS2: usize, const MIRROR: bool>(
    plan: &FastPlan,
    grid: &mut [f64],
    u: &[f64; LB],
    l0: &[usize; LB],
    sc: &[[f64; 2 * LB]; MAX_NODES],
    live: &[bool; LB],
) {
    const { assert!(!MIRROR || WS == 8) };
    let (p, glen, h) = (plan.p, plan.nufft.grid_len(), &plan.nufft.horner[..]);
    for i0 in (0..LB).step_by(4) {
        let u4 = [u[i0], u[i0 + 1], u[i0 + 2], u[i0 + 3]];
        let a: [[f64; WS]; 4] = if MIRROR {
            let m = weights4_mirror(&plan.nufft.mirror, u4);
            std::array::from_fn(|k| std::array::from_fn(|t| if t < 8 { m[k][t] } else { 0.0 }))
        } else {
            weights4::<WS>(h, u4)
        };
        for (k, w) in a.iter().enumerate() {
            let i = i0 + k;
            if live[i] {
                let w2: [f64; WS2] = std::array::from_fn(|t| w[t / 2]);
                let s = |c: usize| [sc[c][2 * i], sc[c][2 * i + 1]];
                spread_channels(grid, glen, p, l0[i], &w2, s);
            }
        }
    }
}

/// From this tolerance up, node values use the short series of [`crate::math::vmath`] (errors
/// below 1e-12, far under the `tol / 5` budget) instead of the full ones (~1e-16).
pub const SHORT_SERIES_TOL: f64 = 1e-9;
/// From this tolerance up, node values use the shortest series: relative errors below 1e-8
/// (erf 1.9e-9, cos 6.6e-10, exp 7.0e-9, all tested), 2.5e-8 after interpolation, still
/// eight times under the `tol / 5` budget. (A term more in each, errors below 1e-9, was 1.5 %
/// slower at 1e5 leaves; shorter sin and cos of the phase gained nothing.)
pub const LOW_SERIES_TOL: f64 = 1e-6;

/// [`paper_nodes_p`] at the precision the plan's tolerance needs.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn paper_nodes<const ATTEN: bool>(
    plan: &FastPlan,
    amp: &[f64; LB],
    range: &[f64; LB],
    beta: &[f64; LB],
    a: &[f64; LB],
    ap: &[f64; LB],
    aq: &[f64; LB],
    s: &mut BatchScratch,
) {
    if plan.tol >= LOW_SERIES_TOL {
        paper_nodes_p::<ATTEN, 2>(plan, amp, range, beta, a, ap, aq, s)
    } else if plan.tol >= SHORT_SERIES_TOL {
        paper_nodes_p::<ATTEN, 1>(plan, amp, range, beta, a, ap, aq, s)
    } else {
        paper_nodes_p::<ATTEN, 0>(plan, amp, range, beta, a, ap, aq, s)
    }
}

/// Work arrays of the paper model's node values and strengths for one batch (lanes = leaves,
/// rows = nodes), made once per task and reused by every batch: rows past the plan's node
/// count are never read, so nothing is zeroed per batch (zeroing and returning these 2 KB
/// arrays by value cost ~7% of a fast pulse).
pub(crate) struct BatchScratch {
    /// The erf's arguments, its Taylor coefficients and its values at the nodes.
    zz: [[f64; LB]; MAX_NODES],
    coef: [[f64; LB]; MAX_NODES],
    ee: [[f64; LB]; MAX_NODES],
    /// Node values of the leaf factor.
    fr: [[f64; LB]; MAX_NODES],
    fi: [[f64; LB]; MAX_NODES],
    /// Strengths (node values times the phase), real and imaginary parts interleaved
    /// (lane `i` at `2 i`, `2 i + 1`), as the spreading reads them.
    sc: [[f64; 2 * LB]; MAX_NODES],
}

impl BatchScratch {
    pub(crate) fn new() -> Box<BatchScratch> {
        let z = [[0.0; LB]; MAX_NODES];
        Box::new(BatchScratch {
            zz: z,
            coef: z,
            ee: z,
            fr: z,
            fi: z,
            sc: [[0.0; 2 * LB]; MAX_NODES],
        })
    }
}

/// Largest `|z_q - z_c| / (|z_c| + 1.5)` for which [`erf_at_nodes`] uses its Taylor series
/// (in the 60-80 kHz band it is at most 0.051; the node values use `K` = 11 and 14 terms at
/// the two finer levels, the fewest for which the truncation stays below the error of the
/// centre's erf: 1.8e-13 and 2.7e-16 worst, tested; one term fewer errs 5x more; at the
/// shortest level 7 terms, 1.9e-9, within that level's budget, see [`LOW_SERIES_TOL`]).
const ERF_TAYLOR_REACH: f64 = 0.055;

/// `erf(z_q)` at the `p` nodes of a batch (lanes = leaves). `z` moves little across the band,
/// so the erf is evaluated once, at the centre `z_c` of each lane's range (`N`-term Chebyshev
/// series), and carried to the nodes by its `K`-term Taylor series:
/// `erf(z_c + d) = erf(z_c) + (2/sqrt(pi)) exp(-z_c^2) sum_n g_n d^(n+1) / (n+1)` with
/// `g_n = (-1)^n H_n(z_c) / n!`, so `g_(n+1) = -(2 z_c g_n + 2 g_(n-1)) / (n+1)`. A batch
/// with a wider range (a band wider than 60-80 kHz) evaluates the erf at every node.
#[inline(always)]
fn erf_at_nodes<const N: usize, const K: usize>(
    p: usize,
    z: &[[f64; LB]; MAX_NODES],
    c: &mut [[f64; LB]; MAX_NODES],
    out: &mut [[f64; LB]; MAX_NODES],
) {
    // z is monotone in frequency: the first and last nodes bound each lane's range
    let mut zc = [0.0; LB];
    let mut fits = true;
    for i in 0..LB {
        zc[i] = 0.5 * (z[0][i] + z[p - 1][i]);
        let half = 0.5 * (z[0][i] - z[p - 1][i]).abs();
        fits &= half <= ERF_TAYLOR_REACH * (zc[i].abs() + 1.5);
    }
    if !fits {
        // the old way: groups of three nodes, so that their Clenshaw chains interleave
        const NG: usize = 3;
        for q0 in (0..p).step_by(NG) {
            let mut zz = [0.0; NG * LB];
            for h in 0..NG {
                zz[h * LB..(h + 1) * LB].copy_from_slice(&z[(q0 + h).min(p - 1)]);
            }
            let e = erf_cheb_lanes::<N, { NG * LB }>(&zz);
            for h in 0..NG.min(p - q0) {
                out[q0 + h].copy_from_slice(&e[h * LB..(h + 1) * LB]);
            }
        }
        return;
    }
    let (e0, ex) = erf_exp_cheb_lanes::<N, LB>(&zc);
    // c_(n+1) = E g_n / (n + 1), E = (2/sqrt(pi)) exp(-z_c^2)
    const { assert!(K <= MAX_NODES) };
    let (mut g0, mut g1) = ([1.0f64; LB], [0.0f64; LB]);
    for i in 0..LB {
        let e = std::f64::consts::FRAC_2_SQRT_PI * ex[i];
        g1[i] = -2.0 * zc[i];
        c[0][i] = e;
        c[1][i] = e * g1[i] * 0.5;
        g0[i] = e;
        g1[i] *= e;
    }
    // (g0, g1) now hold E g_(n-1), E g_n
    for n in 1..K - 1 {
        let m2inv = -2.0 / (n + 1) as f64;
        let inv2 = 1.0 / (n + 2) as f64;
        for i in 0..LB {
            // one FMA on the chain through g1 (g0's product is off it)
            let g2 = (m2inv * zc[i]).mul_add(g1[i], m2inv * g0[i]);
            c[n + 1][i] = g2 * inv2;
            g0[i] = g1[i];
            g1[i] = g2;
        }
    }
    for q in 0..p {
        for i in 0..LB {
            let d = z[q][i] - zc[i];
            let mut acc = c[K - 1][i];
            for cn in c[..K - 1].iter().rev() {
                acc = acc.mul_add(d, cn[i]);
            }
            out[q][i] = acc.mul_add(d, e0[i]);
        }
    }
}

/// Node values of the paper model's leaf factor for a batch of leaves (lanes = leaves):
/// `F(t_q) = amp L exp(-j psi) / k [exp(-atten r)]` at each of the plan's nodes, times `k_q`
/// below [`K_FACTOR_TOL`] (the plan's `node_scale`); `LEVEL`
/// selects the series: 0 full (~1e-16), 1 short (~1e-12), 2 shortest (~1e-9).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn paper_nodes_p<const ATTEN: bool, const LEVEL: u8>(
    plan: &FastPlan,
    amp: &[f64; LB],
    range: &[f64; LB],
    beta: &[f64; LB],
    a: &[f64; LB],
    ap: &[f64; LB],
    aq: &[f64; LB],
    s: &mut BatchScratch,
) {
    let nt = &plan.nodes;
    let (h0r, h0i) = (PAPER_PSI0.cos(), -PAPER_PSI0.sin());
    let BatchScratch {
        zz,
        coef,
        ee,
        fr,
        fi,
        ..
    } = s;
    // The erf's arguments at every node: z_q = P(c_q) (1.57 - beta).
    let p = plan.p;
    for (q, zq) in zz.iter_mut().enumerate().take(p) {
        let kq = nt.kq[q];
        for i in 0..LB {
            zq[i] = PAPER_P1.mul_add(kq * aq[i], PAPER_P0) * (PAPER_BETA_REF - beta[i]);
        }
    }
    if LEVEL == 2 {
        erf_at_nodes::<22, 7>(p, zz, coef, ee)
    } else if LEVEL == 1 {
        erf_at_nodes::<28, 11>(p, zz, coef, ee)
    } else {
        erf_at_nodes::<40, 14>(p, zz, coef, ee)
    }
    for q in 0..p {
        let (k, kp, scale) = (nt.k[q], nt.kp[q], plan.node_scale[q]);
        for i in 0..LB {
            let c = k * a[i];
            let ac = (PAPER_A2 * c).mul_add(c, PAPER_A0);
            let bc = PAPER_B1.mul_add(kp * ap[i], PAPER_B0);
            let cx = if LEVEL == 2 {
                cos_0_pi_k::<7>(bc * beta[i])
            } else if LEVEL == 1 {
                cos_0_pi_k::<9>(bc * beta[i])
            } else {
                cos_0_pi_k::<12>(bc * beta[i])
            };
            // unclamped: smooth leaves are positive anyway; for a kinked leaf this is the
            // smooth extension `g` of its factor (see `paper_batch`)
            let l = ac * cx;
            let ei = ee[q][i];
            let (se, ce) = if LEVEL == 2 {
                sincos_unit_k::<6, 7>(ei)
            } else if LEVEL == 1 {
                sincos_unit_k::<7, 8>(ei)
            } else {
                sincos_unit_k::<11, 12>(ei)
            };
            let hr = h0r.mul_add(ce, h0i * se);
            let hi = h0i.mul_add(ce, -h0r * se);
            let mut am = amp[i] * l * scale;
            if ATTEN {
                let x = -nt.atten[q] * range[i];
                am *= if LEVEL == 2 {
                    exp_nonpos_d::<7>(x)
                } else if LEVEL == 1 {
                    exp_nonpos_d::<10>(x)
                } else {
                    exp_nonpos_d::<13>(x)
                };
            }
            fr[q][i] = am * hr;
            fi[q][i] = am * hi;
        }
    }
}

/// A batch of up to [`LB`] paper-model leaves as lanes (leaf fields side by side), with the
/// first live bin of each kinked leaf ([`NOT_KINKED`] for smooth ones); [`PaperLanes::pad`]
/// fills the missing lanes with the last leaf.
#[derive(Clone, Copy)]
pub(crate) struct PaperLanes {
    pub(crate) n: usize,
    pub(crate) amp: [f64; LB],
    pub(crate) range: [f64; LB],
    pub(crate) beta: [f64; LB],
    /// Radius, `radius^-0.9065`, `radius^0.3523`.
    pub(crate) a: [f64; LB],
    pub(crate) ap: [f64; LB],
    pub(crate) aq: [f64; LB],
    pub(crate) kink: [usize; LB],
    /// A lower bound of the leaf's peak over the whole band, for the smoothness check (0 when
    /// only this band is known; see [`crate::fast::subband`]).
    pub(crate) floor: [f64; LB],
    /// Lanes that add nothing (outside the lobe, or `L = 0` at every bin), in a batch only to
    /// keep a block of candidates whole: computed, never spread, never deferred.
    pub(crate) skip: [bool; LB],
}

/// [`PaperLanes`]' kink entry of a smooth leaf.
pub(crate) const NOT_KINKED: usize = usize::MAX;

impl PaperLanes {
    pub(crate) fn new() -> PaperLanes {
        let z = [0.0; LB];
        PaperLanes {
            n: 0,
            amp: z,
            range: z,
            beta: z,
            a: z,
            ap: z,
            aq: z,
            kink: [NOT_KINKED; LB],
            floor: z,
            skip: [false; LB],
        }
    }

    /// Lanes of up to `LB` terms (smooth or kinked, with their first live bins).
    fn of(sonar: &FastSonar, terms: &[&LeafTerm]) -> PaperLanes {
        let mut l = PaperLanes::new();
        for t in terms {
            let kink = match paper_regime(&sonar.tables, t) {
                PaperRegime::Kinked => kink_bin(sonar, t.radius_pow_b, t.beta),
                _ => NOT_KINKED,
            };
            l.push(t, kink);
        }
        l.pad();
        l
    }

    /// A full block of smooth terms as lanes.
    #[inline(always)]
    fn of_block(block: &[LeafTerm; LB]) -> PaperLanes {
        let mut l = PaperLanes::new();
        for t in block {
            l.push(t, NOT_KINKED);
        }
        l
    }

    /// [`PaperLanes::of_block`] by an in-register transpose of eight 64-byte terms at a time
    /// (the compiler's gathers cost about 5 % of a fast sum over `LeafTerm`s).
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn of_block_avx512(block: &[LeafTerm; LB]) -> PaperLanes {
        use std::arch::x86_64::*;
        const { assert!(std::mem::size_of::<LeafTerm>() == 64 && LB.is_multiple_of(8)) };
        let mut l = PaperLanes::new();
        for h in 0..LB / 8 {
            // rows: the terms' eight fields in declaration order (`LeafTerm` is `repr(C)`)
            let r: [__m512d; 8] =
                std::array::from_fn(|k| _mm512_loadu_pd(&block[8 * h + k].amp as *const f64));
            let t: [__m512d; 8] = std::array::from_fn(|k| {
                let (a, b) = (r[k & !1], r[k | 1]);
                if k % 2 == 0 {
                    _mm512_unpacklo_pd(a, b)
                } else {
                    _mm512_unpackhi_pd(a, b)
                }
            });
            // u[g]: fields g and g + 4 of rows 0-3 (g < 4) or 4-7 (g >= 4)
            let u: [__m512d; 8] = std::array::from_fn(|g| {
                let base = g & 4;
                let (a, b) = (t[base + (g & 1)], t[base + 2 + (g & 1)]);
                if g & 2 == 0 {
                    _mm512_shuffle_f64x2::<0x88>(a, b)
                } else {
                    _mm512_shuffle_f64x2::<0xdd>(a, b)
                }
            });
            let field = |f: usize| {
                let (a, b) = (u[f & 3], u[4 + (f & 3)]);
                if f < 4 {
                    _mm512_shuffle_f64x2::<0x88>(a, b)
                } else {
                    _mm512_shuffle_f64x2::<0xdd>(a, b)
                }
            };
            let at = 8 * h;
            _mm512_storeu_pd(l.amp[at..].as_mut_ptr(), field(0));
            _mm512_storeu_pd(l.range[at..].as_mut_ptr(), field(1));
            _mm512_storeu_pd(l.beta[at..].as_mut_ptr(), field(2));
            _mm512_storeu_pd(l.a[at..].as_mut_ptr(), field(5));
            _mm512_storeu_pd(l.ap[at..].as_mut_ptr(), field(6));
            _mm512_storeu_pd(l.aq[at..].as_mut_ptr(), field(7));
        }
        l.n = LB;
        l
    }

    #[inline(always)]
    pub(crate) fn push(&mut self, t: &LeafTerm, kink: usize) {
        let i = self.n;
        self.amp[i] = t.amp;
        self.range[i] = t.range;
        self.beta[i] = t.beta;
        self.a[i] = t.radius;
        self.ap[i] = t.radius_pow_b;
        self.aq[i] = t.radius_pow_p;
        self.kink[i] = kink;
        self.floor[i] = 0.0;
        self.skip[i] = false;
        self.n = i + 1;
    }

    /// Append lane `k` of `from`, with its first live bin.
    #[inline(always)]
    pub(crate) fn push_lane(&mut self, from: &PaperLanes, k: usize, kink: usize) {
        let i = self.n;
        self.amp[i] = from.amp[k];
        self.range[i] = from.range[k];
        self.beta[i] = from.beta[k];
        self.a[i] = from.a[k];
        self.ap[i] = from.ap[k];
        self.aq[i] = from.aq[k];
        self.kink[i] = kink;
        self.floor[i] = from.floor[k];
        self.skip[i] = false;
        self.n = i + 1;
    }

    /// Ready a full block of lanes (`n = LB`) to go into a batch whole, where each lane is
    /// `out` (not counting: outside the lobe) or `inside` and smooth, kinked or zero at every
    /// bin, and at most [`MAX_SKIP`] lanes add nothing: marks those `skip` (with finite
    /// values, for the batch's unused arithmetic) and gives kinked lanes their first live bin.
    /// False, the lanes' values untouched (their `skip` marks aside), where the block must go
    /// leaf by leaf.
    /// (Inlined: compiled apart from the multiversioned kernels, its `mul_add` would be a
    /// library call.)
    #[inline(always)]
    pub(crate) fn ready_whole(
        &mut self,
        sonar: &FastSonar,
        out: &[bool; LB],
        inside: &[bool; LB],
    ) -> bool {
        let (mut whole, mut n_skip) = (self.n == LB, 0);
        let mut kinked = [false; LB];
        #[allow(clippy::needless_range_loop)]
        for k in 0..LB {
            let bits = paper_regime_bits(&sonar.tables, self.ap[k], self.beta[k]);
            whole &= out[k] | (inside[k] & (bits != 0));
            self.skip[k] = out[k] | (inside[k] & (bits == REGIME_ZERO));
            kinked[k] = inside[k] & (bits == REGIME_KINKED);
            n_skip += usize::from(self.skip[k]);
        }
        if !(whole && n_skip <= MAX_SKIP) {
            return false;
        }
        #[allow(clippy::needless_range_loop)]
        for k in 0..LB {
            if kinked[k] {
                self.kink[k] = kink_bin(sonar, self.ap[k], self.beta[k]);
            }
            if self.skip[k] {
                // (an out lane may be at range 0)
                (self.amp[k], self.range[k], self.beta[k]) = (0.0, 1.0, 0.0);
            }
        }
        true
    }

    /// Lane `i`, a kinked leaf, for the sub-bands (its first live bin and its floor at the
    /// plan's tolerance); None for a smooth one.
    #[inline(always)]
    pub(crate) fn kinked_leaf(
        &self,
        sonar: &FastSonar,
        plan: &FastPlan,
        i: usize,
    ) -> Option<KinkedLeaf> {
        (self.kink[i] != NOT_KINKED)
            .then(|| KinkedLeaf::new(sonar, plan.tol, self.term(i), self.kink[i]))
    }

    /// Lane `i` as a term (its `cos beta`, `sin beta`, which the paper model does not use,
    /// from `beta`).
    pub(crate) fn term(&self, i: usize) -> LeafTerm {
        let (sin_beta, cos_beta) = self.beta[i].sin_cos();
        LeafTerm {
            amp: self.amp[i],
            range: self.range[i],
            beta: self.beta[i],
            cos_beta,
            sin_beta,
            radius: self.a[i],
            radius_pow_b: self.ap[i],
            radius_pow_p: self.aq[i],
        }
    }

    /// Repeat the last leaf in the missing lanes (as smooth: they are computed, never spread).
    pub(crate) fn pad(&mut self) {
        let n = self.n;
        if n == 0 {
            return;
        }
        for i in n..LB {
            self.amp[i] = self.amp[n - 1];
            self.range[i] = self.range[n - 1];
            self.beta[i] = self.beta[n - 1];
            self.a[i] = self.a[n - 1];
            self.ap[i] = self.ap[n - 1];
            self.aq[i] = self.aq[n - 1];
            self.kink[i] = NOT_KINKED;
            self.floor[i] = self.floor[n - 1];
        }
    }
}

/// Calls with fewer leaves than this use the node count of the worst leaf (`nodes_for_tol`);
/// larger ones choose it from a sample of their own leaves.
pub const ADAPT_MIN_LEAVES: usize = 8192;
/// Leaves sampled to choose the node count.
const ADAPT_SAMPLE: usize = 128;

/// The number of Chebyshev nodes for these leaves: from a sample of them (smooth, paper model),
/// the node count each needs for `tol` is read off its Chebyshev coefficients at the plan's
/// node count, and the count with the least expected cost is taken. Leaves that need more
/// fail the per-leaf check and get a second pass at the full count (or the exact sum), so the
/// choice changes the speed, never the error bound.
fn choose_nodes(sonar: &FastSonar, plan: &FastPlan, terms: &[LeafTerm]) -> usize {
    if terms.len() < ADAPT_MIN_LEAVES || sonar.params.leaf_model != LeafModel::Paper {
        return plan.p;
    }
    let stride = (terms.len() / ADAPT_SAMPLE).max(1);
    let sample: Vec<&LeafTerm> = terms.iter().step_by(stride).collect();
    choose_nodes_from(sonar, plan, &sample)
}

/// [`choose_nodes`] from a sample of the call's leaves (paper model; at most [`ADAPT_SAMPLE`]
/// smooth ones are used).
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
pub(crate) fn choose_nodes_from(sonar: &FastSonar, plan: &FastPlan, sample: &[&LeafTerm]) -> usize {
    let sample: Vec<&LeafTerm> = sample
        .iter()
        .copied()
        .filter(|t| paper_regime(&sonar.tables, t) == PaperRegime::Smooth)
        .take(ADAPT_SAMPLE)
        .collect();
    if sample.len() < 32 {
        return plan.p;
    }
    let p = plan.p;
    let atten = !plan.nodes.atten.is_empty();
    // T_d(t_q) for the DCT of node values
    let mut tdq = [[0.0f64; MAX_NODES]; MAX_NODES];
    for (d, row) in tdq.iter_mut().enumerate().take(p) {
        for (q, v) in row.iter_mut().enumerate().take(p) {
            *v = (d as f64 * ((2 * q + 1) as f64 * PI / (2 * p) as f64)).cos();
        }
    }
    let mut need: Vec<usize> = Vec::with_capacity(sample.len());
    let mut s = BatchScratch::new();
    for batch in sample.chunks(LB) {
        let l = PaperLanes::of(sonar, batch);
        let args = (&l.amp, &l.range, &l.beta, &l.a, &l.ap, &l.aq);
        if atten {
            paper_nodes::<true>(plan, args.0, args.1, args.2, args.3, args.4, args.5, &mut s)
        } else {
            paper_nodes::<false>(plan, args.0, args.1, args.2, args.3, args.4, args.5, &mut s)
        }
        let (fr, fi) = (&s.fr, &s.fi);
        // (lanes = leaves, so that the DCT vectorises)
        let mut peak = [0.0f64; LB];
        for q in 0..p {
            for i in 0..LB {
                peak[i] = peak[i].max(fr[q][i].abs()).max(fi[q][i].abs());
            }
        }
        // the last coefficient above 2 tol peak decides: P must reach one past it
        let mut last = [0usize; LB];
        for (d, row) in tdq.iter().enumerate().take(p).skip(1) {
            let (mut cr, mut ci) = ([0.0f64; LB], [0.0f64; LB]);
            for q in 0..p {
                for i in 0..LB {
                    cr[i] += row[q] * fr[q][i];
                    ci[i] += row[q] * fi[q][i];
                }
            }
            for i in 0..LB {
                if (cr[i].abs().max(ci[i].abs()) * 2.0 / p as f64) > 2.0 * plan.tol * peak[i] {
                    last[i] = d;
                }
            }
        }
        need.extend(last[..batch.len()].iter().map(|&l| (l + 2).min(p)));
    }
    // Expected cost per leaf of P nodes (in units of about 1 ns): node values and spreading grow
    // with P; a leaf that needs more goes to a second pass at the plan's full node count.
    let node_cost = |q: usize| q as f64 * (8.0 + 0.5 * plan.nufft.w as f64);
    // (measured: a deferred leaf costs about twice a full-count leaf, plus its copy)
    let second_pass = 2.0 * node_cost(p) + 100.0;
    (2..=p)
        .min_by(|&x, &y| {
            let cost = |q: usize| {
                let fail = need.iter().filter(|&&n| n > q).count() as f64 / need.len() as f64;
                node_cost(q) + fail * second_pass
            };
            cost(x).total_cmp(&cost(y))
        })
        .unwrap_or(p)
}

/// The first band bin where a kinked paper-model leaf's factor is nonzero: below it
/// `B(c) beta >= pi/2` (the cosine is negative and `L` clamps to 0). `B` falls with frequency,
/// so the bins split into a zero side `0..m*` and a live side `m*..M`.
#[inline(always)]
pub(crate) fn kink_bin(sonar: &FastSonar, ap: f64, beta: f64) -> usize {
    first_live_bin(&sonar.tables, ap, beta, 0, sonar.tables.m - 1)
}

/// How a paper-model leaf enters a fast pass.
pub(crate) enum PaperRoute {
    /// `L = 0` at every bin.
    Skip,
    /// Into a batch, with its first live bin when kinked ([`NOT_KINKED`] otherwise).
    Batch(usize),
    /// To the exact sum: outside the paper model's domain.
    Defer,
}

/// The route of a paper-model leaf of regime `regime` with `radius^-0.9065 = ap`.
#[inline(always)]
pub(crate) fn paper_route(sonar: &FastSonar, regime: PaperRegime, ap: f64, beta: f64) -> PaperRoute {
    match regime {
        PaperRegime::Zero => PaperRoute::Skip,
        PaperRegime::Smooth => PaperRoute::Batch(NOT_KINKED),
        PaperRegime::Kinked => PaperRoute::Batch(kink_bin(sonar, ap, beta)),
        PaperRegime::OutOfDomain => PaperRoute::Defer,
    }
}

/// Add `sign g(m) exp(-2 pi j (k0 + m) q)` to `dre`, `dim` (unwindowed band bins, length at
/// least `M + LB`) for the band bins `lo..hi`, with `g` the interpolant through the node
/// values `gr + j gi`: the same values the NUFFT channels give for a spread leaf.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_interpolant(
    sonar: &FastSonar,
    plan: &FastPlan,
    gr: &[f64; MAX_NODES],
    gi: &[f64; MAX_NODES],
    cq: &CyclesPerBin,
    (lo, hi): (usize, usize),
    sign: f64,
    dre: &mut [f64],
    dim: &mut [f64],
) {
    let row = sonar.n_bins() + LB;
    let k0 = sonar.tables.k0;
    // phases advance by LB bins per block (a rotation), re-anchored exactly every ANCHOR
    // blocks; an anchor takes each lane's phase directly, lanes = bins (a chain of one-bin
    // rotations for the lanes' offsets was ~120 cycles of latency per call)
    const ANCHOR: usize = 16;
    let (rr, ri) = cis_neg_cycles(cq.frac_at(LB as f64));
    let mut m0 = lo;
    while m0 < hi {
        let (mut pr, mut pi) = ([0.0; LB], [0.0; LB]);
        for l in 0..LB {
            (pr[l], pi[l]) = cis_neg_cycles(cq.frac_at(k0 + (m0 + l) as f64));
        }
        let end = (m0 + ANCHOR * LB).min(hi);
        while m0 < end {
            let (mut vr, mut vi) = ([0.0; LB], [0.0; LB]);
            for q in 0..plan.p {
                let lq: &[f64; LB] = plan.lagrange_t[q * row + m0..q * row + m0 + LB]
                    .try_into()
                    .unwrap();
                for l in 0..LB {
                    vr[l] = lq[l].mul_add(gr[q], vr[l]);
                    vi[l] = lq[l].mul_add(gi[q], vi[l]);
                }
            }
            let or: &mut [f64; LB] = (&mut dre[m0..m0 + LB]).try_into().unwrap();
            let oi: &mut [f64; LB] = (&mut dim[m0..m0 + LB]).try_into().unwrap();
            for l in 0..LB {
                let w = if m0 + l < hi { sign } else { 0.0 };
                let cr = vr[l].mul_add(pr[l], -vi[l] * pi[l]);
                let ci = vr[l].mul_add(pi[l], vi[l] * pr[l]);
                or[l] = w.mul_add(cr, or[l]);
                oi[l] = w.mul_add(ci, oi[l]);
                let t = pr[l].mul_add(rr, -pi[l] * ri);
                pi[l] = pr[l].mul_add(ri, pi[l] * rr);
                pr[l] = t;
            }
            m0 += LB;
        }
    }
}

/// Unwindowed band-bin accumulators (length `M + LB`) for the terms a fast pass adds directly.
pub(crate) struct Direct {
    pub re: Vec<f64>,
    pub im: Vec<f64>,
}

impl Direct {
    pub(crate) fn new(m: usize) -> Direct {
        Direct {
            re: vec![0.0; m + LB],
            im: vec![0.0; m + LB],
        }
    }

    pub(crate) fn add(&mut self, other: &Direct) {
        for (a, b) in self.re.iter_mut().zip(&other.re) {
            *a += b;
        }
        for (a, b) in self.im.iter_mut().zip(&other.im) {
            *a += b;
        }
    }

    /// Add the exact (unwindowed) sum of `terms`, if any.
    pub(crate) fn add_exact(&mut self, sonar: &FastSonar, terms: &[LeafTerm]) {
        if terms.is_empty() {
            return;
        }
        let (re, im) = crate::echo::spectrum::sum_terms_unwindowed(sonar, terms);
        for (a, b) in self.re.iter_mut().zip(&re) {
            *a += b;
        }
        for (a, b) in self.im.iter_mut().zip(&im) {
            *a += b;
        }
    }
}

/// Values per parallel block of [`add_grids`].
const GRID_SUM_BLOCK: usize = 8192;

/// Add tasks' spread grids into `acc`, in their order at every value (so the sums do not
/// depend on the thread count), in parallel over blocks of the grid; the grids go back to the
/// pool.
pub(crate) fn add_grids(acc: &mut [f64], grids: Vec<Vec<f64>>) {
    acc.par_chunks_mut(GRID_SUM_BLOCK)
        .enumerate()
        .for_each(|(b, a)| {
            let (at, n) = (b * GRID_SUM_BLOCK, a.len());
            for g in &grids {
                for (x, v) in a.iter_mut().zip(&g[at..at + n]) {
                    *x += v;
                }
            }
        });
    grids.into_iter().for_each(give_grid);
}

/// The rounding floor of a kinked leaf's node values, relative to the factor's scale without
/// the cosine (`amp A(c)`, largest over the nodes): near its corner `cos(B beta)` is accurate
/// to ~2e-16 of that scale, not of its own small value. Where the live part is small (a corner
/// in the band's top bins, live values ~1e-4 of the scale) that is ~1e-12 of them, so the
/// check is `|c_last| + KINK_FLOOR scale <= 2 tol live`, and a leaf whose floor alone takes
/// half its budget (`KINK_FLOOR scale > tol live`) is summed exactly: over the whole band
/// when a first pass finds it (sub-bands would meet the same floor, and their exact sums round
/// differently from the band's by ~1e-12 of such a leaf), over the sub-band when a sub-band
/// does. Measured on 20,000 single leaves (radii 3-90 mm, incidence 0-1.5 rad, ranges
/// 0.5-10 m) at `tol = 1e-12`: the worst error against the exact sum was 3.4 tol without this
/// term and 0.24 tol with it (the same for 1e-15 ... 1e-14). It matters only near
/// `tol = 1e-12`: at 1e-6 a leaf fails it only where its live part is under ~1e-8 of its
/// scale. (The exact sum has the same floor, ~1e-12 of such a leaf against mpmath: see the
/// README.)
const KINK_FLOOR: f64 = 3e-15;

/// The paper model's node values, phases and kernel weights for a batch of up to `LB` smooth
/// or kinked leaves (lanes), then the spreading; returns the leaves it did not take
/// ([`Failures`]: not spread, for the caller to defer or sum exactly).
///
/// A kinked leaf's factor is `max(0, g)` with `g` smooth (the unclamped cosine), zero on the
/// bins `0..m*` and `g` on `m*..M`. Where the zero side is the shorter, `g` is spread and its
/// interpolant subtracted on the zero side; where the live side is, the interpolant is added
/// there and nothing is spread: at most `M / 2` bins either way. The error is that of the
/// interpolant on the live side, checked against the peak there (or the lane's
/// [`PaperLanes::floor`], a bound on its peak over a wider band).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn paper_batch<const ATTEN: bool>(
    sonar: &FastSonar,
    plan: &FastPlan,
    lanes: &PaperLanes,
    grid: &mut [f64],
    direct: &mut Direct,
    s: &mut BatchScratch,
) -> Failures {
    let (p, w) = (plan.p, plan.nufft.w);
    let sp = &sonar.params;
    let n = lanes.n;
    let m = sonar.n_bins();
    let PaperLanes {
        amp,
        range,
        beta,
        a,
        ap,
        aq,
        kink,
        floor,
        skip,
        ..
    } = lanes;
    paper_nodes::<ATTEN>(plan, amp, range, beta, a, ap, aq, s);
    let BatchScratch { fr, fi, sc, .. } = s;
    // Smoothness check per lane: the last Chebyshev coefficient against the lane's peak.
    let mut ok = [true; LB];
    let (mut lr, mut li, mut peak) = ([0.0; LB], [0.0; LB], [0.0f64; LB]);
    for q in 0..p {
        for i in 0..LB {
            lr[i] = plan.cheb_last[q].mul_add(fr[q][i], lr[i]);
            li[i] = plan.cheb_last[q].mul_add(fi[q][i], li[i]);
            peak[i] = peak[i].max(fr[q][i].abs()).max(fi[q][i].abs());
        }
    }
    for i in 0..LB {
        peak[i] = peak[i].max(floor[i]);
        ok[i] = lr[i].abs().max(li[i].abs()) <= 2.0 * plan.tol * peak[i];
    }
    // Kinked lanes (their first live bin given): the check against the peak on the live side.
    let mut below_floor = [false; LB];
    if kink.iter().any(|&mk| mk != NOT_KINKED) {
        for i in 0..n {
            let mk = kink[i];
            if mk == NOT_KINKED {
                continue;
            }
            let live = (0..p)
                .filter(|&q| plan.node_x[q] >= mk as f64)
                .fold(floor[i], |mx, q| mx.max(fr[q][i].abs()).max(fi[q][i].abs()));
            // the factor's scale without the cosine, `amp A(c)` times the node's scale: first
            // a bound from the band's top (A grows with c; no absorption), and where that could
            // matter, the largest over the nodes times the weakest absorption (one `exp`)
            let nt = &plan.nodes;
            let c_top = plan.k_top * a[i];
            let mut scale =
                amp[i].abs() * (PAPER_A2 * c_top).mul_add(c_top, PAPER_A0) * plan.scale_top;
            if KINK_FLOOR * scale > 0.01 * plan.tol * live {
                scale = (0..p).fold(0.0f64, |mx, q| {
                    let c = nt.k[q] * a[i];
                    let s = amp[i] * (PAPER_A2 * c).mul_add(c, PAPER_A0) * plan.node_scale[q];
                    mx.max(s.abs())
                });
                if ATTEN {
                    let weakest = nt.atten[..p].iter().fold(f64::INFINITY, |m, &x| m.min(x));
                    scale *= (-weakest * range[i]).exp();
                }
            }
            let floor_err = KINK_FLOOR * scale;
            below_floor[i] = live > 0.0 && floor_err > plan.tol * live;
            ok[i] = live > 0.0 && lr[i].abs().max(li[i].abs()) + floor_err <= 2.0 * plan.tol * live;
        }
    }
    // Phases and grid positions from the exactly reduced delay, lanes = leaves.
    let (mut x, mut pr, mut pi) = ([0.0; LB], [0.0; LB], [0.0; LB]);
    let shift = sonar.tables.k0 + plan.m_c as f64;
    for i in 0..LB {
        let cq = CyclesPerBin::new(range[i], sp.fs, sp.n_samples, sp.sound_speed);
        let f = cq.frac_at(1.0);
        x[i] = if f < 0.0 { f + 1.0 } else { f };
        (pr[i], pi[i]) = cis_neg_cycles(cq.frac_at(shift));
    }
    // Grid positions, lanes = leaves (the weights follow per leaf, lanes = taps).
    let nf = plan.nufft.nf as f64;
    let mut l0f = [0.0; LB];
    let mut u = [0.0; LB];
    for i in 0..LB {
        let left = x[i] * nf - w as f64 / 2.0;
        l0f[i] = left.ceil();
        u[i] = l0f[i] - left;
    }
    // Strengths (node values times the phase), lanes = leaves, then interleaved for the
    // spreading (a loop writing `sc` directly was vectorised over nodes, with gathers and
    // scatters).
    for (q, row) in sc.iter_mut().enumerate().take(p) {
        let (mut re, mut im) = ([0.0; LB], [0.0; LB]);
        for i in 0..LB {
            re[i] = fr[q][i].mul_add(pr[i], -fi[q][i] * pi[i]);
            im[i] = fr[q][i].mul_add(pi[i], fi[q][i] * pr[i]);
        }
        *row = std::array::from_fn(|t| if t % 2 == 0 { re[t / 2] } else { im[t / 2] });
    }
    let mut out = Failures {
        defer: [false; LB],
        exact: [false; LB],
    };
    let mut live = [false; LB];
    for i in 0..n {
        if skip[i] {
            continue;
        }
        if !ok[i] {
            if below_floor[i] {
                out.exact[i] = true;
            } else {
                out.defer[i] = true;
            }
            continue;
        }
        if kink[i] != NOT_KINKED {
            let mk = kink[i];
            let cq = CyclesPerBin::new(range[i], sp.fs, sp.n_samples, sp.sound_speed);
            let gr: [f64; MAX_NODES] = std::array::from_fn(|q| fr[q][i]);
            let gi: [f64; MAX_NODES] = std::array::from_fn(|q| fi[q][i]);
            let (dre, dim) = (&mut direct.re, &mut direct.im);
            if m - mk <= mk {
                // live side the shorter: its interpolant added there, nothing spread
                add_interpolant(sonar, plan, &gr, &gi, &cq, (mk, m), 1.0, dre, dim);
                continue;
            }
            add_interpolant(sonar, plan, &gr, &gi, &cq, (0, mk), -1.0, dre, dim);
        }
        live[i] = true;
    }
    // (integers below 2^51 in size, finite as the ranges are, converted exactly by the
    // 1.5 2^52 shift: vector adds, where `as i64`, saturating, was scalar)
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let pad = plan.nufft.pad as f64;
    let l0: [usize; LB] = std::array::from_fn(|i| {
        ((l0f[i] + pad + SHIFT).to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64) as usize
    });
    spread_lanes(plan, grid, &u, &l0, sc, &live);
    out
}

/// The lanes of a batch that [`paper_batch`] did not take: `defer`, those its interpolant
/// cannot represent to tol (for a later pass); `exact`, kinked lanes whose live part lies
/// below the node values' rounding floor ([`KINK_FLOOR`]), for the exact sum over the whole
/// band (a later pass would only meet the same floor).
pub(crate) struct Failures {
    pub(crate) defer: [bool; LB],
    pub(crate) exact: [bool; LB],
}

#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn spread_chunk(sonar: &FastSonar, plan: &FastPlan, terms: &[LeafTerm], floors: &[f64]) -> Partial {
    let (p, glen) = (plan.p, plan.nufft.grid_len());
    let mut part = Partial {
        grid: take_grid(2 * p * glen),
        direct: Direct::new(sonar.n_bins()),
        deferred: Vec::new(),
        kinked: Vec::new(),
        exact: Vec::new(),
    };
    match sonar.params.leaf_model {
        LeafModel::Paper => {
            // Route by regime; smooth and kinked leaves go through the vector batches.
            let mut lanes = PaperLanes::new();
            let mut ids = [0usize; LB];
            let atten = !plan.nodes.atten.is_empty();
            let mut s = BatchScratch::new();
            let mut flush = |lanes: &mut PaperLanes, ids: &[usize; LB], part: &mut Partial| {
                if lanes.n == 0 {
                    return;
                }
                lanes.pad();
                let (grid, sums) = (&mut part.grid, &mut part.direct);
                let failed = if atten {
                    paper_batch::<true>(sonar, plan, lanes, grid, sums, &mut s)
                } else {
                    paper_batch::<false>(sonar, plan, lanes, grid, sums, &mut s)
                };
                for (k, &id) in ids[..lanes.n].iter().enumerate() {
                    if failed.defer[k] {
                        match lanes.kinked_leaf(sonar, plan, k) {
                            Some(kl) => part.kinked.push(kl),
                            None => part.deferred.push(id),
                        }
                    } else if failed.exact[k] {
                        part.exact.push(id);
                    }
                }
                lanes.n = 0;
            };
            let tab = &sonar.tables;
            for (b, block) in terms.chunks(LB).enumerate() {
                // A block is a batch as it stands where it can be (`ready_whole`); otherwise
                // each leaf goes its route.
                let base = b * LB;
                crate::math::prefetch::ahead::<_, LB>(terms, base + TERMS_AHEAD);
                if let Ok(block) = <&[LeafTerm; LB]>::try_from(block) {
                    let mut bl = {
                        #[cfg(target_arch = "x86_64")]
                        {
                            if multiversion::target::target_cfg_f!(target_feature = "avx512f") {
                                // SAFETY: this clone runs only where AVX-512F is present.
                                unsafe { PaperLanes::of_block_avx512(block) }
                            } else {
                                PaperLanes::of_block(block)
                            }
                        }
                        #[cfg(not(target_arch = "x86_64"))]
                        PaperLanes::of_block(block)
                    };
                    if let Some(f) = floors.get(base..base + LB) {
                        bl.floor.copy_from_slice(f);
                    }
                    if bl.ready_whole(sonar, &[false; LB], &[true; LB]) {
                        flush(&mut bl, &std::array::from_fn(|k| base + k), &mut part);
                        continue;
                    }
                }
                for (k, t) in block.iter().enumerate() {
                    let idx = base + k;
                    let regime = paper_regime(tab, t);
                    match paper_route(sonar, regime, t.radius_pow_b, t.beta) {
                        PaperRoute::Skip => {}
                        PaperRoute::Defer => part.exact.push(idx),
                        PaperRoute::Batch(kink) => {
                            ids[lanes.n] = idx;
                            lanes.push(t, kink);
                            if let Some(&f) = floors.get(idx) {
                                lanes.floor[lanes.n - 1] = f;
                            }
                            if lanes.n == LB {
                                flush(&mut lanes, &ids, &mut part);
                            }
                        }
                    }
                }
            }
            flush(&mut lanes, &ids, &mut part);
        }
        LeafModel::PhysicalOptics => {
            for (idx, t) in terms.iter().enumerate() {
                if !po_leaf(sonar, plan, t, &mut part.grid) {
                    part.deferred.push(idx);
                }
            }
        }
    }
    // Leaves the interpolation cannot represent to tol (ascending): the caller gives them a
    // second pass or sums them exactly.
    part.deferred.sort_unstable();
    part
}

/// Leaves per task of a second pass over `n` deferred leaves: smaller tasks than
/// [`chunk_len`] (a few thousand such leaves would otherwise be one or two uneven tasks), a
/// function of `n` only.
pub(crate) fn second_chunk_len(n: usize) -> usize {
    n.div_ceil(4)
        .clamp(SUB_CHUNK, FAST_CHUNK)
        .div_ceil(SUB_CHUNK)
        * SUB_CHUNK
}

/// The second fast pass over deferred leaves: the plan's full node count, tasks of
/// [`second_chunk_len`], the leaves it still cannot represent summed exactly (None for none).
pub(crate) fn second_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    leaves: &[LeafTerm],
) -> Option<(Vec<f64>, Vec<f64>)> {
    (!leaves.is_empty())
        .then(|| fast_sum_fixed(sonar, plan, leaves, &[], second_chunk_len(leaves.len())))
}

/// Fewer failures than this are summed exactly rather than given a second fast pass.
const SECOND_PASS_MIN: usize = 256;

/// The leaves a first fast pass left, as a windowed band spectrum (None for none): of its
/// failures, the kinked paper-model ones (`kinked`) by sub-bands ([`crate::fast::subband`], where
/// the band has them) and the others (`retry`) by a second pass at the plan's full node count;
/// the exact-routed leaves (`exact`: outside the model's domain, or below a kinked leaf's
/// rounding floor) by the exact sum. The three run side by side and are added in that order.
pub(crate) fn leftover_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    retry: &[LeafTerm],
    kinked: &[KinkedLeaf],
    exact: &[LeafTerm],
    shares: Option<(&KinkPass, Vec<KinkedShare>)>,
) -> Option<(Vec<f64>, Vec<f64>)> {
    if retry.is_empty() && kinked.is_empty() && exact.is_empty() && shares.is_none() {
        return None;
    }
    let subs = match sonar.params.leaf_model {
        LeafModel::Paper => sonar.sub_bands(),
        LeafModel::PhysicalOptics => None,
    };
    let (mut retry2, mut exact2) = (retry.to_vec(), exact.to_vec());
    let kinked = if subs.is_some() {
        kinked
    } else {
        // (no sub-bands: kinked leaves take the second pass too)
        retry2.extend(kinked.iter().map(|k| k.term));
        &[]
    };
    if retry2.len() < SECOND_PASS_MIN {
        // (a second pass costs its grids and transforms: a few hundred exact leaves)
        exact2.append(&mut retry2);
    }
    let ((second, sub), (shared, direct)) = rayon::join(
        || {
            rayon::join(
                || second_pass(sonar, plan, &retry2),
                || {
                    let s = subs.as_ref().filter(|_| !kinked.is_empty())?;
                    // (a sub-band plan cannot fail where the band's did; if one did, the
                    // exact sum stands in)
                    Some(s.kinked_sum(sonar, plan.tol, kinked).unwrap_or_else(|_| {
                        let terms: Vec<LeafTerm> = kinked.iter().map(|k| k.term).collect();
                        sum_terms(sonar, &terms)
                    }))
                },
            )
        },
        || {
            rayon::join(
                || shares.and_then(|(pass, sh)| pass.finish(sonar, sh)),
                || (!exact2.is_empty()).then(|| sum_terms(sonar, &exact2)),
            )
        },
    );
    let m = sonar.n_bins();
    let (mut re, mut im) = (vec![0.0; m], vec![0.0; m]);
    for (pr, pi) in [second, sub, shared, direct].into_iter().flatten() {
        for j in 0..m {
            re[j] += pr[j];
            im[j] += pi[j];
        }
    }
    Some((re, im))
}

/// The windowed band spectrum `(re, im)` of the members by the fast method.
pub fn fast_band_spectrum(
    sonar: &FastSonar,
    plan: &FastPlan,
    scene: &Scene,
    members: &[Member],
) -> (Vec<f64>, Vec<f64>) {
    let terms: Vec<LeafTerm> = members
        .iter()
        .map(|mb| leaf_term(sonar, scene, mb))
        .collect();
    fast_sum_terms(sonar, plan, &terms)
}

/// A first pass's spectrum (`first`: its transforms) plus its leftover leaves' (`left`, from
/// [`leftover_pass`]), the two computed side by side.
pub(crate) fn beside_leftovers(
    left: impl FnOnce() -> Option<(Vec<f64>, Vec<f64>)> + Send,
    first: impl FnOnce() -> (Vec<f64>, Vec<f64>) + Send,
) -> (Vec<f64>, Vec<f64>) {
    let (left, (mut re, mut im)) = rayon::join(left, first);
    if let Some((lr, li)) = left {
        for j in 0..re.len() {
            re[j] += lr[j];
            im[j] += li[j];
        }
    }
    (re, im)
}

/// A first pass of at most this many tasks spreads its kinked leaves in its tasks
/// ([`KinkPass`]); a longer one leaves them to a later pass. With few tasks the later pass's
/// sub-bands are a few small sums after the tasks, run beside the first pass's transforms on
/// two threads: at 1e5 leaves (4 tasks) taking them into the tasks cut `fast_sum_terms` from
/// 1.91 to 1.72 ms. With more, the later pass fills the threads while the transforms run, and
/// in the tasks they cost more (3e5 leaves, 12 tasks: 5.3 against 6.2 ms; 1e6: 16.9 against
/// 18.1 ms).
const KINKED_IN_TASKS_UP_TO: usize = 4;

/// The windowed band spectrum of the given leaf terms by the fast method; `plan` fixes the
/// tolerance and the largest node count (see [`choose_nodes`]).
pub fn fast_sum_terms(sonar: &FastSonar, plan: &FastPlan, terms: &[LeafTerm]) -> (Vec<f64>, Vec<f64>) {
    if rayon::current_thread_index().is_none() {
        // Called from outside the pool: run on a pool thread, so that the parallel steps
        // follow one another there (from outside, each is injected into the pool and this
        // thread sleeps and wakes in between: at 1e5 leaves, ~30 us before the tasks start
        // and ~40 us after they end). The call is then the pool's only work, so its first
        // pass keeps a thread awake for the transforms after it ([`TaskCount`]).
        return rayon::scope(|_| fast_sum_terms_in(sonar, plan, terms, true));
    }
    fast_sum_terms_in(sonar, plan, terms, false)
}

/// [`fast_sum_terms`] on a pool thread; `alone`: the call is the pool's only work (see
/// [`TaskCount::new`]).
fn fast_sum_terms_in(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    alone: bool,
) -> (Vec<f64>, Vec<f64>) {
    let p = choose_nodes(sonar, plan, terms);
    if p < plan.p {
        if let Ok(smaller) = sonar.plans.get_with_nodes(sonar, plan.tol, p) {
            // First pass with fewer nodes; leaves it cannot represent get the full count, in a
            // later pass that runs beside the first pass's transforms.
            let chunk = chunk_len(terms.len(), smaller.nufft.nf);
            // (with few tasks, each spreads its kinked leaves onto sub-band grids of its own)
            let kink = (terms.len().div_ceil(chunk) <= KINKED_IN_TASKS_UP_TO)
                .then(|| KinkPass::new(sonar, plan.tol, p))
                .flatten();
            let first = spread_pass(sonar, &smaller, terms, &[], chunk, kink.as_ref(), alone);
            let retry: Vec<LeafTerm> = first.deferred.iter().map(|&i| terms[i]).collect();
            let exact: Vec<LeafTerm> = first.exact.iter().map(|&i| terms[i]).collect();
            let shares = kink.as_ref().map(|k| (k, first.shares));
            return beside_leftovers(
                || leftover_pass(sonar, plan, &retry, &first.kinked, &exact, shares),
                || {
                    let (grids, sums) = (first.grids, first.sums);
                    finish_grids(sonar, &smaller, grids, (sums.re, sums.im))
                },
            );
        }
    }
    fast_sum_fixed(
        sonar,
        plan,
        terms,
        &[],
        chunk_len(terms.len(), plan.nufft.nf),
    )
}

/// One fast pass at the plan's node count, `chunk` leaves per task: the windowed band
/// spectrum, the leaves it cannot represent (and those outside the model's domain) summed
/// exactly. `floors` (empty, or one per term) are lower bounds of the leaves' peaks over a
/// wider band, for the smoothness check ([`PaperLanes::floor`]).
pub(crate) fn fast_sum_fixed(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
    chunk: usize,
) -> (Vec<f64>, Vec<f64>) {
    let Spread {
        grids,
        mut sums,
        deferred,
        kinked,
        exact,
        ..
    } = spread_pass(sonar, plan, terms, floors, chunk, None, false);
    sums.add_exact(sonar, &rest_terms(terms, deferred, exact, &kinked));
    finish_grids(sonar, plan, grids, (sums.re, sums.im))
}

/// The leaves a fast pass leaves to the exact sum, in its order: the deferred and the
/// exact-routed ones (indices into `terms`) ascending, then the kinked ones.
fn rest_terms(
    terms: &[LeafTerm],
    deferred: Vec<usize>,
    exact: Vec<usize>,
    kinked: &[KinkedLeaf],
) -> Vec<LeafTerm> {
    let mut all: Vec<usize> = deferred.into_iter().chain(exact).collect();
    all.sort_unstable();
    all.iter()
        .map(|&i| terms[i])
        .chain(kinked.iter().map(|k| k.term))
        .collect()
}

/// One task's fast sum of `terms` without its transforms: its spread grid, and its direct
/// bins (unwindowed) with the leaves the grid cannot take summed exactly, as
/// [`fast_sum_fixed`] sums them.
pub(crate) fn spread_task(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
) -> (Vec<f64>, Direct) {
    let part = spread_chunk(sonar, plan, terms, floors);
    let mut direct = part.direct;
    direct.add_exact(
        sonar,
        &rest_terms(terms, part.deferred, part.exact, &part.kinked),
    );
    (part.grid, direct)
}

/// The spreading of one fast pass: the tasks' grids (for [`finish_grids`] to sum), the terms
/// they added bin by bin, and the leaves they left, as ascending indices into the terms (the
/// kinked ones as [`KinkedLeaf`]s).
pub(crate) struct Spread {
    /// The tasks' grids, in order (their sum is the pass's grid).
    grids: Vec<Vec<f64>>,
    sums: Direct,
    /// Leaves the interpolation cannot represent (for a later pass), kinked paper-model ones
    /// apart (in task order).
    pub(crate) deferred: Vec<usize>,
    pub(crate) kinked: Vec<KinkedLeaf>,
    /// Leaves outside the model's domain (for the exact sum).
    pub(crate) exact: Vec<usize>,
    /// The tasks' kinked leaves on their sub-band grids (in task order; empty without a
    /// [`KinkPass`], the kinked leaves then in `kinked`).
    pub(crate) shares: Vec<KinkedShare>,
}

/// The spreading part of a fast pass ([`fast_sum_fixed`]): `chunk` leaves per task, the
/// tasks' grids kept in task order; `alone`: the pass is the pool's only work (see
/// [`TaskCount::new`]).
pub(crate) fn spread_pass(
    sonar: &FastSonar,
    plan: &FastPlan,
    terms: &[LeafTerm],
    floors: &[f64],
    chunk: usize,
    kink: Option<&KinkPass>,
    alone: bool,
) -> Spread {
    let m = sonar.n_bins();
    // A task: its share of the pass, its kinked leaves onto its own sub-band grids.
    let task = |terms: &[LeafTerm], floors: &[f64]| {
        let mut part = spread_chunk(sonar, plan, terms, floors);
        let share = kink.map(|k| k.spread(&std::mem::take(&mut part.kinked)));
        (part, share)
    };
    if terms.len() <= chunk {
        // One task: its grid and sums are the pass's (adding them to zeros changes nothing).
        let (part, share) = task(terms, floors);
        return Spread {
            grids: vec![part.grid],
            sums: part.direct,
            deferred: part.deferred,
            kinked: part.kinked,
            exact: part.exact,
            shares: share.into_iter().collect(),
        };
    }
    let mut grids: Vec<Vec<f64>> = Vec::new();
    let mut sums = Direct::new(m);
    let (mut deferred, mut exact): (Vec<usize>, Vec<usize>) = (Vec::new(), Vec::new());
    let (mut kinked, mut shares) = (Vec::new(), Vec::new());
    let mut offset = 0usize;
    let mut add = |parts: Vec<((Partial, Option<KinkedShare>), usize)>| {
        if grids.len() > 1 {
            // (a later batch: the earlier ones summed into the first grid, in order)
            let rest = grids.split_off(1);
            add_grids(&mut grids[0], rest);
        }
        for ((part, share), len) in parts {
            shares.extend(share);
            deferred.extend(part.deferred.iter().map(|&i| i + offset));
            kinked.extend_from_slice(&part.kinked);
            exact.extend(part.exact.iter().map(|&i| i + offset));
            sums.add(&part.direct);
            offset += len;
            grids.push(part.grid);
        }
    };
    // (16 grids at a time at most: memory stays bounded for long records)
    for (b, batch) in terms.chunks(chunk * 16).enumerate() {
        let tasks = TaskCount::new(batch.len().div_ceil(chunk), alone);
        let parts: Vec<_> = batch
            .par_chunks(chunk)
            .enumerate()
            .map(|(k, c)| {
                let start = b * chunk * 16 + k * chunk;
                let f = floors.get(start..start + c.len()).unwrap_or(&[]);
                tasks.run(|| (task(c, f), c.len()))
            })
            .collect();
        add(parts);
    }
    Spread {
        grids,
        sums,
        deferred,
        kinked,
        exact,
        shares,
    }
}

/// The tasks of one parallel pass, counted as they start and end, so that a pool thread left
/// without a task before the pass is over stays awake for the work after it
/// ([`TaskCount::run`]).
///
/// Left to itself, a rayon worker idle for ~10 us sleeps; the work after a pass (the
/// transforms beside the leftovers, in parallel) then waited ~20 us for the futex wake and
/// ~30-50 us more for the sleeper to start: at 1e5 leaves in most calls, where the tasks end
/// tens of microseconds apart (a 1e5-leaf `fast_sum_terms` took 1.79-1.87 ms with it against
/// 1.96-2.19 ms without, in a timeline of three calls each). Only the order of events
/// changes, never a result. (The fused pulse does without: its tail is the kinked pass,
/// ~1.7 ms at 1e6 leaves, beside which a wake costs little, and with a thread kept awake it
/// measured 2-3 % slower.)
struct TaskCount {
    n: usize,
    started: std::sync::atomic::AtomicUsize,
    done: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    /// Set when the pass is over (the count dropped): the waiting thread stops.
    over: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// Whether a thread has been kept awake for this pass (one at most).
    waiter: std::sync::atomic::AtomicBool,
    /// The pool thread running the pass, where it is alone in the pool (none: no thread is
    /// kept awake).
    owner: Option<usize>,
}

/// The longest a thread waits awake for a pass to end.
const AWAKE_WAIT: std::time::Duration = std::time::Duration::from_micros(1000);

impl TaskCount {
    /// `n` tasks, run from the pool thread that drops the count when the pass is over;
    /// `alone`: the pass is the pool's only work. (Where other work may be queued, such as
    /// the other poses of a flight, an idle thread must take that instead of waiting.)
    fn new(n: usize, alone: bool) -> TaskCount {
        TaskCount {
            n,
            started: 0.into(),
            done: std::sync::Arc::new(0.into()),
            over: std::sync::Arc::new(false.into()),
            waiter: false.into(),
            owner: rayon::current_thread_index().filter(|_| alone),
        }
    }

    /// Run one task. The first thread other than the pass's own to end a task when every
    /// task has started leaves a job behind that spins until the pass is over (at most
    /// [`AWAKE_WAIT`]; on the pass's own thread, should it take the job, until the tasks
    /// are done), so that it is awake for the work after the pass. The pass's own thread,
    /// ending a task when every task has started, spins until all are done (at most
    /// [`AWAKE_WAIT`]), so that it does not sleep before the pass's end.
    fn run<T>(&self, task: impl FnOnce() -> T) -> T {
        use std::sync::atomic::Ordering::{Acquire, Relaxed, Release};
        self.started.fetch_add(1, Relaxed);
        let out = task();
        self.done.fetch_add(1, Release);
        let here = rayon::current_thread_index();
        if self.owner.is_some()
            && here != self.owner
            && self.started.load(Relaxed) == self.n
            && !self.waiter.swap(true, Relaxed)
        {
            let (n, done, over, owner) = (self.n, self.done.clone(), self.over.clone(), self.owner);
            rayon::spawn(move || {
                let own = rayon::current_thread_index() == owner;
                spin_until(|| over.load(Acquire) || (own && done.load(Acquire) >= n));
            });
        } else if self.owner.is_some() && here == self.owner && self.started.load(Relaxed) == self.n
        {
            // The pass's own thread, its last task done while others still run: wait for them
            // awake (a pool thread waiting for a job slept and was woken 17-68 us after the
            // last task ended, in about half of the 1e5-leaf calls of a timeline).
            spin_until(|| self.done.load(Acquire) >= self.n);
        }
        out
    }
}

/// Spin until `ended` holds, at most [`AWAKE_WAIT`].
fn spin_until(ended: impl Fn() -> bool) {
    let t0 = std::time::Instant::now();
    while !ended() && t0.elapsed() < AWAKE_WAIT {
        for _ in 0..32 {
            std::hint::spin_loop();
        }
    }
}

impl Drop for TaskCount {
    fn drop(&mut self) {
        self.over.store(true, std::sync::atomic::Ordering::Release);
    }
}

/// One channel (`span` of each grid) of the tasks' grids summed in their order, as complex
/// values.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn channel_sum(grids: &[Vec<f64>], span: std::ops::Range<usize>) -> Vec<Complex64> {
    let mut acc: Vec<Complex64> = grids[0][span.clone()]
        .chunks_exact(2)
        .map(|v| Complex64::new(v[0], v[1]))
        .collect();
    for g in &grids[1..] {
        for (a, v) in acc.iter_mut().zip(g[span.clone()].chunks_exact(2)) {
            a.re += v[0];
            a.im += v[1];
        }
    }
    acc
}

/// The windowed band spectrum from the tasks' spread grids (their sum, one NUFFT per
/// channel, then the Lagrange combination) plus the unwindowed exactly summed part `direct`.
/// The grids are summed in their order at every value (so the sums do not depend on the
/// thread count) while each channel is copied for its transform, and go back to the pool.
pub(crate) fn finish_grids(
    sonar: &FastSonar,
    plan: &FastPlan,
    grids: Vec<Vec<f64>>,
    direct: (Vec<f64>, Vec<f64>),
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let (p, glen) = (plan.p, plan.nufft.grid_len());
    // One NUFFT per channel, then the Lagrange combination.
    let modes: Vec<Vec<Complex64>> = (0..p)
        .into_par_iter()
        .map(|c| {
            let mut cg = channel_sum(&grids, 2 * c * glen..2 * (c + 1) * glen);
            let mut out = vec![Complex64::new(0.0, 0.0); m];
            plan.nufft.finish(&mut cg, &mut out);
            out
        })
        .collect();
    grids.into_iter().for_each(give_grid);
    lagrange_sum(sonar, plan, &modes, direct)
}

/// `window (direct + sum_c L_c modes_c)` at each band bin, the channels added in order.
#[multiversion(targets("x86_64+avx512f+avx512vl+avx512dq+avx2+fma", "x86_64+avx2+fma"))]
fn lagrange_sum(
    sonar: &FastSonar,
    plan: &FastPlan,
    modes: &[Vec<Complex64>],
    (mut re, mut im): (Vec<f64>, Vec<f64>),
) -> (Vec<f64>, Vec<f64>) {
    let m = sonar.n_bins();
    let row = m + LB;
    re.truncate(m);
    im.truncate(m);
    for (c, mc) in modes.iter().enumerate() {
        let lt = &plan.lagrange_t[c * row..c * row + m];
        for (((r, i), z), &l) in re.iter_mut().zip(im.iter_mut()).zip(mc).zip(lt) {
            // (a product, then a sum: not fused)
            *r += z.re * l;
            *i += z.im * l;
        }
    }
    for ((r, i), &w) in re.iter_mut().zip(im.iter_mut()).zip(&sonar.window) {
        *r *= w;
        *i *= w;
    }
    (re, im)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::absorption::Atmosphere;
    use crate::echo::spectrum::sum_terms;
    use crate::test_util::{rel_l2_pair as rel_l2, sonar_with};

    fn sonar(atm: Option<Atmosphere>, model: LeafModel) -> FastSonar {
        sonar_with(|p| {
            p.atmosphere = atm;
            p.leaf_model = model;
        })
    }

    use crate::test_util::uniforms;

    /// Leaves of every kind: tiny to huge, normal to grazing incidence (kinked and zero-L
    /// leaves included), near and far.
    fn terms(n: usize) -> Vec<LeafTerm> {
        let mut u = uniforms(7);
        (0..n)
            .map(|_| {
                let radius = (0.0005f64.ln() + u() * (0.3f64.ln() - 0.0005f64.ln())).exp();
                let range = 0.05 + u() * 10.1;
                LeafTerm::new(
                    0.2 / (range * range),
                    range,
                    u() * std::f64::consts::FRAC_PI_2,
                    radius,
                )
            })
            .collect()
    }

    #[test]
    fn fast_spectrum_is_within_tol_of_the_exact_sum() {
        let t = terms(3000);
        for (atm, model) in [
            (None, LeafModel::Paper),
            (Some(Atmosphere::default()), LeafModel::Paper),
            (None, LeafModel::PhysicalOptics),
        ] {
            let s = sonar(atm, model);
            let exact = sum_terms(&s, &t);
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                let plan = FastPlan::new(&s, tol).unwrap();
                let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
                assert!(
                    err <= tol,
                    "{model:?} atm {} tol {tol:e}: error {err:e}",
                    atm.is_some()
                );
            }
        }
    }

    #[test]
    fn fast_spectrum_is_bit_identical_across_chunkings() {
        // Many leaves: several parallel chunks; the result must not depend on the thread count,
        // which only changes who computes each chunk.
        let t = terms(FAST_CHUNK * 2 + 123);
        assert_same_bits_on_one_and_two_threads(&sonar(None, LeafModel::Paper), &t);
    }

    /// `fast_sum_terms` at `tol = 1e-6` gives the same bits on the global pool (two threads)
    /// and on a pool of one.
    fn assert_same_bits_on_one_and_two_threads(s: &FastSonar, t: &[LeafTerm]) {
        let plan = FastPlan::new(s, 1e-6).unwrap();
        let a = fast_sum_terms(s, &plan, t);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let b = pool.install(|| fast_sum_terms(s, &plan, t));
        assert_eq!(a, b);
    }

    #[test]
    fn a_first_pass_that_keeps_a_thread_awake_gives_the_bits_of_one_that_does_not() {
        // four tasks of ~25k leaves on two and three threads: a thread that ends its task
        // early waits awake for the pass's end, which changes only who computes what, when
        let s = sonar(None, LeafModel::Paper);
        let plan = FastPlan::new(&s, 1e-6).unwrap();
        let t = terms(100_000);
        for threads in [2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let awake = pool.install(|| fast_sum_terms_in(&s, &plan, &t, true));
            let asleep = pool.install(|| fast_sum_terms_in(&s, &plan, &t, false));
            assert_eq!(awake, asleep);
        }
    }

    /// Kinked paper-model leaves only (the factor's cosine crosses zero inside the band).
    fn kinked_terms(s: &FastSonar, n: usize) -> Vec<LeafTerm> {
        terms(40 * n)
            .into_iter()
            .filter(|t| paper_regime(&s.tables, t) == PaperRegime::Kinked)
            .take(n)
            .collect()
    }

    #[test]
    fn kinked_leaves_are_within_tol_of_the_exact_sum_and_mostly_spread() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, LeafModel::Paper);
            let t = kinked_terms(&s, 400);
            assert!(t.len() >= 200, "{}", t.len());
            let exact = sum_terms(&s, &t);
            // (every kinked leaf goes into a batch: its interpolant is subtracted on the
            // shorter zero side, or added on the shorter live side)
            let spread = t.clone();
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                let plan = FastPlan::new(&s, tol).unwrap();
                let deferred = spread_pass(
                    &s,
                    &plan,
                    &spread,
                    &[],
                    chunk_len(spread.len(), plan.nufft.nf),
                    None,
                    false,
                )
                .deferred;
                // (a few fail the check on their live side and are summed exactly)
                assert!(
                    deferred.len() * 4 <= spread.len(),
                    "tol {tol:e}: {} of {} deferred",
                    deferred.len(),
                    spread.len()
                );
                let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
                assert!(err <= tol, "atm {} tol {tol:e}: {err:e}", atm.is_some());
            }
            // each kinked leaf alone, too (its own peak sets the scale)
            let plan = FastPlan::new(&s, 1e-9).unwrap();
            for leaf in t.iter().take(40) {
                let one = std::slice::from_ref(leaf);
                let err = rel_l2(&fast_sum_terms(&s, &plan, one), &sum_terms(&s, one));
                assert!(err <= 1e-9, "{leaf:?}: {err:e}");
            }
        }
    }

    /// 20,000 leaves, every tenth kinked: a first pass of four tasks, which spread their
    /// kinked leaves themselves.
    fn few_task_terms(s: &FastSonar) -> Vec<LeafTerm> {
        let kinked = kinked_terms(s, 2000);
        let smooth = terms(18_000);
        let mut t = Vec::with_capacity(20_000);
        for (i, k) in kinked.iter().enumerate() {
            t.push(*k);
            t.extend_from_slice(&smooth[9 * i..9 * i + 9]);
        }
        t
    }

    #[test]
    fn a_few_task_pass_spreads_its_kinked_leaves_in_its_tasks() {
        let s = sonar(None, LeafModel::Paper);
        let t = few_task_terms(&s);
        // (the first pass's node count for these leaves, which most kinked ones fail)
        let full = FastPlan::new(&s, 1e-6).unwrap();
        let p = choose_nodes(&s, &full, &t);
        assert!(p < full.p, "{p} {}", full.p);
        let plan = s.plans.get_with_nodes(&s, 1e-6, p).unwrap();
        let chunk = chunk_len(t.len(), plan.nufft.nf);
        assert!(t.len().div_ceil(chunk) <= KINKED_IN_TASKS_UP_TO);
        let kink = KinkPass::new(&s, 1e-6, p).unwrap();
        let f = spread_pass(&s, &plan, &t, &[], chunk, Some(&kink), false);
        // (none left for a later pass; one share per task)
        assert!(f.kinked.is_empty());
        assert_eq!(f.shares.len(), t.len().div_ceil(chunk));
        let without = spread_pass(&s, &plan, &t, &[], chunk, None, false);
        assert!(without.kinked.len() > 100, "{}", without.kinked.len());
    }

    #[test]
    fn kinked_leaves_spread_in_the_tasks_are_within_tol_of_the_exact_sum() {
        for atm in [None, Some(Atmosphere::default())] {
            let s = sonar(atm, LeafModel::Paper);
            let t = few_task_terms(&s);
            let exact = sum_terms(&s, &t);
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                let plan = FastPlan::new(&s, tol).unwrap();
                let err = rel_l2(&fast_sum_terms(&s, &plan, &t), &exact);
                assert!(err <= tol, "atm {} tol {tol:e}: {err:e}", atm.is_some());
            }
            // the kinked leaves alone (their own peaks set the scale)
            let kinked: Vec<LeafTerm> = t.iter().step_by(10).copied().collect();
            let plan = FastPlan::new(&s, 1e-9).unwrap();
            let err = rel_l2(&fast_sum_terms(&s, &plan, &kinked), &sum_terms(&s, &kinked));
            assert!(err <= 1e-9, "atm {}: {err:e}", atm.is_some());
        }
    }

    #[test]
    fn kinked_leaves_spread_in_the_tasks_are_bit_identical_for_one_and_two_threads() {
        let s = sonar(None, LeafModel::Paper);
        assert_same_bits_on_one_and_two_threads(&s, &few_task_terms(&s));
    }

    #[test]
    fn kinked_leaves_with_a_tiny_live_part_are_within_tol_alone() {
        // The corner in the band's top bins: the live side is a few bins where cos(B beta)
        // has barely turned positive (~1e-4 of the factor's scale), so the node values'
        // rounding (~2e-16 of that scale) is ~1e-12 of the live values.
        let s = sonar(None, LeafModel::Paper);
        let (tab, m) = (&s.tables, s.n_bins());
        for &radius in &[0.003f64, 0.0045, 0.0056, 0.008] {
            let ap = radius.powf(crate::physics::leaf::PAPER_BP);
            for live in [2usize, 5, 8, 20, 26, 64, 100] {
                let j = m - live;
                let beta = std::f64::consts::FRAC_PI_2 / PAPER_B1.mul_add(tab.kp[j] * ap, PAPER_B0)
                    + 1e-12;
                for range in [2.44, 9.48] {
                    let leaf = LeafTerm::new(0.01, range, beta, radius);
                    assert_eq!(paper_regime(tab, &leaf), PaperRegime::Kinked);
                    let one = std::slice::from_ref(&leaf);
                    let exact = sum_terms(&s, one);
                    // (1e-6 and 1e-3: the shortest series, whose relative errors, ~1e-8, scale
                    // with the factor and so with its small live values)
                    for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                        let plan = FastPlan::new(&s, tol).unwrap();
                        let err = rel_l2(&fast_sum_terms(&s, &plan, one), &exact);
                        assert!(err <= tol, "{leaf:?} live {live} tol {tol:e}: {err:e}");
                    }
                }
            }
        }
    }

    #[test]
    fn a_deferring_pass_returns_exact_routed_leaves_apart_from_its_failures() {
        // a 20-80 kHz band: wide enough for leaves outside the model's domain (B(c) beta past
        // pi at the low edge while live at the high one)
        let s = sonar_with(|p| {
            p.f_lo = 20e3;
            p.min_ka = 0.01;
        });
        // kinked leaves (in batches) and, every fourth, a 0.2 mm leaf outside the model's
        // domain (to the exact sum)
        let mut u = uniforms(5);
        let t: Vec<LeafTerm> = kinked_terms(&s, 450)
            .into_iter()
            .enumerate()
            .flat_map(|(i, l)| {
                let tiny = LeafTerm::new(l.amp, l.range, 0.62 + 0.07 * u(), 2e-4);
                std::iter::once(l).chain((i % 3 == 0).then_some(tiny))
            })
            .collect();
        assert!(t
            .iter()
            .any(|l| paper_regime(&s.tables, l) == PaperRegime::OutOfDomain));
        let routed = |l: &LeafTerm| {
            let route = paper_route(&s, paper_regime(&s.tables, l), l.radius_pow_b, l.beta);
            matches!(route, PaperRoute::Defer)
        };
        let want: Vec<usize> = (0..t.len()).filter(|&i| routed(&t[i])).collect();
        assert!(
            want.len() >= 50 && t.len() - want.len() >= 50,
            "{}",
            want.len()
        );
        let plan = FastPlan::new(&s, 1e-6).unwrap();
        // several tasks, so that the indices cross task boundaries
        let f = spread_pass(&s, &plan, &t, &[], 64, None, false);
        assert_eq!(f.exact, want);
        assert!(f.deferred.iter().all(|i| !routed(&t[*i])));
        // a whole pass sums both exactly: every leaf is counted once
        let g = fast_sum_fixed(&s, &plan, &t, &[], 64);
        assert!(rel_l2(&g, &sum_terms(&s, &t)) <= 1e-6);
    }

    #[test]
    fn second_pass_tasks_are_a_quarter_of_the_leaves_in_whole_sub_chunks() {
        assert_eq!(second_chunk_len(1), SUB_CHUNK);
        assert_eq!(second_chunk_len(4188), 2 * SUB_CHUNK);
        assert_eq!(second_chunk_len(10_000_000), FAST_CHUNK);
        for n in [1, 500, 4096, 4188, 20_000, 1 << 20] {
            let c = second_chunk_len(n);
            assert_eq!(c % SUB_CHUNK, 0);
            assert!(n.div_ceil(c) <= 4 || c == FAST_CHUNK, "{n}: {c}");
        }
    }

    #[test]
    fn first_pass_tasks_are_four_to_sixteen_with_ten_leaves_per_grid_point() {
        // the default record's grid (2430 points): 1e5 leaves in 4 tasks, 1e6 in 16
        assert_eq!(100_000usize.div_ceil(chunk_len(100_000, 2430)), 4);
        assert_eq!(chunk_len(1_000_000, 2430), 62_500);
        for nf in [100, 2430, 100_000] {
            for n in [1, 5000, 20_000, 100_000, 400_000, 1_000_000, 10_000_000] {
                let c = chunk_len(n, nf);
                assert!((1..=FAST_CHUNK).contains(&c), "{n} {nf}: {c}");
                let tasks = n.div_ceil(c);
                // tasks of 4096 leaves at least, unless the leaves are too few for that
                assert!(c >= 4096 || tasks == n.div_ceil(4096), "{n} {nf}: {c}");
                assert!(
                    tasks <= 16 || tasks == n.div_ceil(FAST_CHUNK),
                    "{n} {nf}: {tasks}"
                );
                assert!(tasks >= 4 || c < 4096 + tasks, "{n} {nf}: {tasks}");
                // the last task at most one leaf per task shorter than the others
                assert!(n - (tasks - 1) * c + tasks > c, "{n} {nf}: {c}");
                // past 16 tasks' worth, at least ten leaves per grid point (or the cap)
                if n >= 4 * LEAVES_PER_GRID_POINT * nf && tasks < 16 {
                    assert!(c >= LEAVES_PER_GRID_POINT * nf, "{n} {nf}");
                }
            }
        }
    }

    #[test]
    fn mirror_weights_match_the_horner_weights_of_an_eight_tap_kernel() {
        let plan = Type1Plan::new(1201, 2e-7).unwrap();
        assert_eq!(plan.w, 8);
        let mut worst: f64 = 0.0;
        for k in 0..2000 {
            let u = [
                k as f64 / 2000.0,
                0.5,
                1.0 - k as f64 / 2000.0,
                (k as f64 * 0.37) % 1.0,
            ];
            let want = weights4::<8>(&plan.horner, u);
            let got = weights4_mirror(&plan.mirror, u);
            for (g, w) in got.iter().zip(&want) {
                for t in 0..8 {
                    worst = worst.max((g[t] - w[t]).abs());
                }
            }
        }
        assert!(worst <= 1e-15, "{worst:e}");
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn a_block_transposed_in_registers_equals_the_block_pushed_leaf_by_leaf() {
        if !std::arch::is_x86_feature_detected!("avx512f") {
            return;
        }
        let t = terms(3 * LB);
        for block in t.chunks_exact(LB) {
            let block: &[LeafTerm; LB] = block.try_into().unwrap();
            let want = PaperLanes::of_block(block);
            // SAFETY: AVX-512F was detected above.
            let got = unsafe { PaperLanes::of_block_avx512(block) };
            assert_eq!(got.n, want.n);
            for (g, w) in [
                (got.amp, want.amp),
                (got.range, want.range),
                (got.beta, want.beta),
                (got.a, want.a),
                (got.ap, want.ap),
                (got.aq, want.aq),
                (got.floor, want.floor),
            ] {
                assert_eq!(g.map(f64::to_bits), w.map(f64::to_bits));
            }
            assert_eq!((got.kink, got.skip), (want.kink, want.skip));
        }
    }

    #[test]
    fn erf_at_nodes_matches_libm_at_each_level() {
        // node ranges as the 60-80 kHz band gives them (half-width up to 0.051 (|z_c| + 1.5)),
        // and wider ones (the fallback)
        let mut u = uniforms(3);
        for spread in [0.051, 0.3] {
            let mut worst = [0.0f64; 3];
            for _ in 0..2000 {
                let p = 2 + (u() * 14.0) as usize;
                let centres: [f64; LB] = std::array::from_fn(|_| -3.0 + 12.0 * u());
                let z: [[f64; LB]; MAX_NODES] = std::array::from_fn(|q| {
                    let t = ((2 * q + 1) as f64 * PI / (2 * p) as f64).cos();
                    centres.map(|zc| zc + spread * (zc.abs() + 1.5) * t)
                });
                let mut c = [[0.0; LB]; MAX_NODES];
                let mut got = [[[0.0; LB]; MAX_NODES]; 3];
                erf_at_nodes::<22, 7>(p, &z, &mut c, &mut got[0]);
                erf_at_nodes::<28, 11>(p, &z, &mut c, &mut got[1]);
                erf_at_nodes::<40, 14>(p, &z, &mut c, &mut got[2]);
                for (lvl, g) in got.iter().enumerate() {
                    for q in 0..p {
                        for i in 0..LB {
                            let e = (g[q][i] - libm::erf(z[q][i])).abs();
                            worst[lvl] = worst[lvl].max(e);
                        }
                    }
                }
            }
            assert!(worst[0] <= 2e-9, "spread {spread}: {worst:?}");
            assert!(worst[1] <= 1e-12, "spread {spread}: {worst:?}");
            assert!(worst[2] <= 2e-15, "spread {spread}: {worst:?}");
        }
    }

    #[test]
    fn kink_bin_splits_the_band_where_the_factor_turns_on() {
        let s = sonar(None, LeafModel::Paper);
        for t in kinked_terms(&s, 100) {
            let mk = kink_bin(&s, t.radius_pow_b, t.beta);
            assert!(mk > 0 && mk < s.n_bins());
            let x = |m: usize| PAPER_B1.mul_add(s.tables.kp[m] * t.radius_pow_b, PAPER_B0) * t.beta;
            assert!(
                x(mk - 1) >= std::f64::consts::FRAC_PI_2 && x(mk) < std::f64::consts::FRAC_PI_2
            );
        }
    }

    #[test]
    fn nodes_grow_as_the_tolerance_tightens() {
        let p: Vec<usize> = [1e-3, 1e-6, 1e-9, 1e-12]
            .iter()
            .map(|&t| nodes_for_tol(t))
            .collect();
        assert!(p.windows(2).all(|w| w[0] < w[1]), "{p:?}");
        assert!(FastPlan::new(&sonar(None, LeafModel::Paper), 1e-14).is_err());
    }
}
