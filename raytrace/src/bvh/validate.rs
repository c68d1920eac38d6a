//! Structural checks of a built [`Bvh`] against its scene. Traversal relies on these
//! invariants (its indexing is in bounds because of them), and the GPU will too.

use super::{Bvh, MAX_DEPTH};
use crate::{Aabb, Error, Node, Result, Scene};

/// What validation counted on the way.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ValidationReport {
    /// Nodes reached from the root.
    pub nodes: usize,
    /// Leaves reached.
    pub leaves: usize,
    /// Distinct scene triangles referenced by leaves.
    pub triangles: usize,
    /// Deepest leaf (root = 1).
    pub depth: usize,
}

/// Checks that:
/// - every node is reached from the root exactly once, children come after their parent and
///   sibling pairs are in bounds;
/// - children's boxes lie inside their parent's;
/// - leaves partition the triangle array, and each triangle's box lies in its leaf's box
///   (or, with spatial splits, overlaps it);
/// - each triangle matches the scene's vertices for its primitive id;
/// - every non-degenerate triangle appears exactly once (at least once with spatial splits),
///   and no degenerate one does;
/// - the depth is what the build recorded and within [`MAX_DEPTH`].
pub fn validate(bvh: &Bvh, scene: &Scene) -> Result<ValidationReport> {
    let bad = |s: String| Err(Error::InvalidBvh(s));
    let nodes = &bvh.nodes;
    let tris = &bvh.tris;
    let splits = bvh.report.spatial_splits;
    if nodes.is_empty() {
        return bad("no nodes".into());
    }
    let mut report = ValidationReport::default();
    if tris.is_empty() {
        // The build's empty tree: one node, and nothing that should have been in it.
        if nodes.len() != 2 || nodes[0].count != 0 || !nodes[0].aabb().is_empty() {
            return bad("an empty tree must be one empty node".into());
        }
        if let Some(p) = (0..scene.len()).find(|&p| !scene.is_degenerate(p)) {
            return bad(format!("triangle {p} is missing"));
        }
        report.nodes = 1;
        report.depth = 1;
        return Ok(report);
    }
    let mut seen_node = vec![false; nodes.len()];
    let mut covered = vec![false; tris.len()];
    let mut prim_refs = vec![0u32; scene.len()];
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, level)) = stack.pop() {
        if seen_node[i] {
            return bad(format!("node {i} is reached twice"));
        }
        seen_node[i] = true;
        report.nodes += 1;
        report.depth = report.depth.max(level);
        let n = &nodes[i];
        let bx = n.aabb();
        if n.is_leaf() {
            report.leaves += 1;
            let (a, c) = (n.index as usize, n.count as usize);
            if a + c > tris.len() {
                return bad(format!(
                    "leaf {i} triangles {a}..{} beyond {}",
                    a + c,
                    tris.len()
                ));
            }
            for (k, t) in tris.iter().enumerate().skip(a).take(c) {
                if covered[k] {
                    return bad(format!("triangle slot {k} is in two leaves"));
                }
                covered[k] = true;
                let p = t.prim as usize;
                if p >= scene.len() {
                    return bad(format!("slot {k} has primitive id {p} beyond the scene"));
                }
                let v = scene.vertices(p).map(|v| v.to_array());
                if v != [t.v0, t.v1, t.v2] {
                    return bad(format!("slot {k} vertices differ from scene triangle {p}"));
                }
                if scene.is_degenerate(p) {
                    return bad(format!("degenerate triangle {p} is in leaf {i}"));
                }
                let tb = Aabb::from_points(v.map(glam::Vec3::from));
                let ok = if splits {
                    bx.overlaps(&tb)
                } else {
                    bx.contains(&tb)
                };
                if !ok {
                    return bad(format!("triangle {p} is outside its leaf {i}'s box"));
                }
                prim_refs[p] += 1;
            }
        } else {
            let l = n.index as usize;
            if l <= i || l % 2 == 1 || l + 1 >= nodes.len() {
                return bad(format!("node {i} has children at {l} (of {})", nodes.len()));
            }
            for ch in [l, l + 1] {
                if !bx.contains(&nodes[ch].aabb()) {
                    return bad(format!("child {ch} sticks out of parent {i}"));
                }
                stack.push((ch, level + 1));
            }
        }
    }
    // Index 1 is padding (`Node::PAD`), not a tree node; every other node is reached.
    let pads = |i: usize| i == 1;
    if let Some(i) = (0..nodes.len()).find(|&i| seen_node[i] == pads(i)) {
        return bad(format!("node {i} is unreachable or a reached pad"));
    }
    if let Some(i) = (0..nodes.len()).find(|&i| pads(i) && nodes[i] != Node::PAD) {
        return bad(format!("pad node {i} is not Node::PAD"));
    }
    if let Some(k) = covered.iter().position(|c| !c) {
        return bad(format!("triangle slot {k} is in no leaf"));
    }
    for (p, &r) in prim_refs.iter().enumerate() {
        let want_some = !scene.is_degenerate(p);
        if want_some && r == 0 {
            return bad(format!("triangle {p} is missing"));
        }
        if !splits && r > 1 {
            return bad(format!("triangle {p} appears {r} times"));
        }
    }
    report.triangles = prim_refs.iter().filter(|&&r| r > 0).count();
    if report.depth != bvh.depth || report.depth > MAX_DEPTH {
        return bad(format!(
            "depth {} (recorded {}, max {MAX_DEPTH})",
            report.depth, bvh.depth
        ));
    }
    Ok(report)
}
