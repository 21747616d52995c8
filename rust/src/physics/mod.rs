//! The echo model's physics (docs/model.md §2-§6, §9-§10), scalar and exact: poses, the
//! beampattern, leaf and branch scattering, the round-trip phase, atmospheric absorption,
//! bistatic geometry, shading; distances to the scene's primitives (clearance).

pub mod absorption;
pub mod amplitude;
pub mod beam;
pub mod bistatic;
pub mod branch;
pub mod distance;
pub mod leaf;
pub mod phase;
pub mod pose;
pub mod shading;
