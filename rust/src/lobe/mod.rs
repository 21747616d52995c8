//! Which leaves and branch pieces count for a pose (docs/model.md §3, §9): the exact per-leaf test in f64, and a
//! conservative traversal of an obvhs BVH over the leaf centres that only ever skips nodes
//! that provably hold no counting leaf. The index never changes the answer: every candidate
//! goes through the same exact test as the brute-force scan.

pub mod block;
pub mod bound;
pub mod candidates;
pub mod members;
pub mod pieces;
pub mod rule;
pub mod walk;

pub(crate) use block::{classify_candidates, BlockView, CB};
pub use bound::{test_box, AngularBound, BoxTest};
pub(crate) use members::classify_member;
pub use members::{farthest_member_range, members, members_of, Member, Search};
pub use pieces::{branch_members, PieceMember};
pub use rule::{classify, Decision, LeafView};
pub use walk::{bvh_candidates, candidates};

#[cfg(test)]
mod tests;
