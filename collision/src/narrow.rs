use parry3d::bounding_volume::BoundingVolume;
use parry3d::math::Pose;
use parry3d::query;
use parry3d::shape::Shape;

use crate::World;

/// A contact found: two bodies, or a body and a triangle of the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Pair {
    /// Bodies `a < b` touch or overlap.
    Bodies(u32, u32),
    /// Body `body` touches or overlaps triangle `triangle` of the mesh.
    Mesh {
        /// The body.
        body: u32,
        /// The triangle's index in the mesh.
        triangle: u32,
    },
}

/// Narrow phase of two bodies: parry3d's contact with no prediction distance (touching or
/// overlapping). `None` when parry has no algorithm for the pair of shapes.
pub fn bodies_touch(world: &World, a: usize, b: usize) -> Option<bool> {
    let (x, y) = (&world.bodies[a], &world.bodies[b]);
    query::contact(&x.pose, &*x.shape, &y.pose, &*y.shape, 0.0)
        .ok()
        .map(touching)
}

/// Narrow phase of a body and a mesh triangle.
pub fn touches_triangle(world: &World, body: usize, triangle: u32) -> Option<bool> {
    let x = &world.bodies[body];
    let tri = world.mesh.triangle(triangle);
    query::contact(&x.pose, &*x.shape, &Pose::IDENTITY, &tri, 0.0)
        .ok()
        .map(touching)
}

/// parry's support-map contact can return a contact a little apart (positive `dist`) even
/// with no prediction distance asked for, so the sign of `dist` decides.
fn touching(contact: Option<query::Contact>) -> bool {
    contact.is_some_and(|c| c.dist <= 0.0)
}

/// Every contact by testing every pair's boxes, then the same narrow phase: the reference
/// for the BVH broad phase, on small inputs. (Without the box test, parry's contact called a
/// convex hull and a cuboid whose boxes are apart touching: seed 1 of the crate example.)
pub fn brute_force(world: &World) -> Vec<Pair> {
    let mut pairs = Vec::new();
    for a in 0..world.len() {
        for b in a + 1..world.len() {
            let boxes = world.bodies[a].aabb.intersects(&world.bodies[b].aabb);
            if boxes && bodies_touch(world, a, b) == Some(true) {
                pairs.push(Pair::Bodies(a as u32, b as u32));
            }
        }
        for t in 0..world.mesh.num_triangles() as u32 {
            let tri = world.mesh.triangle(t).compute_aabb(&Pose::IDENTITY);
            if world.bodies[a].aabb.intersects(&tri) && touches_triangle(world, a, t) == Some(true)
            {
                pairs.push(Pair::Mesh {
                    body: a as u32,
                    triangle: t,
                });
            }
        }
    }
    pairs.sort_unstable();
    pairs
}
