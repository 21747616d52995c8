//! The echo model's physics (docs/model.md §2-§6, §9-§10), scalar and exact: poses, the
//! beampattern, leaf and branch scattering, the round-trip phase, atmospheric absorption,
//! shading; distances to the scene's primitives (clearance).

pub mod absorption;
pub mod amplitude;
pub mod beam;
pub mod branch;
pub mod distance;
pub mod leaf;
pub mod phase;
pub mod pose;
pub mod shading;
