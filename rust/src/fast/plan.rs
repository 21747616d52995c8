//! The fast path's plan for one sonar and tolerance: the Chebyshev nodes and their tables,
//! the Lagrange rows, the NUFFT plan; the node count a tolerance needs; the cache of plans.
use crate::echo::{NodeTables, LANES};
use crate::error::{invalid, Result};
use crate::fast::lanes::LB;
use crate::fast::nufft::Type1Plan;
use crate::fast::prepared::FastSonar;
use std::f64::consts::PI;

/// Largest number of interpolation nodes.
pub const MAX_NODES: usize = 16;
/// The tightest tolerance the fast path accepts (the interpolants' floor is ~2e-14).
pub const MIN_TOL: f64 = 1e-13;

/// The widest band, as `f_hi / f_lo`, on which a fast sum at `tol` keeps its error within
/// `tol`: [`WORST_CHEB`] and the leaves' check are calibrated on 60-80 kHz (a ratio of 4/3).
/// A random search of 5,300 one-pose cases (of the kind `tools/fast_band_search.py` runs:
/// bands with ratios 1.1-12 and tops at 40-150 kHz, both leaf models, radii 2 mm - 20 cm,
/// ranges 0.3 m to the record's edge, windows, absorption, wood; `tol` 1e-3 ... 1e-12) found
/// the error within 0.83 `tol` up to a ratio of 2, within 1.8 `tol` up to 3, and up to 41 `tol`
/// beyond.
pub const CALIBRATED_BAND_RATIO: f64 = 2.0;
/// On wider bands the fast sum is taken at `tol` divided by a factor: (the widest ratio, the
/// factor). A second search of 1,400 cases at these factors found the error within 0.48 `tol`
/// up to a ratio of 3 and 0.11 `tol` up to 7; beyond a ratio of 7 it found 1.3 `tol` even at
/// `tol / 100`, so bands wider than [`WIDEST_FAST_BAND_RATIO`] are summed exactly. A smaller
/// `tol` costs more nodes, then exact sums of the leaves that fail their check; the sum is
/// exact where it falls below [`MIN_TOL`].
pub const WIDE_BAND_TIGHTENING: [(f64, f64); 2] = [(3.0, 10.0), (WIDEST_FAST_BAND_RATIO, 100.0)];
/// The widest band, as `f_hi / f_lo`, that the fast sum takes at all (see
/// [`WIDE_BAND_TIGHTENING`]).
pub const WIDEST_FAST_BAND_RATIO: f64 = 6.0;
/// On a band wider than [`CALIBRATED_BAND_RATIO`], the tightest working tolerance the fast
/// sum takes; below it the sum is exact. At `tol = 1e-12` on a band of ratio 2.6 (worked at
/// 1e-13, the floor) a search found 1.16 `tol`.
pub const WIDE_BAND_MIN_TOL: f64 = 1e-12;

/// What a fast sum's tolerance is divided by on the band `f_lo..f_hi` (Hz): 1 on bands up to
/// [`CALIBRATED_BAND_RATIO`], then as [`WIDE_BAND_TIGHTENING`] says, and infinity (the exact
/// sum) beyond [`WIDEST_FAST_BAND_RATIO`].
pub fn band_tightening(f_lo: f64, f_hi: f64) -> f64 {
    if f_hi <= CALIBRATED_BAND_RATIO * f_lo {
        return 1.0;
    }
    WIDE_BAND_TIGHTENING
        .iter()
        .find(|&&(ratio, _)| f_hi <= ratio * f_lo)
        .map_or(f64::INFINITY, |&(_, factor)| factor)
}

/// A clear error unless `tol` is one the fast method takes: in `[MIN_TOL, 1)`.
pub fn check_tol(tol: f64) -> Result<()> {
    if !(MIN_TOL..1.0).contains(&tol) {
        return invalid(format!(
            "tol must be in [{MIN_TOL:e}, 1) for the fast method, got {tol:e} (use method='exact' for exact sums)"
        ));
    }
    Ok(())
}

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
    pub(crate) cheb_last: Vec<f64>,
    /// `l_q(t_m)`, divided by `k_m` where the channels carry `k F`, by node: row-major
    /// (P, M + LB), zero past the band (whole vectors of bins).
    pub(crate) lagrange_t: Vec<f64>,
    /// The nodes' band-bin positions.
    pub(crate) node_x: Vec<f64>,
    /// What the node values are multiplied by: 1 where the channels carry `k F`, `1/k_q`
    /// where they carry `F` itself (see [`K_FACTOR_TOL`]).
    pub(crate) node_scale: Vec<f64>,
    pub nufft: Type1Plan,
    /// `m_c = M / 2`: output mode `k` is band bin `m = k + m_c`.
    pub(crate) m_c: usize,
    /// The largest node wavenumber and node scale (a bound of a kinked leaf's scale; see
    /// [`KINK_FLOOR`]).
    pub(crate) k_top: f64,
    pub(crate) scale_top: f64,
}

impl FastPlan {
    pub fn new(sonar: &FastSonar, tol: f64) -> Result<FastPlan> {
        FastPlan::with_nodes(sonar, tol, nodes_for_tol(tol))
    }

    /// A plan with `p` Chebyshev nodes (at most [`MAX_NODES`]).
    pub fn with_nodes(sonar: &FastSonar, tol: f64, p: usize) -> Result<FastPlan> {
        check_tol(tol)?;
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
