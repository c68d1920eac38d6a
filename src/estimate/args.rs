//! The arguments of `cobalt estimate` ([`Args`]), read by the dispatch (`mod.rs`).

use std::num::NonZeroUsize;

use raytrace::RayKind;
use raytrace::cost::{SampleRate, SampleRun};
use raytrace::estimate::WalkChoice;

use crate::args::{
    MAX_AO_SAMPLES, Size, camera_index, count, positive_length, sample_rate, task_size,
};

/// Arguments of `cobalt estimate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub(super) scene: crate::args::SceneArgs,
    /// `primary` (camera rays), `ao` (32 Halton AO rays per primary hit), `whitted` (every
    /// generation of a Whitted render: primary, shadow and two bounces of reflection rays,
    /// each cut into its own tasks) or a binary ray file (`f32 × 8` per ray, see
    /// `cobalt trace`).
    #[arg(long)]
    pub(super) rays: String,
    /// Rays per task.
    #[arg(long, default_value = "4096", value_parser = task_size)]
    pub(super) task_size: NonZeroUsize,
    /// Fraction of each task's rays traced by the estimator, in (0, 1].
    #[arg(long, default_value = "0.125", value_parser = sample_rate)]
    pub(super) sample_rate: SampleRate,
    /// Adjacent rays the sample keeps together: longer runs trace faster, shorter ones spread
    /// the sample over more of each task (CPU only).
    #[arg(long, default_value_t = SampleRun::DEFAULT)]
    pub(super) sample_run: SampleRun,
    /// How far the CPU estimate's sample refines: it starts at a quarter of --sample-rate and
    /// doubles, up to it, while its two interleaved halves disagree by more than this share
    /// of the tasks' cost (the sample's expected part of `error_vs_time`); `off` samples every
    /// task at --sample-rate. The GPU estimator always samples at --sample-rate.
    #[arg(long, default_value_t = crate::args::SampleError(
        Some(raytrace::cost::ReducedTraversal::DEFAULT_SAMPLE_ERROR)
    ))]
    pub(super) sample_error: crate::args::SampleError,
    /// What times are taken on: `wall` time, or `cpu`, the CPU time of the whole process,
    /// which other work on a shared machine disturbs far less (CPU only; Linux).
    #[arg(long, default_value_t = sched::Clock::Wall)]
    pub(super) clock: sched::Clock,
    /// Image size `WxH` of the camera rays.
    #[arg(long, default_value = "512x512")]
    pub(super) size: Size,
    /// Orbit camera 0..3: above one quadrant of the scene, looking at its centre.
    #[arg(long, default_value = "0", value_parser = camera_index)]
    pub(super) camera: usize,
    /// AO rays per primary hit, 1..=4096.
    #[arg(long, default_value_t = 32,
          value_parser = clap::value_parser!(u32).range(1..=MAX_AO_SAMPLES as i64))]
    pub(super) ao_samples: u32,
    /// Length of AO rays as a fraction of the scene's bounding-box diagonal.
    #[arg(long, default_value_t = 0.05, value_parser = positive_length)]
    pub(super) ao_distance: f32,
    /// Kind of the rays of a ray file (primary, shadow, reflection, ao): decides closest- or
    /// any-hit tracing.
    #[arg(long, default_value = "primary")]
    pub(super) ray_kind: RayKind,
    /// Every timing is repeated this many times, 1..=1000, and the least kept. On the CPU the
    /// estimates, the full trace and the rest are timed in rounds, at least this many and more
    /// while the full trace's rounds add up to less than a second and a half (at most 128; an
    /// even count): the JSON's `rounds`. Within a round, the full trace and the rest of more
    /// than 2^19 rays run in up to 16 slices, taken in turn (the JSON's `slices`).
    #[arg(long, default_value_t = 3, value_parser = count::<1000>)]
    pub(super) repeats: usize,
    /// Where the estimator and the full trace run: `cpu` (all cores) or `gpu` (the first
    /// usable adapter; software ones only with `COBALT_GPU_SOFTWARE=1`): the sample taken on
    /// the host, its rays traced by the reduced traversal on the device and their counts
    /// summed on the host, the same estimates as the CPU's. Measured task times (the
    /// calibration) stay single-thread CPU times.
    #[arg(long, value_enum, default_value = "cpu")]
    pub(super) device: crate::trace::Device,
    /// How the sample is traced: `trace` (the real trace, closest or any hit, counted as
    /// traced, its hits kept for the render; the default on the CPU), `reduced` (the reduced
    /// traversal of the whole range of every ray; the default, and the only one, on the
    /// GPU), `first-leaf` (closest-hit rays end at the exit of the first leaf they reach;
    /// shadow and AO rays keep the reduced walk), or `auto`: the reduced traversal whose
    /// full counts, calibrated, err least against the measured task times.
    #[arg(long)]
    pub(super) walk: Option<WalkChoice>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub(super) json: bool,
}
