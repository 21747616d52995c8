//! The BVH walk of one pose: the candidate leaves (a superset of the counting ones) in
//! traversal order, the top levels split into parallel tasks.
use crate::lobe::bound::test_box;
use crate::lobe::bound::AngularBound;
use crate::lobe::bound::BoxTest;
use crate::lobe::candidates::Candidates;
use crate::lobe::members::Search;
use crate::lobe::receivers::PlacedReceiver;
use crate::lobe::receivers_bound::test_box_heard;
use crate::physics::pose::Pose;
use crate::scene::Scene;
use crate::sonar::Sonar;

/// Subtrees with at most this many leaves are not bounded: all their leaves become candidates
/// (the exact test rejects the rest at a few nanoseconds each; a node test costs far more).
const SMALL_SUBTREE: u32 = 8;

/// Levels of the BVH whose subtrees are walked as parallel tasks (up to 2^8 tasks): a beam's
/// boundary crosses many nodes, and the walk is bound by fetching them.
const PAR_LEVELS: u32 = 8;
/// Subtrees with fewer leaves than this are walked in one task (a narrow beam, or a small
/// scene, gains nothing from splitting its walk).
const PAR_MIN_LEAVES: u32 = 8192;

/// Every leaf the BVH cannot rule out (a superset of the counting leaves), in traversal order:
/// a whole subtree or a BVH leaf at a time. Called from a pool thread, the top [`PAR_LEVELS`]
/// levels split into parallel tasks whose candidates are appended in traversal order, so the
/// result is that of one sequential walk for any number of threads.
pub fn bvh_candidates(scene: &Scene, sonar: &Sonar, pose: &Pose) -> Candidates {
    walk_candidates(scene, sonar, pose, None)
}

/// [`bvh_candidates`] for receivers at their own places: every leaf the BVH cannot rule out
/// for any of `rxs` (see [`test_box_heard`]).
pub fn bvh_candidates_heard(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    rxs: &[PlacedReceiver],
) -> Candidates {
    walk_candidates(scene, sonar, pose, Some(rxs))
}

fn walk_candidates(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    receivers: Option<&[PlacedReceiver]>,
) -> Candidates {
    if scene.bvh.nodes.is_empty() {
        return Candidates::default();
    }
    let walk = Walk {
        scene,
        sonar,
        pose,
        bound: match receivers {
            None => AngularBound::new(sonar, pose),
            Some(_) => None,
        },
        receivers,
        // With `node_ranges`, the scene is stored in BVH order (`primitive_indices` is the
        // identity), so a node's leaves are the run of stored indices below it.
        in_order: !scene.node_ranges.is_empty(),
    };
    // (only from inside the pool, where a split costs a push onto this thread's queue: from
    // outside, each split would be sent to the pool and waited for)
    let levels = match rayon::current_thread_index() {
        Some(_) => PAR_LEVELS,
        None => 0,
    };
    walk.par_subtree(0, false, levels)
}

/// The candidates of a pose in a thread-independent order: the BVH's traversal order, or
/// every leaf in index order.
pub fn candidates(scene: &Scene, sonar: &Sonar, pose: &Pose, search: Search) -> Candidates {
    match search {
        Search::Bvh => bvh_candidates(scene, sonar, pose),
        Search::BruteForce => Candidates::all(scene.len()),
    }
}

/// [`candidates`] for receivers at their own places.
pub fn candidates_heard(
    scene: &Scene,
    sonar: &Sonar,
    pose: &Pose,
    rxs: &[PlacedReceiver],
    search: Search,
) -> Candidates {
    match search {
        Search::Bvh => bvh_candidates_heard(scene, sonar, pose, rxs),
        Search::BruteForce => Candidates::all(scene.len()),
    }
}

/// What the walk does at one node.
pub(super) enum Step<'a> {
    /// Outside the lobe: nothing below it counts.
    Skip,
    /// Its leaves are these stored indices (or these ids, out of order).
    Run(u32, u32),
    Ids(&'a [u32]),
    /// Its two children, and whether an ancestor was entirely inside.
    Children(u32, bool),
}

