//! Path-resident rendering: every frame goes through `sched`, on CPUs, GPUs or any mix.
//!
//! A task is a range of paths (pixels in the image's Morton order). The device that gets a
//! task makes its primary rays itself, traces and shades every generation of those paths
//! where their rays are (GPU: kernels; CPU: the host's shading), and returns one value per
//! path at the end of its launch. The host sees task lists, costs and the paths' values;
//! no ray or hit crosses a link, so traffic grows with tasks, not with rays.
//!
//! The pieces:
//! - [`PathDevice`]: a device that renders ranges of paths ([`CpuPaths`], and `GpuPaths`
//!   with the `gpu` feature); [`BoundPaths`] makes one a [`sched::Executor`] for a frame;
//! - [`build_path_devices`]: a `--devices` list (with injected faults, [`FailAfter`], and
//!   slowdowns, [`SlowBy`]) made into devices;
//! - [`Settings`] and [`Mode`]: policy, regular or cost-based, task size, sample rate;
//! - [`sample_paths`]: a task's cost from a sample of its paths traced for real, or
//!   ([`walk_paths`]) from their camera rays walked as the thesis does;
//! - [`PathRenderer`]: a frame cut into tasks, costed, planned and run; [`FrameStats`] says
//!   what it did, [`Traffic`] what crossed between host and devices;
//! - [`PathRenderer::recall`] and [`PathRenderer::remember`]: the speeds and cost model of a
//!   [`crate::calibration::Calibration`] plan the first frame, and what the frames measured
//!   (timing spikes left out) goes back into it.
//!
//! ## Example
//!
//! ```
//! use raytrace::devices::parse_devices;
//! use raytrace::paths::{PathRenderer, Settings, build_path_devices};
//! use raytrace::shade::{CpuTracer, RenderOptions, Shader, render};
//! use raytrace::{BuildPreset, Bvh, Camera, SceneSource};
//!
//! let shader = Shader::Whitted(Default::default());
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(shader.needs())?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let options = RenderOptions::new(16, 16, Camera::orbit(&scene.bounds(), 0), shader);
//!
//! let devices = build_path_devices(&scene, &bvh, &parse_devices("cpu:2")?, &[], &[])?;
//! let mut renderer = PathRenderer::new(devices, Settings::default())?;
//! let frame = renderer.render(&scene, &bvh, &options)?;
//! assert_eq!(frame.film, render(&scene, &mut CpuTracer::new(&bvh), &options).film);
//! assert_eq!(frame.stats.traffic().bytes(), 0, "CPU devices share the host's memory");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod build;
mod choice;
mod cpu;
mod device;
mod estimate;
mod fault;
mod frame;
#[cfg(feature = "gpu")]
mod gpu;
mod learn;
mod memory;
mod renderer;
mod settings;
mod stats;

pub use crate::traffic::Traffic;
pub use build::build_path_devices;
pub use cpu::CpuPaths;
pub use device::{BoundPaths, Estimate, Launch, PathDevice, TaskValues};
pub use estimate::{SampledTask, sample_paths, sampled_options, task_work, walk_paths};
pub use fault::{FailAfter, InjectedFault, InjectedPaths, SlowBy};
pub use frame::Frame;
#[cfg(feature = "gpu")]
pub use gpu::GpuPaths;
pub use renderer::{FrameRendering, PathRenderer};
pub use settings::{Mode, Settings};
pub use stats::{FrameStats, PathDeviceStats, TaskStats};
