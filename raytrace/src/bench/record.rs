//! One run of a matrix cell as `cobalt bench` reports it ([`Record`]): what a cell's run fills
//! in (`matrix.rs`, `paths.rs`), what repeated runs are combined into (`repeats.rs`), and what
//! the table and the charts read.

use serde::Serialize;

/// One run of the matrix: the fields `cobalt bench --json` promises, plus context.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Record {
    /// `measured` (a run on real devices) or `mpi` (a run over the ranks of an MPI job).
    pub source: &'static str,
    /// The scene (`--scene`).
    pub scene: String,
    /// The workload: `whitted` or `ao`.
    pub shader: &'static str,
    /// Its rays: `coherent` or `diffuse`.
    pub ray_kind: &'static str,
    /// The policy that planned the run.
    pub policy: &'static str,
    /// `regular` (equal costs) or `cost` (estimates).
    pub mode: &'static str,
    /// How cost mode counted a sampled path (`--walk`): `trace`, `reduced` or `first-leaf`.
    pub walk: &'static str,
    /// The share of each task's paths cost mode sampled (`--sample-rate`, else the shader's).
    pub sample_rate: f64,
    /// Whether idle devices ran backup copies of the tasks others held (false with
    /// `--no-backups`).
    pub backups: bool,
    /// The cell's entry of `--task-sizes`.
    pub task_size: usize,
    /// What a frame of the cell was cut into: its tasks, and the paths of the largest
    /// (`task_size`, or fewer where the frame is too small to give every device four tasks).
    pub tasks: usize,
    /// The paths of the largest task a frame was cut into.
    pub cut_task_size: usize,
    /// Devices the run used.
    pub devices: usize,
    /// The devices as given (`--devices`).
    pub device_list: String,
    /// Orbit cameras, a frame each.
    pub cameras: usize,
    /// The image width.
    pub width: u32,
    /// The image height.
    pub height: u32,
    /// Rays traced over the frames.
    pub rays: usize,
    /// Wall time of the measured frames: estimation, planning and rendering.
    pub seconds: f64,
    /// Rendering efficiency (thesis): rays over `seconds`.
    pub mrays_per_s: f64,
    /// Σ device busy time / Σ (makespan × devices), over the measured frames.
    pub balance_efficiency: f64,
    /// Seconds spent estimating the tasks (cost mode).
    pub estimate_seconds: f64,
    /// Frames whose estimate was the previous frame's, taken at no cost (the same scene,
    /// camera, tasks and sampling), over the cell's runs.
    pub estimates_reused: usize,
    /// Seconds spent planning.
    pub plan_seconds: f64,
    /// Σ|estimated − full| / Σ full (cost mode; the estimates do not depend on the policy).
    pub prediction_error: Option<f64>,
    /// Launches of the median run.
    pub launches: u64,
    /// Tasks re-run after a device failed, over all runs.
    pub reruns: u64,
    /// Runs of this cell (`--repeats`); the figures above are their medians.
    pub repeats: usize,
    /// Every run's MRays/s, in the order they ran.
    pub run_mrays_per_s: Vec<f64>,
    /// Every run's balance efficiency, in the order they ran.
    pub run_balance_efficiency: Vec<f64>,
    /// What crossed between the host and the devices, the paths' values excepted.
    #[serde(flatten)]
    pub traffic: crate::traffic::Traffic,
    /// Bytes of the paths' values sent to the host.
    pub film_bytes: u64,
    /// `seconds` with the run's makespans replaced by their replays in `sched`'s simulator,
    /// from the run's own task times, speeds and launch delays (the median over the runs);
    /// `None` where a frame could not be replayed (a device failed).
    pub simulated_seconds: Option<f64>,
    /// Every run's simulated over measured seconds, in the order they ran.
    pub run_simulated_over_measured: Vec<f64>,
    /// `seconds` with the run's makespans replaced by the ones predicted before each frame
    /// ran, from its estimates and each device class's paths per second on earlier frames
    /// (the median over the runs); `None` where a frame had no prediction (a class not yet
    /// measured).
    pub predicted_seconds: Option<f64>,
    /// Every predicted run's predicted over measured seconds, in the order they ran.
    pub run_predicted_over_measured: Vec<f64>,
    /// Σ makespans of the measured frames, and of their replays.
    pub makespan_seconds: f64,
    /// Σ of the replays' makespans.
    pub simulated_makespan_seconds: Option<f64>,
    /// Σ of their lower bounds: integral (no plan beats the largest task on the fastest
    /// device), and fractional (all work over all speed, what balance efficiency is measured
    /// against).
    pub lower_bound_seconds: Option<f64>,
    /// Σ of the fractional lower bounds (all work over all speed).
    pub fractional_bound_seconds: Option<f64>,
    /// `makespan_seconds / lower_bound_seconds`: 1 is an optimal plan.
    pub makespan_over_bound: Option<f64>,
    /// The calibration file that planned the cell's first frame, the entries it used, and
    /// the entries the bench wrote back (path pipeline, unless `--no-calibration`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<crate::run::CalibrationReport>,
    /// Devices a frame of the cell left idle because the fastest class alone had rendered
    /// frames faster (path pipeline; absent when none was).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub left_idle: Vec<String>,
    /// What a run over MPI ranks adds (`mpi` records only).
    #[serde(flatten)]
    pub mpi: Option<MpiFigures>,
}

/// What a run over the ranks of an MPI job measures beside a record's figures.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MpiFigures {
    /// Ranks of the MPI job.
    pub ranks: usize,
    /// Seconds rank 0 spent inside MPI calls.
    pub comm_seconds: f64,
    /// `comm_seconds` over the record's `seconds`.
    pub comm_share: f64,
    /// Σ over the other ranks of their round trips' time not spent working.
    pub dispatch_overhead_seconds: f64,
    /// Batches sent to the other ranks.
    pub batches: u64,
}
