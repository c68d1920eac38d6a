use parry3d::bounding_volume::Aabb;
use parry3d::math::{Pose, Vector};
use parry3d::shape::SharedShape;

use sched::Rng;

/// One moving body at its current pose.
#[derive(Clone)]
pub struct Body {
    /// A ball, a cuboid or a convex hull.
    pub shape: SharedShape,
    /// Where it is.
    pub pose: Pose,
    /// Its world-space bounding box (cached: the broad phase reads it for every test).
    pub aabb: Aabb,
}

impl std::fmt::Debug for Body {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Body")
            .field("shape", &self.shape.shape_type())
            .field("aabb", &self.aabb)
            .finish()
    }
}

impl Body {
    /// A body of `shape` at `pose`.
    pub fn new(shape: SharedShape, pose: Pose) -> Self {
        let aabb = shape.compute_aabb(&pose);
        Body { shape, pose, aabb }
    }
}

/// How bodies are scattered in the unit cube: a share of them crowded into a few tight
/// swarms (where every body touches many others), the rest spread thinly.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Swarms {
    /// Number of swarms.
    pub swarms: usize,
    /// Share of the bodies in swarms, in `[0, 1]`.
    pub crowded: f32,
    /// Standard deviation of a swarm's positions.
    pub sigma: f32,
    /// Typical body size (half-extent).
    pub size: f32,
}

impl Default for Swarms {
    fn default() -> Self {
        Swarms {
            swarms: 6,
            crowded: 0.5,
            sigma: 0.03,
            size: 0.01,
        }
    }
}

/// `n` bodies, a third each balls, cuboids and convex hulls of random points, randomly
/// rotated, placed by `spec`; reproducible from `seed`.
pub fn random_bodies(n: usize, spec: Swarms, seed: u64) -> Vec<Body> {
    let mut rng = Rng::new(seed);
    let centres: Vec<[f32; 3]> = (0..spec.swarms.max(1))
        .map(|_| {
            [
                0.2 + 0.6 * rng.f32(),
                0.2 + 0.6 * rng.f32(),
                0.1 + 0.5 * rng.f32(),
            ]
        })
        .collect();
    (0..n)
        .map(|i| {
            let p = if spec.swarms > 0 && rng.f32() < spec.crowded {
                let c = centres[rng.below(centres.len() as u32) as usize];
                c.map(|x| x + spec.sigma * rng.normal())
            } else {
                [rng.f32(), rng.f32(), rng.f32()]
            };
            let s = spec.size * (0.5 + rng.f32());
            let shape = match i % 3 {
                0 => SharedShape::ball(s),
                1 => SharedShape::cuboid(s, 0.5 * s + s * rng.f32(), s * rng.f32() + 0.2 * s),
                _ => {
                    let pts: Vec<Vector> = (0..8)
                        .map(|_| Vector::new(rng.normal(), rng.normal(), rng.normal()) * s)
                        .collect();
                    SharedShape::convex_hull(&pts).unwrap_or_else(|| SharedShape::ball(s))
                }
            };
            let axis = Vector::new(rng.normal(), rng.normal(), rng.normal()) * 0.5;
            Body::new(shape, Pose::new(Vector::new(p[0], p[1], p[2]), axis))
        })
        .collect()
}
