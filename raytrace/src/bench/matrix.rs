//! The thesis experiment on real devices: every (shader, task size, policy, mode) of one scene
//! rendered through `sched`, one record per run. A cell renders frames of whole paths on
//! path-resident devices (see `paths.rs`); a record covers every ray of its frames.

use std::num::NonZeroUsize;

use sched::Policy;

use super::error::BenchError;
use super::record::Record;
use super::repeats;
use crate::bvh::Bvh;
use crate::cost::SampleRate;
use crate::paths::{FrameStats, Mode, PathRenderer, Settings};
use crate::run::Store;
use crate::scene::Scene;
use crate::shade::Shader;

/// The kind of a workload's rays, as records name it: Whitted's are `coherent`, AO's
/// `diffuse`.
pub(super) fn ray_kind(shader: &Shader) -> &'static str {
    match shader {
        Shader::Whitted(_) => "coherent",
        Shader::Ao(_) => "diffuse",
    }
}

impl Record {
    /// A record of one run of `matrix`'s cell (`w`, `settings`) on `devices` devices, its
    /// figures still zero.
    pub fn new(matrix: &SceneMatrix<'_>, w: Shader, settings: Settings, devices: usize) -> Self {
        Self {
            source: "measured",
            scene: matrix.scene_name.to_string(),
            shader: w.name(),
            ray_kind: ray_kind(&w),
            policy: settings.policy.name(),
            mode: settings.mode.name(),
            walk: settings.walk.name(),
            sample_rate: settings.rate_for(&w).get(),
            backups: settings.backups,
            task_size: settings.task_size.get(),
            devices,
            device_list: matrix.device_list.to_string(),
            cameras: matrix.cameras,
            width: matrix.width,
            height: matrix.height,
            balance_efficiency: 1.0,
            repeats: 1,
            ..Default::default()
        }
    }
}

/// What one run of a cell gave: its record, its measured frames (whose tasks the simulator
/// replays: each one's planned cost and measured time), and, when measured, the estimate's
/// prediction error.
pub struct CellRun {
    pub record: Record,
    pub frames: Vec<FrameStats>,
    pub error: Option<f64>,
}

/// The cost-mode run of one (workload, task size) kept for the simulator (see
/// `replay_policy`).
#[derive(Clone, Debug)]
pub struct Replays {
    pub(crate) workload: Shader,
    pub(crate) task_size: usize,
    pub(crate) prediction_error: Option<f64>,
    pub(crate) frames: Vec<FrameStats>,
}

/// What to run on one scene: every cell (workload, task size, policy, mode) of its matrix.
pub struct SceneMatrix<'a> {
    /// The scene as the records name it (`--scene`).
    pub scene_name: &'a str,
    /// The scene.
    pub scene: &'a Scene,
    /// The BVH of `scene`.
    pub bvh: &'a Bvh,
    /// The devices every cell renders on.
    pub devices: &'a [crate::devices::DeviceSpec],
    /// The devices as the records list them (`--devices`).
    pub device_list: &'a str,
    /// The workloads: each a shader with its settings (Whitted: coherent rays; AO: diffuse
    /// rays).
    pub workloads: &'a [Shader],
    /// Paths per task, each a cell of every workload.
    pub task_sizes: &'a [NonZeroUsize],
    /// The policies, each in every mode of `modes`.
    pub policies: &'a [Policy],
    /// `regular` (equal costs), `cost` (estimates) or both.
    pub modes: &'a [Mode],
    /// Orbit cameras, each a frame of every run.
    pub cameras: usize,
    /// The image size.
    pub width: u32,
    /// The image height.
    pub height: u32,
    /// AO probes per primary hit.
    pub ao_samples: u32,
    /// The share of each task's paths cost mode samples (`None`: each shader's own).
    pub sample_rate: Option<SampleRate>,
    /// How cost mode counts a sampled path.
    pub walk: crate::traverse::Walk,
    /// Whether idle devices run backup copies (`--no-backups` turns them off).
    pub backups: bool,
    /// Devices made slower on purpose (`--slow`).
    pub slow: &'a [crate::paths::SlowBy],
    /// Runs of every cell, in rounds that each run every cell of the matrix once.
    pub repeats: usize,
    /// The calibration that plans each path cell's first frame and keeps what it learnt.
    pub calibration: Option<&'a std::cell::RefCell<Store>>,
    /// The path devices, kept from cell to cell (`None` before the first): a GPU keeps its
    /// context, compiled kernels, buffers and measured launch overhead, so a cell's frame is
    /// not its first on the device, and a cell runs on every device or on the fastest class
    /// alone by what the cells before it measured.
    pub path_devices: std::cell::RefCell<Option<PathRenderer<'a>>>,
    /// The MPI job whose other ranks render beside this rank's devices, every cell anew
    /// (`None`: this process alone).
    #[cfg(feature = "mpi")]
    pub cluster: Option<&'a sched::mpi::Cluster>,
}

