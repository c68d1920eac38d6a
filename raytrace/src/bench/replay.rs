//! Every measured run replayed in `sched`'s simulator with its own task times, device speeds
//! and launch delays ([`sched::MeasuredRun`]), and its lower bounds: what the simulator is
//! worth is how close its replay of a run comes to the run.

use sched::bounds::{fractional_bound, lower_bound};
use sched::{Costs, MeasuredRun, MeasuredTask, Speeds};

use crate::paths::FrameStats;

/// What a frame's replay and bounds came to, in seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct Replayed {
    /// The measured makespan.
    pub makespan: f64,
    /// The replay's makespan.
    pub simulated_makespan: f64,
    /// No plan beats it: the largest tasks on the fastest devices, all work on all speed.
    pub lower_bound: f64,
    /// All work over all speed, as if tasks could be split.
    pub fractional_bound: f64,
}

impl std::ops::Add for Replayed {
    type Output = Self;

    fn add(self, o: Self) -> Self {
        Self {
            makespan: self.makespan + o.makespan,
            simulated_makespan: self.simulated_makespan + o.simulated_makespan,
            lower_bound: self.lower_bound + o.lower_bound,
            fractional_bound: self.fractional_bound + o.fractional_bound,
        }
    }
}

/// Replays one frame with its own task times, the speeds it was planned with and the launch
/// overheads its devices declared. `None` when it cannot be replayed: a task undelivered or a
/// device unknown (after a failure), or nothing measured.
pub fn replay(f: &FrameStats) -> Option<Replayed> {
    let position = |index: usize| f.devices.iter().position(|d| d.index == index);
    let measured: Option<Vec<MeasuredTask>> = f
        .task_stats
        .iter()
        .map(|t| {
            Some(MeasuredTask {
                device: position(t.device)?,
                start: t.start,
                seconds: t.seconds,
            })
        })
        .collect();
    let run = MeasuredRun {
        policy: f.policy,
        planned: Costs::new(f.task_stats.iter().map(|t| t.cost).collect()).ok()?,
        speeds: Speeds::new(f.devices.iter().map(|d| d.speed).collect()).ok()?,
        overheads: f.devices.iter().map(|d| d.launch_overhead).collect(),
        tasks: measured?,
    };
    let simulated = run.replay().ok()?.metrics.makespan;
    // The bounds in seconds: each task's work in cost units at its device's measured rate,
    // on devices of those rates.
    let rates = run.rates();
    let work = Costs::new(
        run.tasks
            .iter()
            .map(|t| t.seconds * rates[t.device])
            .collect(),
    )
    .ok()?;
    let speeds = Speeds::new(rates).ok()?;
    Some(Replayed {
        makespan: f.makespan,
        simulated_makespan: simulated,
        lower_bound: lower_bound(&work, &speeds),
        fractional_bound: fractional_bound(&work, &speeds),
    })
}
