//! Which leaves count for a pose (MODEL.md section 3): the exact per-leaf test in f64, and a
//! conservative traversal of an obvhs BVH over the leaf centres that only ever skips nodes
//! that provably hold no counting leaf. The index never changes the answer: every candidate
//! goes through the same exact test as the brute-force scan.

pub mod block;
pub mod bound;
pub mod members;
pub mod rule;
pub mod walk;
pub mod candidates;

pub use rule::LeafView;
pub use rule::Decision;
pub use rule::classify;
pub use bound::BoxTest;
pub use bound::AngularBound;
pub use bound::test_box;
pub use walk::{bvh_candidates, candidates};
pub use members::Member;
pub use members::incidence;
pub use members::Search;
pub(crate) use block::CB;
pub(crate) use block::BlockView;
pub(crate) use block::classify_candidates;
pub(crate) use members::classify_member;
pub use members::members;
pub use members::members_of;
pub use members::farthest_member_range;

#[cfg(test)]
mod tests;
