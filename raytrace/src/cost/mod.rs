//! Cost estimation of ray tasks by the thesis's reduced traversal (section 3.1), and what is
//! needed to judge it: full counts, measured task times, a least-squares calibration of
//! `C = kB·B + kT·T`, and the error metrics (the thesis's [`sched::prediction_error`],
//! [`error_vs_time`], [`sched::rank_correlation`]).
//!
//! A task is a `Range<usize>` of a [`RayBatch`](crate::RayBatch) (`sched` implements
//! [`sched::Task`] for ranges). The pieces:
//! - [`SampleRate`] and [`SampleRun`]: a uniform stride sample of every task, compacted into
//!   one contiguous list of ray indices (the thesis compacts the sample before the reduced
//!   trace; the CPU reads the sampled rays in place through it), refined where asked;
//! - [`ReducedTraversal`]: the estimator, a [`sched::CostEstimator`], written once over what
//!   counts its sample ([`CountRays`]: the host's tree or a GPU); [`full_work`] is the same
//!   count over *all* rays, the reference of the prediction error;
//! - [`measure_seconds`]: the measured trace time of each task;
//! - [`CostModel`] and [`calibrate`]: `kB`, `kT` fitted to measured times;
//! - [`error_vs_time`] and `sched::rank_correlation`: the metrics beyond the thesis's, and
//!   [`judge`]: estimates judged by measured times, with the balance they buy a plan;
//! - [`Rounds`]: an estimate timed against the trace it saves, in rounds.
//!
//! ## Example
//!
//! ```
//! use raytrace::cost::{CostModel, ReducedTraversal, SampleRate, full_work};
//! use raytrace::{BuildPreset, Bvh, Camera, SceneNeeds, SceneSource, Walk};
//! use sched::{CostEstimator, prediction_error};
//!
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(SceneNeeds::AO)?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let rays = Camera::orbit(&scene.bounds(), 0).primary_rays(32, 32).rays;
//! let tasks = sched::split_ranges(rays.len(), 128);
//!
//! let estimator = ReducedTraversal::new(&bvh, &rays, SampleRate::new(0.125)?);
//! let estimate = estimator.estimate_timed(&tasks)?; // costs and overhead
//! let (est, full) = (estimator.try_work(&tasks)?, full_work(&bvh, &rays, &tasks, Walk::Reduced)?);
//! let model = CostModel::default();
//! let error = prediction_error(&model.costs(&est), &model.costs(&full)).ok_or("no full cost")?;
//! assert!(estimate.costs.len() == 8 && error < 0.5);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod calibrate;
mod error;
mod estimator;
pub mod judge;
mod measure;
mod model;
mod refine;
mod rounds;
mod sample;

pub use calibrate::{Fit, FitForm, calibrate};
pub use error::CostError;
pub use estimator::{CountRays, ReducedTraversal, full_work};
pub use judge::error_vs_time;
pub use measure::measure_seconds;
pub use model::{CostModel, Work};
pub use rounds::{Budget, Rounds, SlicedStep, SlicedTraces, WholeStep};
pub use sample::{Sample, SampleRate, SampleRun, Traced};
