//! Numerics with no physics in them: vectorisable elementary functions and their tables,
//! cache-line-aligned arrays, prefetch hints.

pub mod aligned;
pub mod erf_table;
pub(crate) mod prefetch;
pub mod vec3;
pub mod vmath;
