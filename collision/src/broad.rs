use parry3d::partitioning::{BvhNode, TraversalAction};

use crate::World;

/// Broad-phase candidates of body `i`: the bodies `j > i` (each pair once) whose boxes
/// overlap its box, through the body BVH.
pub fn body_candidates(world: &World, i: usize, out: &mut Vec<u32>) {
    let aabb = &world.bodies[i].aabb;
    out.extend(
        world
            .body_bvh()
            .intersect_aabb(aabb)
            .filter(|&j| j as usize > i),
    );
}

/// Broad-phase candidates of body `i` among the mesh's triangles, through the mesh's BVH.
pub fn mesh_candidates(world: &World, i: usize, out: &mut Vec<u32>) {
    let aabb = &world.bodies[i].aabb;
    out.extend(world.mesh.bvh().intersect_aabb(aabb));
}

/// What a broad-phase query of one body does: BVH nodes entered and candidates it yields
/// (each a narrow-phase test to come).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Work {
    /// BVH nodes whose boxes were tested.
    pub nodes: f64,
    /// Candidate pairs found (bodies `j > i` and triangles).
    pub candidates: f64,
}

/// The reduced traversal: the same descent as the broad phase, counting nodes and leaves,
/// with no narrow phase (the expensive part).
pub fn count(world: &World, i: usize) -> Work {
    let query = BvhNode::leaf(world.bodies[i].aabb, 0);
    let mut work = Work::default();
    world.body_bvh().traverse(|node| {
        work.nodes += 1.0;
        if !node.intersects(&query) {
            TraversalAction::Prune
        } else {
            if node.leaf_data().is_some_and(|j| j as usize > i) {
                work.candidates += 1.0;
            }
            TraversalAction::Continue
        }
    });
    world.mesh.bvh().traverse(|node| {
        work.nodes += 1.0;
        if !node.intersects(&query) {
            TraversalAction::Prune
        } else {
            if node.is_leaf() {
                work.candidates += 1.0;
            }
            TraversalAction::Continue
        }
    });
    work
}
