//! The echo model's physics (docs/model.md §2-§6), scalar and exact: poses, the beampattern,
//! leaf scattering, the round-trip phase, atmospheric absorption, bistatic geometry; distances
//! to the scene's primitives (clearance).

pub mod absorption;
pub mod amplitude;
pub mod beam;
pub mod bistatic;
pub mod distance;
pub mod leaf;
pub mod phase;
pub mod pose;