impl SceneMatrix<'_> {
    /// Runs in the matrix, repeats included.
    pub fn runs(&self) -> usize {
        self.workloads.len()
            * self.task_sizes.len()
            * self.policies.len()
            * self.modes.len()
            * self.repeats
    }

    /// Runs the whole matrix, calling `tick` after each run; returns one record per cell (the
    /// medians of its repeats) and, per (workload, task size), the replay of the cost-mode
    /// run of median time under `replay_policy`.
    pub fn run(
        &self,
        mut tick: impl FnMut(&str),
    ) -> Result<(Vec<Record>, Vec<Replays>), BenchError> {
        // Untimed warm-up: page in the scene, the BVH and the thread pools.
        if let Some(&w) = self.workloads.first() {
            self.run_paths(w, Settings::default(), false)?;
        }
        // Every cell of the matrix: (workload, task size) blocks of policies and modes.
        let mut cells: Vec<(Shader, Settings)> = Vec::new();
        for &w in self.workloads {
            for &size in self.task_sizes {
                for &policy in self.policies {
                    for &mode in self.modes {
                        let settings = Settings {
                            policy,
                            mode,
                            task_size: size,
                            sample_rate: self.sample_rate,
                            walk: self.walk,
                            backups: self.backups,
                        };
                        cells.push((w, settings));
                    }
                }
            }
        }
        let block = |(w, s): &(Shader, Settings)| (*w, s.task_size.get());
        let mut errors: Vec<((Shader, usize), f64)> = Vec::new();
        let mut runs: Vec<Vec<Record>> = vec![Vec::new(); cells.len()];
        let kept_policy = replay_policy(self.policies);
        let mut kept: Vec<Vec<Vec<FrameStats>>> = vec![Vec::new(); cells.len()];
        // Round after round of the whole matrix, so that a spell of load on the machine falls
        // on every cell alike instead of on all the runs of one cell or one task size.
        for _ in 0..self.repeats {
            for (cell, c) in cells.iter().enumerate() {
                let ((w, settings), key) = (*c, block(c));
                let known = errors.iter().any(|(k, _)| *k == key);
                let measure_error = settings.mode == Mode::Cost && !known;
                let run = self.run_paths(w, settings, measure_error)?;
                if let Some(e) = run.error {
                    errors.push((key, e));
                }
                if settings.mode == Mode::Cost && Some(settings.policy) == kept_policy {
                    kept[cell].push(run.frames);
                }
                runs[cell].push(run.record);
                tick(&format!(
                    "{} {} {} {}",
                    w.name(),
                    settings.task_size,
                    settings.policy.name(),
                    settings.mode.name()
                ));
            }
        }
        let mut records = Vec::new();
        let mut replays = Vec::new();
        for (cell, c) in cells.iter().enumerate() {
            let (w, settings) = c;
            let Some(mut r) = repeats::combine(&runs[cell]) else {
                continue;
            };
            // The estimates, and so their error, depend on neither the policy nor the run.
            let error = errors.iter().find(|(k, _)| *k == block(c)).map(|&(_, e)| e);
            r.prediction_error = error.filter(|_| settings.mode == Mode::Cost);
            if let Some(mid) = repeats::median_run(&runs[cell]).filter(|_| !kept[cell].is_empty()) {
                replays.push(Replays {
                    workload: *w,
                    task_size: settings.task_size.get(),
                    prediction_error: error,
                    frames: std::mem::take(&mut kept[cell][mid]),
                });
            }
            records.push(r);
        }
        Ok((records, replays))
    }
}

/// The policy whose cost-mode runs the simulator replays: a queue's, whose launches hold one
/// task each, so that each task's measured time is its own. A static plan launches a device's
/// tasks together and times them together (the launch's time falls on its first task), which
/// a machine of more devices could not replay. Static LPT where no queue was run.
pub(crate) fn replay_policy(policies: &[Policy]) -> Option<Policy> {
    [Policy::QueueSorted, Policy::QueueFifo, Policy::StaticLpt]
        .into_iter()
        .find(|p| policies.contains(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_queue_run_is_replayed_before_a_static_plan() {
        use Policy::{Hybrid, QueueFifo, QueueSorted, StaticLpt};
        assert_eq!(replay_policy(&[StaticLpt, QueueFifo]), Some(QueueFifo));
        assert_eq!(replay_policy(&[QueueFifo, QueueSorted]), Some(QueueSorted));
        assert_eq!(replay_policy(&[StaticLpt, Hybrid]), Some(StaticLpt));
        assert_eq!(replay_policy(&[Hybrid]), None);
    }
}
