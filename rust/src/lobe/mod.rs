//! Which leaves and branch pieces count for a pose (docs/model.md §3, §9): the exact per-leaf test in f64, and a
//! conservative traversal of an obvhs BVH over the leaf centres that only ever skips nodes
//! that provably hold no counting leaf. The index never changes the answer: every candidate
//! goes through the same exact test as the brute-force scan. Receivers at their own places
//! have their own exact test and node test ([`receivers`], [`receivers_bound`]).

pub mod block;
pub mod bound;
pub mod candidates;
pub mod members;
pub mod pieces;
pub mod pieces_heard;
pub mod receivers;
pub(crate) mod receivers_block;
pub mod receivers_bound;
pub mod rule;
pub mod walk;

pub(crate) use block::{classify_candidates, BlockView, CB};
pub use bound::{test_box, AngularBound, BoxTest};
pub(crate) use members::{classify_member, refuse_too_close};
pub use members::{farthest_member_range, members, members_of, ranged_positions, Member, Search};
pub use pieces::{branch_members, PieceMember};
pub use pieces_heard::{branch_members_heard, HeardPiece};
pub use receivers::{
    classify_heard, emitter_side, place_receivers, Heard, HeardDecision, OneWay, PlacedReceiver,
};
pub use receivers_bound::test_box_heard;
pub use rule::{classify, Decision, LeafView};
pub use walk::{bvh_candidates, bvh_candidates_heard, candidates, candidates_heard};

#[cfg(test)]
mod tests;
