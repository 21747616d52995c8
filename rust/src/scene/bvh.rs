//! The BVH over the leaf centres (obvhs): conservative f32 boxes, the depth-first renumbering
//! of its leaves, and each node's range of stored leaves.
use crate::math::vec3::V3;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;

/// The f32 box that surely contains the f64 point (rounded outward), widened by `half` on
/// every side. (The leaf's own radius: zero-extent boxes make the builder's surface-area
/// heuristic degenerate, quadratic for colinear leaves; the box still holds the centre, so
/// the query stays conservative.)
pub(super) fn point_box(c: V3, half: f64) -> Aabb {
    let down = |x: f64| {
        let f = x as f32;
        if f as f64 > x {
            f.next_down()
        } else {
            f
        }
    };
    let up = |x: f64| {
        let f = x as f32;
        if (f as f64) < x {
            f.next_up()
        } else {
            f
        }
    };
    Aabb::new(
        Vec3A::new(down(c[0] - half), down(c[1] - half), down(c[2] - half)),
        Vec3A::new(up(c[0] + half), up(c[1] + half), up(c[2] + half)),
    )
}

/// The f32 box that surely contains the cylinder of axis `a`-`b` and radius `r` (its axis box
/// widened by `r`, rounded outward).
pub(super) fn segment_box(a: V3, b: V3, r: f64) -> Aabb {
    let lo = point_box([a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])], r);
    let hi = point_box([a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])], r);
    Aabb::new(lo.min, hi.max)
}

/// Renumber the BVH's leaves in depth-first order (first child first, as the lobe traversal
/// visits them): returns the primitives in that order and sets `primitive_indices` to the
/// identity. None (BVH untouched) unless every primitive appears exactly once.
pub(super) fn dfs_order(bvh: &mut Bvh2, n: usize) -> Option<Vec<u32>> {
    if bvh.nodes.is_empty() || bvh.primitive_indices.len() != n {
        return None;
    }
    let mut order: Vec<u32> = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let mut new_first: Vec<(usize, u32)> = Vec::new();
    let mut stack = vec![0u32];
    while let Some(ni) = stack.pop() {
        let node = &bvh.nodes[ni as usize];
        if node.is_leaf() {
            new_first.push((ni as usize, order.len() as u32));
            let first = node.first_index as usize;
            for &p in bvh
                .primitive_indices
                .get(first..first + node.prim_count as usize)?
            {
                if (p as usize) >= n || std::mem::replace(&mut seen[p as usize], true) {
                    return None;
                }
                order.push(p);
            }
        } else {
            stack.push(node.first_index + 1);
            stack.push(node.first_index);
        }
    }
    if order.len() != n {
        return None;
    }
    for (ni, first) in new_first {
        bvh.nodes[ni].first_index = first;
    }
    bvh.primitive_indices = (0..n as u32).collect();
    Some(order)
}

/// Per node, the range of primitive positions below it, if every subtree's positions are
/// contiguous (else empty).
pub(super) fn subtree_ranges(bvh: &Bvh2) -> Vec<(u32, u32)> {
    let nodes = &bvh.nodes;
    if nodes.is_empty() {
        return Vec::new();
    }
    let mut out = vec![(u32::MAX, 0u32); nodes.len()];
    let mut count = vec![0u64; nodes.len()];
    // Post-order over an explicit stack: (node, children done).
    let mut stack = vec![(0u32, false)];
    while let Some((ni, done)) = stack.pop() {
        let node = &nodes[ni as usize];
        if node.is_leaf() {
            let lo = node.first_index;
            out[ni as usize] = (lo, lo + node.prim_count);
            count[ni as usize] = node.prim_count as u64;
        } else if !done {
            stack.push((ni, true));
            stack.push((node.first_index, false));
            stack.push((node.first_index + 1, false));
        } else {
            let (a, b) = (node.first_index as usize, node.first_index as usize + 1);
            let lo = out[a].0.min(out[b].0);
            let hi = out[a].1.max(out[b].1);
            count[ni as usize] = count[a] + count[b];
            if (hi - lo) as u64 != count[ni as usize] {
                return Vec::new();
            }
            out[ni as usize] = (lo, hi);
        }
    }
    out
}
