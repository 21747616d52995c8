//! The exact sum (`method = "exact"`, docs/model.md §4-§5, §9): the per-leaf spectrum kernel
//! adds one leaf's unwindowed `A_k exp(j phi_k)` to every band bin, the branch kernel
//! ([`branch`]) one branch piece's, and the band spectrum sums them in fixed chunks
//! ([`spectrum`]).
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

pub mod branch;
pub mod exact;
pub mod impulse;
pub mod po;
pub mod prepared;
pub mod receivers;
pub mod regime;
pub mod spectrum;
pub mod tables;
pub mod term;
pub mod term_pool;

pub use branch::{
    add_branch, branch_points, branch_term, heard_branch_term, sum_branch_terms,
    sum_branch_terms_unwindowed, BranchPoint, BranchTerm, PointForm,
};
pub(crate) use exact::cis_neg;
pub use exact::{add_leaf, add_leaf_scalar, CHEB_TOL, SMOOTH_TOL};
pub use prepared::Prepared;
pub use receivers::{heard_amplitude, heard_leaf_term, heard_terms};
pub(crate) use regime::{
    first_live_bin, paper_regime, paper_regime_bits, paper_regime_of, PaperRegime, REGIME_KINKED,
    REGIME_ZERO,
};
pub use spectrum::{band_spectrum, sum_chunked, sum_terms, sum_terms_unwindowed};
pub use tables::{BandTables, BinOfKp, NodeTables, ANCHOR_BINS, LANES, POLY_BLOCK, POLY_DEG};
pub use term::{leaf_amp, leaf_term, LeafTerm};

#[cfg(test)]
mod receivers_tests;
#[cfg(test)]
mod tests;
