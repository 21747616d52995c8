//! Per-bin tables shared by all leaves (wavenumbers, the paper model's powers of k,
//! absorption, the interpolation blocks' nodes and matrices), at the band bins and at any
//! fractional bin positions.
use crate::physics::leaf::PAPER_BP;
use crate::physics::leaf::PAPER_PP;
use std::f64::consts::PI;

/// Bins per vector block.
pub const LANES: usize = 8;
/// Bins between exact re-anchoring of the phase recurrence (error growth ~ 128 steps * 1e-16).
pub const ANCHOR_BINS: usize = 1024;
/// Bins per interpolation block of the smooth path (a multiple of [`LANES`]).
pub const POLY_BLOCK: usize = 128;
/// Degree of the interpolating polynomial per block.
pub const POLY_DEG: usize = 6;
pub(super) const NODES: usize = POLY_DEG + 1;
const _: () = assert!(
    NODES < LANES,
    "a block's nodes and its end fit one vector of lanes"
);
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
/// (linear between bins). For [`first_live_bin`](crate::echo::regime::first_live_bin)'s first guess: over a 60-80 kHz band it
/// lands within a bin of the crossing, where a chord and a Newton step on the table cost
/// two dependent divisions and four dependent loads.
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
    #[inline(always)]
    pub(super) fn tables(&self) -> Tables<'_> {
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

impl NodeTables {
    #[inline(always)]
    pub(super) fn tables(&self) -> Tables<'_> {
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

/// Per-position tables: `k`, `1/k`, `k^-0.9065`, `k^0.3523`, absorption (empty when off).
pub(super) type Tables<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64], &'a [f64]);

/// The `LANES` values of a padded per-bin array from index `j0`.
#[inline(always)]
pub(crate) fn lanes(v: &[f64], j0: usize) -> &[f64; LANES] {
    v[j0..j0 + LANES]
        .try_into()
        .expect("tables are padded to LANES")
}

/// [`lanes`], mutable.
#[inline(always)]
pub(crate) fn lanes_mut(v: &mut [f64], j0: usize) -> &mut [f64; LANES] {
    (&mut v[j0..j0 + LANES])
        .try_into()
        .expect("accumulators are padded to LANES")
}
