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
//! nodes: in the first pass's own tasks where it has few ([`KINKED_IN_TASKS_UP_TO`](pass::KINKED_IN_TASKS_UP_TO)), else in
//! a later pass ([`leftover_pass`]).

pub mod batch;
pub mod branch;
pub mod finish;
pub mod kinks;
pub mod lanes;
pub mod nodes;
pub mod nufft;
pub mod pass;
pub mod plan;
pub mod po;
pub mod pool;
pub mod prepared;
pub mod pulse;
pub mod schedule;
pub mod spread;
pub mod subband;

pub(crate) use batch::paper_batch;
pub use branch::fast_branch_spectrum;
pub(crate) use finish::{finish_grids, Direct};
pub(crate) use kinks::{paper_route, PaperRoute};
pub(crate) use lanes::{PaperLanes, LB, NOT_KINKED};
pub(crate) use nodes::{choose_nodes_from, BatchScratch};
pub use nodes::{ADAPT_MIN_LEAVES, LOW_SERIES_TOL, SHORT_SERIES_TOL};
pub(crate) use pass::{beside_leftovers, fast_sum_fixed, leftover_pass, spread_task};
pub use pass::{chunk_len, fast_band_spectrum, fast_sum_terms, FAST_CHUNK};
pub use plan::{
    band_tightening, check_tol, nodes_for_tol, FastPlan, PlanCache, K_FACTOR_TOL, MAX_NODES,
    MIN_TOL, WIDE_BAND_MIN_TOL,
};
pub(crate) use po::po_leaf;
pub(crate) use pool::take_grid;
pub use prepared::FastSonar;

#[cfg(test)]
mod tests;
