//! How the render engine cuts, costs and plans each frame: policy, mode, task size, sample rate.

use std::fmt;
use std::num::NonZeroUsize;
use std::str::FromStr;

use sched::Policy;

use crate::Walk;
use crate::cost::SampleRate;
use crate::shade::Shader;

/// Where the task costs of a frame come from: `--mode` on the command
/// line, and the `mode` of every report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Every task costs the same (`sched::Costs::uniform`): the thesis's regular mode, no
    /// estimation overhead.
    Regular,
    /// Each task's nodes `B` and triangle tests `T`, counted on a sample of its paths
    /// rendered for real, weighed by the calibrated `C = kB·B + kT·T` (thesis, chapter 3).
    #[default]
    Cost,
}

impl Mode {
    /// Both modes, in the order reports list them.
    pub const ALL: [Mode; 2] = [Mode::Regular, Mode::Cost];

    /// `regular` or `cost`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Regular => "regular",
            Mode::Cost => "cost",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| format!("unknown mode `{s}` (expected cost or regular)"))
    }
}

/// The scheduling settings of every frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// How tasks are assigned to devices.
    pub policy: Policy,
    /// Regular or cost-based.
    pub mode: Mode,
    /// Paths per task (the thesis uses 16384, 4096 and 512 rays); smaller frames are cut
    /// finer ([`Self::task_size_for`]).
    pub task_size: NonZeroUsize,
    /// Fraction of each task's paths the estimate samples (cost mode); `None`, the default,
    /// takes the shader's ([`Shader::sample_rate`]; what each costs and predicts:
    /// `docs/results.md`, "What an estimate costs").
    pub sample_rate: Option<SampleRate>,
    /// How the estimate counts a sampled path (cost mode), on the devices: rendered for real
    /// ([`Walk::Trace`], the default), or its camera ray walked by the thesis's reduced
    /// traversal or the first-leaf walk; see [`super::walk_paths`].
    pub walk: Walk,
    /// Whether a device left idle runs backup copies of what a slower one holds
    /// ([`sched::Runtime::backups`]); CPU devices then render their launches in pieces
    /// ([`super::BoundPaths::new`]). Off, the plan runs as planned.
    pub backups: bool,
}

impl Settings {
    /// 4096 paths per task, as in the middle of the thesis's range.
    pub const DEFAULT_TASK_SIZE: NonZeroUsize = NonZeroUsize::new(4096).expect("4096 > 0");

    /// Tasks per device below which a frame counts as small at the wanted task size.
    pub const MIN_TASKS_PER_DEVICE: usize = 4;

    /// Tasks per device a small frame is cut into instead, while its tasks keep
    /// [`Self::MIN_TASK_RAYS`] paths.
    pub const SMALL_TASKS_PER_DEVICE: usize = 16;

    /// The fewest paths a task is cut down to: a floor, so that a tiny frame is not cut into
    /// tasks of a few paths whose dispatch would cost more than their rendering.
    pub const MIN_TASK_RAYS: usize = 64;

    /// Paths per task for a frame of `rays` paths on `devices` devices: [`Self::task_size`]
    /// when that gives every device [`Self::MIN_TASKS_PER_DEVICE`] tasks, else a size that
    /// gives each [`Self::SMALL_TASKS_PER_DEVICE`].
    ///
    /// A small frame at 4096 paths per task would be a few tasks, which a few devices render
    /// while the others wait (one task on two devices: a balance of at most 50 % by
    /// construction). Four tasks per device still leave the last task a large share of the
    /// devices' time; sixteen give LPT and Hybrid enough small tasks to even out. Large
    /// frames keep the wanted size: they are the experiment.
    pub fn task_size_for(&self, rays: usize, devices: usize) -> usize {
        let wanted = self.task_size.get();
        let devices = devices.max(1);
        if rays >= devices * Self::MIN_TASKS_PER_DEVICE * wanted {
            return wanted;
        }
        let share = rays.div_ceil(devices * Self::SMALL_TASKS_PER_DEVICE);
        wanted.min(share.max(Self::MIN_TASK_RAYS)).max(1)
    }

    /// The share of each task's paths an estimate of `shader`'s frames samples.
    pub fn rate_for(&self, shader: &Shader) -> SampleRate {
        self.sample_rate.unwrap_or_else(|| shader.sample_rate())
    }
}

impl Default for Settings {
    /// Cost-based LPT on tasks of 4096 paths, each shader's share of them sampled and
    /// rendered for real, with backup copies.
    fn default() -> Self {
        Self {
            policy: Policy::StaticLpt,
            mode: Mode::Cost,
            task_size: Self::DEFAULT_TASK_SIZE,
            sample_rate: None,
            walk: Walk::Trace { any: false },
            backups: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_frames_are_cut_so_every_device_gets_tasks() {
        let s = Settings::default(); // 4096 rays per task
        // Large frames keep the asked size.
        assert_eq!(s.task_size_for(262_144, 2), 4096);
        assert_eq!(s.task_size_for(32_768, 2), 4096);
        // 6447 paths on two devices: 16 tasks each, not 2 in all.
        assert_eq!(s.task_size_for(6447, 2), 202);
        assert_eq!(sched::split_ranges(6447, 202).len(), 32);
        // Just short of 4 tasks per device at the wanted size: cut finer.
        assert_eq!(s.task_size_for(32_767, 2), 1024);
        // Never below the smallest worthwhile task, nor zero.
        assert_eq!(s.task_size_for(297, 2), 64);
        assert_eq!(s.task_size_for(1, 2), 64);
        assert_eq!(s.task_size_for(0, 0), 64);
        let tiny = Settings {
            task_size: NonZeroUsize::new(16).unwrap(),
            ..s
        };
        assert_eq!(tiny.task_size_for(100_000, 8), 16);
    }
}