/// The BVH walk of [`bvh_candidates`] for one pose.
pub(super) struct Walk<'a> {
    pub(super) scene: &'a Scene,
    pub(super) sonar: &'a Sonar,
    pub(super) pose: &'a Pose,
    pub(super) bound: Option<AngularBound>,
    /// Receivers at their own places (the union of their lobes), or None: the monostatic lobe.
    pub(super) receivers: Option<&'a [PlacedReceiver<'a>]>,
    pub(super) in_order: bool,
}

impl Walk<'_> {
    /// Node `ni`, `inside` when an ancestor was entirely inside the lobe.
    #[inline(always)]
    pub(super) fn step(&self, ni: u32, inside: bool) -> Step<'_> {
        let (scene, bvh) = (self.scene, &self.scene.bvh);
        let node = &bvh.nodes[ni as usize];
        // A subtree this small costs less to test leaf by leaf (vectorised) than to bound.
        let small = match scene.node_ranges.get(ni as usize) {
            Some(&(lo, hi)) => hi - lo <= SMALL_SUBTREE,
            None => node.is_leaf(),
        };
        let inside = inside || small || {
            let a = node.aabb();
            let lo = [a.min.x as f64, a.min.y as f64, a.min.z as f64];
            let hi = [a.max.x as f64, a.max.y as f64, a.max.z as f64];
            let test = match self.receivers {
                None => test_box(self.sonar, self.pose, self.bound.as_ref(), lo, hi),
                Some(rxs) => test_box_heard(self.sonar, self.pose, rxs, lo, hi),
            };
            match test {
                BoxTest::Outside => return Step::Skip,
                BoxTest::Partial => false,
                BoxTest::Inside => true,
            }
        };
        if inside && self.in_order {
            // the whole subtree counts as candidates: its stored leaves are one run
            let (lo, hi) = scene.node_ranges[ni as usize];
            Step::Run(lo, hi)
        } else if node.is_leaf() {
            let (first, count) = (node.first_index, node.prim_count);
            if self.in_order {
                Step::Run(first, first + count)
            } else {
                Step::Ids(&bvh.primitive_indices[first as usize..(first + count) as usize])
            }
        } else {
            Step::Children(node.first_index, inside)
        }
    }

    /// The candidates below node `ni`, depth first, onto `out`.
    pub(super) fn subtree(&self, ni: u32, inside: bool, out: &mut Candidates) {
        let mut stack: Vec<(u32, bool)> = Vec::with_capacity(64);
        stack.push((ni, inside));
        while let Some((ni, inside)) = stack.pop() {
            match self.step(ni, inside) {
                Step::Skip => {}
                Step::Run(lo, hi) => out.push_run(lo, hi),
                Step::Ids(ids) => out.push_ids(ids),
                Step::Children(first, inside) => {
                    stack.push((first + 1, inside));
                    stack.push((first, inside));
                }
            }
        }
    }

    /// [`Walk::subtree`] with the children of the top `levels` levels walked in parallel
    /// (those of subtrees of at least [`PAR_MIN_LEAVES`] leaves).
    fn par_subtree(&self, ni: u32, inside: bool, levels: u32) -> Candidates {
        let mut out = Candidates::default();
        let small = match self.scene.node_ranges.get(ni as usize) {
            Some(&(lo, hi)) => hi - lo < PAR_MIN_LEAVES,
            None => false,
        };
        if levels == 0 || small {
            self.subtree(ni, inside, &mut out);
            return out;
        }
        match self.step(ni, inside) {
            Step::Skip => {}
            Step::Run(lo, hi) => out.push_run(lo, hi),
            Step::Ids(ids) => out.push_ids(ids),
            Step::Children(first, inside) => {
                let (a, b) = rayon::join(
                    || self.par_subtree(first, inside, levels - 1),
                    || self.par_subtree(first + 1, inside, levels - 1),
                );
                out = a;
                out.append(&b);
            }
        }
        out
    }
}
