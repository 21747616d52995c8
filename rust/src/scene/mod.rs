//! The scene: leaves as disks, the BVH over their centres, clearance queries and OBJ loading.

pub mod bvh;
pub mod leaves;
pub mod nearest;
pub mod obj;

pub use leaves::{normalized, validate_leaves, Scene, Xyz, MAX_COORDINATE};
pub use nearest::Nearest;
