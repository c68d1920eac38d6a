//! Ray tracing workload of cobalt: scenes, a BVH shared by CPU and GPU, and robust traversal.
//!
//! The pieces, in the order data flows through them (see ARCHITECTURE.md):
//! - [`Scene`] (from an OBJ file or a built-in generator, via [`SceneSource`]) keeps only what the
//!   shader needs ([`SceneNeeds`]);
//! - [`Bvh`] is built by obvhs ([`BuildPreset`]) and flattened into one GPU-uploadable [`Node`]
//!   layout plus a [`BvhTriangle`] array in leaf order;
//! - rays ([`Ray`], [`RayBatch`]) are traced by closest-hit, any-hit, counting and the thesis's
//!   reduced traversal ([`traverse`]); the ray/triangle test is watertight and the ray/box test
//!   conservative, and secondary rays are spawned without self-intersection ([`spawn`]);
//! - [`shade`] drives generations of rays (primary, shadow, reflection, AO) through one
//!   [`shade::Tracer`] into a [`Film`]; [`cost_image`] draws where the traversal work is.
//!
//! ## Example
//!
//! ```
//! use raytrace::{Bvh, BuildPreset, Ray, SceneNeeds, SceneSource};
//!
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(SceneNeeds::AO)?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let c = scene.bounds().center();
//! let ray = Ray::new(c, glam::Vec3::new(0.0, -1.0, 0.0));
//! let hit = bvh.closest_hit(&ray).expect("the floor is below the centre");
//! assert!(hit.t > 0.0);
//! # Ok::<(), raytrace::Error>(())
//! ```

mod aabb;
pub mod ao;
pub mod atomic;
pub mod bench;
pub mod builtin;
pub mod bvh;
pub mod calibration;
pub mod camera;
pub mod cost;
pub mod cost_image;
pub mod devices;
#[cfg(feature = "mpi")]
pub mod distributed;
mod error;
pub mod estimate;
mod file;
pub mod film;
mod gltf;
#[cfg(feature = "gpu")]
pub mod gpu;
mod obj;
pub mod paths;
mod ply;
mod pool;
mod ray;
pub mod run;
mod scene;
mod scene_source;
pub mod shade;
mod slab;
pub mod spawn;
pub mod testkit;
#[cfg(test)]
mod tests;
pub mod tradeoff;
mod traffic;
pub mod traverse;
mod triangle;
pub mod workload;

pub use aabb::Aabb;
pub use bvh::{BuildPreset, BuildReport, Bvh, BvhTriangle, Node};
pub use camera::{Camera, PrimaryRays};
pub use error::Error;
pub use film::Film;
/// The math crate of the public API (points, directions, colours), so callers need not pin it.
pub use glam;
pub use ray::{Hit, HitBatch, RAY_RECORD_BYTES, Ray, RayBatch, RayKind};
pub use scene::{DEFAULT_REFLECTANCE, Light, LoadReport, Material, Scene, SceneNeeds};
pub use scene_source::SceneSource;
/// The seeded generator of the built-in scenes and the seeded tests.
pub use sched::Rng;
pub use traffic::Traffic;
pub use traverse::{Counts, Layout, Walk};
pub use triangle::{RayShear, intersect_watertight};

/// Result alias for this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
