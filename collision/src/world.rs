use parry3d::partitioning::{Bvh, BvhBuildStrategy};
use parry3d::shape::TriMesh;

use crate::Body;

/// Bodies (sorted along the Z curve, so a range of them is a compact region: a coherent
/// task) and the static mesh, each with a BVH for the broad phase.
pub struct World {
    /// The bodies, in Morton order of their centres; pair ids index this.
    pub bodies: Vec<Body>,
    /// The static triangle mesh (parry keeps its own BVH over the triangles).
    pub mesh: TriMesh,
    bvh: Bvh,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("bodies", &self.bodies.len())
            .field("triangles", &self.mesh.num_triangles())
            .finish_non_exhaustive()
    }
}

impl World {
    /// Sorts `bodies` spatially and builds the body BVH.
    pub fn new(bodies: Vec<Body>, mesh: TriMesh) -> Self {
        let centres: Vec<[f32; 3]> = bodies.iter().map(|b| b.aabb.center().to_array()).collect();
        let order = sched::locality::morton_order(&centres);
        let bodies: Vec<Body> = order.iter().map(|&i| bodies[i as usize].clone()).collect();
        let aabbs: Vec<_> = bodies.iter().map(|b| b.aabb).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::default(), &aabbs);
        World { bodies, mesh, bvh }
    }

    /// The BVH over the bodies' boxes; leaf `i` is body `i`.
    pub fn body_bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// True when there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }
}
