//! Rendering through `sched`: every generation of rays (primary, shadow, reflection, AO) is
//! cut into tasks, costed (uniformly, or by the reduced traversal of a sample), planned by a
//! [`sched::Policy`] and run on devices; device speeds and `kB`, `kT` are measured as it goes
//! and used by the next generation's plan.
//!
//! The pieces:
//! - [`build_devices`]: a `--devices` list (with injected faults) made into devices;
//! - [`RayDevice`]: a device that traces ranges of rays ([`crate::cpu::CpuDevice`] is one);
//!   [`Bound`] makes it a [`sched::Executor`] for one generation;
//! - [`Settings`] and [`Mode`]: policy, regular or cost-based, task size, sample rate;
//! - [`ScheduledTracer`]: the [`crate::shade::Tracer`] that does it all;
//! - [`GenerationStats`]: what each generation did, for reports.
//!
//! ## Example
//!
//! ```
//! use raytrace::devices::parse_devices;
//! use raytrace::scheduled::{ScheduledTracer, Settings, build_devices};
//! use raytrace::shade::{CpuTracer, RenderOptions, Shader, render};
//! use raytrace::{BuildPreset, Bvh, Camera, SceneSource};
//!
//! let shader = Shader::Whitted(Default::default());
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(shader.needs())?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let options = RenderOptions::new(16, 16, Camera::orbit(&scene.bounds(), 0), shader);
//!
//! let devices = build_devices(&bvh, &parse_devices("cpu:2")?, &[])?;
//! let mut tracer = ScheduledTracer::new(&bvh, devices, Settings::default())?;
//! let image = render(&scene, &mut tracer, &options);
//! assert_eq!(image.film, render(&scene, &mut CpuTracer::new(&bvh), &options).film);
//! assert_eq!(tracer.stats()[0].devices.len(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod build;
mod learn;
mod settings;
mod speeds;
mod stats;
mod tracer;

pub use crate::ray_device::{BadRange, Bound, FailingAfter, InjectedFault, RayDevice};
pub(crate) use build::assemble;
#[cfg(not(feature = "gpu"))]
pub(crate) use build::no_gpus;
#[cfg(feature = "gpu")]
pub(crate) use build::open_gpus;
pub use build::{FailAfter, build_devices};
pub use settings::{EstimateOn, Mode, Settings};
pub use stats::{DeviceFit, DeviceStats, GenerationStats, TaskStats};
pub use tracer::ScheduledTracer;
