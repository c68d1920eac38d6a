//! How a [`super::ScheduledTracer`] cuts, costs and plans each generation.

use std::fmt;
use std::num::NonZeroUsize;
use std::str::FromStr;

use sched::Policy;

use crate::cost::SampleRate;

/// Where a generation's task costs come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Every task costs the same (`sched::Costs::uniform`): the thesis's regular mode, no
    /// estimation overhead.
    Regular,
    /// The reduced traversal of a sample of each task's rays, weighed by the calibrated
    /// `C = kB·B + kT·T` (thesis, chapter 3).
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

/// The scheduling settings of every generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// How tasks are assigned to devices.
    pub policy: Policy,
    /// Regular or cost-based.
    pub mode: Mode,
    /// Rays per task (the thesis uses 16384, 4096 and 512).
    pub task_size: NonZeroUsize,
    /// Fraction of each task's rays the estimate traces (cost mode).
    pub sample_rate: SampleRate,
}

impl Settings {
    /// 4096 rays per task, as in the middle of the thesis's range.
    pub const DEFAULT_TASK_SIZE: NonZeroUsize = NonZeroUsize::new(4096).expect("4096 > 0");
}

impl Default for Settings {
    /// Cost-based LPT on tasks of 4096 rays sampled at 12.5 %: the thesis's method.
    fn default() -> Self {
        Self {
            policy: Policy::StaticLpt,
            mode: Mode::Cost,
            task_size: Self::DEFAULT_TASK_SIZE,
            sample_rate: SampleRate::THESIS,
        }
    }
}
