//! Collision queries on [parry3d], balanced across devices by [`sched`].
//!
//! Many moving bodies (balls, cuboids, convex hulls; [`random_bodies`] crowds some into
//! swarms) against each other and a static triangle mesh ([`terrain`], or any mesh through
//! [`unit_cube_mesh`]). A task is a range of the bodies sorted along the Z curve
//! ([`sched::locality`]); its [`Device`] runs the broad phase through parry's BVHs and the
//! narrow phase with parry's `contact`. The [`BroadPhaseCount`] estimator is a reduced
//! traversal: the broad phase of a sample of the bodies, counting nodes and candidate pairs,
//! with no narrow phase (the candidate pairs stand for the narrow phase's work).
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
pub use mesh::{terrain, unit_cube_mesh};
pub use narrow::{Pair, bodies_touch, brute_force, touches_triangle};
pub use task::Device;
pub use world::World;
