//! Collision queries on [parry3d], balanced across devices by [`sched`].
//!
//! Many moving bodies (balls, cuboids, convex hulls; [`random_bodies`] crowds some into
//! swarms) against each other and a static triangle mesh ([`terrain`] or a scene). A task
//! is a range of the Morton-sorted bodies; its [`Device`] runs the broad phase through
//! parry's BVHs and the narrow phase with parry's `contact`. The [`BroadPhaseCount`]
//! estimator is the thesis's reduced traversal: the broad phase of a sample of the bodies,
//! counting nodes and candidate pairs, with no narrow phase.
//!
//! # Example
//!
//! ```
//! use collision::{BroadPhaseCount, Device, SampleRate, Swarms, World, random_bodies, terrain};
//! use sched::{CostEstimator, Policy, Runtime};
//!
//! let world = World::new(random_bodies(600, Swarms::default(), 1), terrain(16)?);
//! let tasks = sched::split_ranges(world.len(), 32);
//! let estimator = BroadPhaseCount::new(&world, SampleRate::new(0.25)?);
//! let costs = estimator.estimate_timed(&tasks)?.costs;
//!
//! let mut devices = Device::many(&world, 2);
//! let run = Runtime::new(Policy::StaticLpt).run(&tasks, &costs, &mut devices)?;
//! let mut pairs: Vec<_> = run.outputs.into_iter().flatten().collect();
//! pairs.sort_unstable();
//! assert_eq!(pairs, collision::brute_force(&world));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bodies;
mod broad;
mod error;
mod estimate;
mod mesh;
mod narrow;
mod task;
mod world;

pub use bodies::{Body, Swarms, random_bodies};
pub use broad::{Work, body_candidates, count, mesh_candidates};
pub use error::CollisionError;
pub use estimate::{BroadPhaseCount, CANDIDATE_WEIGHT, SampleRate, prediction_error};
pub use mesh::{scene_mesh, terrain};
pub use narrow::{Pair, bodies_touch, brute_force, touches_triangle};
pub use raytrace::Rng;
pub use task::Device;
pub use world::World;
