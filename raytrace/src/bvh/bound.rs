//! Bounding the depth of a built tree. PLOC with reinsertion optimises cost, not depth: a fan
//! of many thin triangles sharing a vertex nests boxes hundreds deep. The CPU traversal and the
//! GPU kernels both have a fixed stack, so every subtree that would go past the limit is
//! replaced by an object-median tree over the same triangles, whose depth grows with the
//! logarithm of their number. Subtrees within the limit keep the builder's tree.

use obvhs::{aabb::Aabb as OAabb, bvh2::Bvh2, triangle::Triangle};

use super::node::Node;

/// Most triangles in a leaf of a median subtree.
const LEAF: usize = 4;

/// What the flattening needs to know of each source node: how deep its subtree goes and how
/// many triangle references it holds.
pub(super) struct Shape {
    height: Vec<usize>,
    count: Vec<usize>,
}

impl Shape {
    /// Heights and counts of every node of `bvh2`, without recursion (a deep tree is exactly
    /// the case this exists for).
    pub(super) fn of(bvh2: &Bvh2) -> Self {
        let src = &bvh2.nodes;
        let mut height = vec![0usize; src.len()];
        let mut count = vec![0usize; src.len()];
        // Post-order: a node is finished once both children are.
        let mut stack: Vec<(usize, bool)> = vec![(0, false)];
        while let Some((s, children_done)) = stack.pop() {
            let n = &src[s];
            if n.is_leaf() {
                height[s] = 1;
                count[s] = n.prim_count as usize;
            } else if children_done {
                let c = n.first_index as usize;
                height[s] = 1 + height[c].max(height[c + 1]);
                count[s] = count[c] + count[c + 1];
            } else {
                stack.push((s, true));
                stack.push((n.first_index as usize, false));
                stack.push((n.first_index as usize + 1, false));
            }
        }
        Self { height, count }
    }

    /// Whether the subtree at `s`, its root at `level`, stays within `max_depth`.
    pub(super) fn fits(&self, s: usize, level: usize, max_depth: usize) -> bool {
        level + self.height[s] - 1 <= max_depth
    }

    /// Whether the subtree at `s` must be rebuilt here rather than lower down: it does not
    /// fit, and going one level down would leave a child that neither fits nor can be
    /// rebuilt within the limit.
    pub(super) fn rebuild_here(
        &self,
        bvh2: &Bvh2,
        s: usize,
        level: usize,
        max_depth: usize,
    ) -> bool {
        let n = &bvh2.nodes[s];
        if self.fits(s, level, max_depth) {
            return false;
        }
        if n.is_leaf() {
            return true;
        }
        let c = n.first_index as usize;
        [c, c + 1].into_iter().any(|child| {
            !self.fits(child, level + 1, max_depth)
                && level + median_depth(self.count[child]) > max_depth
        })
    }
}

/// Depth of an object-median tree over `n` triangles.
pub(super) fn median_depth(n: usize) -> usize {
    if n <= LEAF {
        1
    } else {
        1 + median_depth(n.div_ceil(2))
    }
}

/// The triangle references (indices into the builder's primitives) under source node `s`.
pub(super) fn gather(bvh2: &Bvh2, s: usize) -> Vec<u32> {
    let mut prims = Vec::new();
    let mut stack = vec![s];
    while let Some(s) = stack.pop() {
        let n = &bvh2.nodes[s];
        if n.is_leaf() {
            let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
            prims.extend_from_slice(&bvh2.primitive_indices[range]);
        } else {
            stack.push(n.first_index as usize);
            stack.push(n.first_index as usize + 1);
        }
    }
    prims
}

/// Where a median subtree is written: the flattened nodes and triangles of the whole tree.
pub(super) struct Out<'a> {
    pub nodes: &'a mut Vec<Node>,
    /// The leaves' triangles, as indices into the builder's primitives.
    pub refs: &'a mut Vec<u32>,
}

/// Writes an object-median tree over `prims` with its root at `nodes[d]`; returns its depth.
/// Boxes are the triangles' own, so a triangle that the builder split keeps a box around all
/// of it.
pub(super) fn median(prims: &mut [u32], d: usize, tris: &[Triangle], out: &mut Out<'_>) -> usize {
    let bounds = prims
        .iter()
        .fold(OAabb::INVALID, |b, &p| b.union(&tris[p as usize].aabb()));
    let node = |index: u32, count: u32| Node {
        min: bounds.min.to_array(),
        index,
        max: bounds.max.to_array(),
        count,
    };
    if prims.len() <= LEAF {
        let first = out.refs.len() as u32;
        out.refs.extend_from_slice(prims);
        out.nodes[d] = node(first, prims.len() as u32);
        return 1;
    }
    let centres = prims.iter().fold(OAabb::INVALID, |b, &p| {
        let mut b = b;
        b.extend(tris[p as usize].aabb().center());
        b
    });
    let axis = centres.largest_axis();
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |&a, &b| {
        let key = |p: u32| tris[p as usize].aabb().center_axis(axis);
        key(a).total_cmp(&key(b))
    });
    let l = out.nodes.len();
    out.nodes.push(Node::default());
    out.nodes.push(Node::default());
    out.nodes[d] = node(l as u32, 0);
    let (left, right) = prims.split_at_mut(mid);
    let a = median(left, l, tris, out);
    let b = median(right, l + 1, tris, out);
    1 + a.max(b)
}
