//! The scene: leaves as disks, the BVH over their centres, and OBJ loading.

pub mod bvh;
pub mod leaves;
pub mod obj;

pub use leaves::normalized;
pub use leaves::validate_leaves;
pub use leaves::Scene;
pub use leaves::Xyz;
pub use leaves::MAX_COORDINATE;
