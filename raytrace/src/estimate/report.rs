//! The report of an estimate judged ([`Report`]): the estimator's error and overhead, every
//! walk's trade on the CPU and the calibrated model. `cobalt estimate` prints it as one JSON
//! object (its field names are read by users and tests, so they stay as they are) or as its
//! table (`table.rs`).

use serde::Serialize;

use crate::cost::{CostModel, Fit};

/// How well one walk's full reduced traversal, calibrated, explains the measured times.
#[derive(Debug, Serialize)]
pub struct WalkFit {
    /// The walk: `trace`, `reduced` or `first-leaf`.
    pub walk: &'static str,
    /// Its full counts' error, calibrated, against the measured task times.
    pub error_vs_time: Option<f64>,
    /// Their rank correlation with the measured task times.
    pub spearman_vs_time: Option<f64>,
}

/// One walk's estimates judged by the measured task times, and what they cost a render: every
/// walk's in a [`Report`]'s `walks` ([`WalkTrade`]), and a point of the bench's sampling
/// trade. Serialized flattened into each.
#[derive(Clone, Debug, Serialize)]
pub struct WalkFigures {
    /// The walk: `trace`, `reduced` or `first-leaf` (applied to closest-hit generations
    /// only).
    pub walk: &'static str,
    /// Its sampled estimates, calibrated, against each task's measured single-thread trace
    /// time.
    pub error_vs_time: Option<f64>,
    /// Their rank correlation with the measured task times.
    pub spearman_vs_time: Option<f64>,
    /// The thesis's (secondary: it judges the sample against its own walk's full count, not
    /// against time): Σ|est − full| / Σ full of `C` under the default model.
    pub prediction_error: Option<f64>,
    /// Estimate over full trace; on the CPU, the median over the pairs of rounds of each
    /// pair's own (see [`Rounds`](crate::cost::Rounds)).
    pub overhead: f64,
    /// `(estimate + rest − full trace) / full trace`, where `rest` is the full trace less
    /// the sampled rays when the walk traces them for real (a render takes their hits from
    /// the estimate), else the full trace: what estimating costs a render. On the CPU, the
    /// median over the pairs of rounds of each pair's own.
    pub net_overhead: f64,
}

/// One walk's trade on the CPU, timed in the same rounds as the others.
#[derive(Clone, Debug, Serialize)]
pub struct WalkTrade {
    /// How its estimates fared.
    #[serde(flatten)]
    pub figures: WalkFigures,
    /// The estimate's least time over the rounds.
    pub estimate_seconds: f64,
    /// What the estimates buy a plan: the balance of an LPT plan by them on
    /// `balance_devices` equal devices, judged by the measured task times.
    pub lpt_balance: Option<f64>,
}

/// A calibrated model, for the report: the fit of the estimates to the measured times.
#[derive(Debug, Serialize)]
pub struct Calibration {
    /// The device the model is for: one CPU thread (`cpu-thread`), as the times were measured.
    pub device: &'static str,
    /// The model and how well it fits (its fields flattened into this object).
    #[serde(flatten)]
    pub fit: Fit,
}

