//! The scene: leaves as disks, the BVH over their centres, branches as cylinder segments,
//! clearance queries and OBJ loading.

pub mod branches;
pub mod bvh;
pub mod leaves;
pub mod nearest;
pub mod obj;

pub use branches::Branches;
pub use leaves::{normalized, validate_leaves, Scene, Xyz, MAX_COORDINATE};
pub use nearest::Nearest;
