//! The scene: leaves as disks, the BVH over their centres, and OBJ loading.

pub mod bvh;
pub mod leaves;
pub mod obj;

pub use leaves::{normalized, validate_leaves, Scene, Xyz, MAX_COORDINATE};