/// Everything is a fraction (not a percentage); a metric that is undefined for the input
/// (one task, all rays missing the scene) is `null`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// The estimator judged by time: its calibrated estimates against each task's measured
    /// single-thread trace time.
    pub error_vs_time: Option<f64>,
    /// Their rank correlation with the measured task times.
    pub spearman_vs_time: Option<f64>,
    /// The same with each task's exact counts of the real trace (closest or any hit, as
    /// traced): what no estimate of `B` and `T` can beat, whatever its walk and rate. What
    /// is left is time the counts do not see (caches, branches, the machine).
    pub error_vs_time_trace: Option<f64>,
    /// The real trace's counts' rank correlation with the times.
    pub spearman_trace_vs_time: Option<f64>,
    /// `(estimate + rest − full trace) / full trace`, where `rest` is the full trace less
    /// the sampled rays when the walk traces them for real (a render takes their hits from
    /// the estimate), else the full trace: what estimating costs a render. On the CPU, the
    /// median over the pairs of rounds of each pair's own (see [`Rounds`](crate::cost::Rounds)).
    pub net_overhead: f64,
    /// On the CPU, the first and third quartile of the pairs' own net overheads: how far
    /// the machine moved them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub net_overhead_quartiles: Option<[f64; 2]>,
    /// The scene (`--scene`).
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// The BVH build preset.
    pub preset: String,
    /// The rays' kind (`whitted` for a Whitted render's generations).
    pub ray_kind: &'static str,
    /// Whether the rays are coherent.
    pub coherent: bool,
    /// Rays estimated, over every generation.
    pub rays: usize,
    /// Rays per task.
    pub task_size: usize,
    /// Tasks the rays were cut into.
    pub tasks: usize,
    /// The share of each task's rays the estimate samples at most.
    pub sample_rate: f64,
    /// Adjacent rays the sample keeps together.
    pub sample_run: usize,
    /// The halves' disagreement the sample refined to; `None` where it was taken whole at
    /// `sample_rate` (`--sample-error off`, or the GPU estimator).
    pub sample_error: Option<f64>,
    /// `trace`, `reduced` or `first-leaf` (applied to closest-hit generations only): the one
    /// asked for, or the better fit with `--walk auto`.
    pub walk: &'static str,
    /// With `--walk auto`: how each walk fitted the measured times.
    pub walk_fits: Option<Vec<WalkFit>>,
    /// On the CPU: every walk's trade at this sample rate, timed in the same rounds.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub walks: Vec<WalkTrade>,
    /// Equal devices each walk's `lpt_balance` plans for.
    pub balance_devices: usize,
    /// The balance of LPT by the measured times themselves (the best an estimate can buy),
    /// and of the tasks dealt out in order without an estimate.
    pub balance_measured: Option<f64>,
    /// The balance of the tasks dealt out in order, without an estimate.
    pub balance_uniform: Option<f64>,
    /// Rays the asked walk's sample traced.
    pub sampled_rays: usize,
    /// The host's threads the estimate and the trace ran on.
    pub threads: usize,
    /// Timings asked for (`--repeats`).
    pub repeats: usize,
    /// Rounds the estimates, the full trace and the rest were timed in: at least `repeats`,
    /// more where the trace is short (see `--repeats`).
    pub rounds: usize,
    /// Slices each round cut the full trace and the rest in, taken in turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub slices: Option<usize>,
    /// What the times were taken on: `wall` or `cpu` (the process's CPU time).
    pub clock: &'static str,
    /// Where the estimate and the full trace ran: `cpu` or `gpu`.
    pub device: &'static str,
    /// The GPU adapter's name with `--device gpu`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adapter: Option<String>,
    /// The thesis's (secondary: it judges the sample against its own walk's full count, not
    /// against time): Σ|est − full| / Σ full of `C` under the default model.
    pub prediction_error: Option<f64>,
    /// The same for `B` and for `T` alone.
    pub prediction_error_nodes: Option<f64>,
    /// The same for `T` alone.
    pub prediction_error_tris: Option<f64>,
    /// Reduced traversal of the sample, gather included, on all cores (or on the GPU, the
    /// rays' upload included).
    pub estimate_seconds: f64,
    /// Full trace (closest or any hit, with triangle tests) of all rays, on all cores (or on
    /// the GPU, upload and read-back included). On the CPU, the least over the rounds of the
    /// trace's slices' sum (see [`Rounds`](crate::cost::Rounds)).
    pub trace_seconds: f64,
    /// Estimate over full trace; on the CPU, the median over the pairs of rounds of each
    /// pair's own.
    pub overhead: f64,
    /// With `--walk trace` on the CPU: the full trace less the sampled rays, which a render
    /// takes from the estimate instead of tracing them again; timed in slices, as the trace.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest_seconds: Option<f64>,
    /// The error against time with full counts: the best any sample rate could do.
    pub error_vs_time_full: Option<f64>,
    /// The full counts' rank correlation with the times.
    pub spearman_full_vs_time: Option<f64>,
    /// Σ measured task times (one thread).
    pub measured_seconds: f64,
    /// Mean `B`, `T` per ray of the reduced traversal and of the real trace (an any-hit
    /// trace counts up to its first hit): the reduced traversal never shortens a ray, so it
    /// enters more nodes than the trace does, which bounds how cheap a sample can be.
    pub reduced_nodes_per_ray: f64,
    /// Mean `T` per ray of the walk's full count.
    pub reduced_tris_per_ray: f64,
    /// Mean `B` per ray of the real trace.
    pub trace_nodes_per_ray: f64,
    /// Mean `T` per ray of the real trace.
    pub trace_tris_per_ray: f64,
    /// The default cost model, which the prediction errors are taken in.
    pub default_model: CostModel,
    /// The model calibrated to the measured task times.
    pub calibration: Option<Calibration>,
    /// Seconds the BVH took to build.
    pub build_seconds: f64,
}
