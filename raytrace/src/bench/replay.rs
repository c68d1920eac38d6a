//! Every measured run replayed in `sched`'s simulator with its own task times, device speeds
//! and launch delays ([`sched::MeasuredRun`]), and its lower bounds: what the simulator is
//! worth is how close its replay of a run comes to the run.

use sched::bounds::{fractional_bound, lower_bound};
use sched::{Costs, MeasuredRun, MeasuredTask, Policy, Speeds};

use crate::paths::TaskStats;

/// One device of a frame: its index among the renderer's devices, the speed it
/// was planned with and the launch overhead it declared.
pub struct RunDevice {
    pub index: usize,
    pub speed: f64,
    pub launch_overhead: Option<f64>,
}

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

impl std::ops::AddAssign for Replayed {
    fn add_assign(&mut self, o: Self) {
        self.makespan += o.makespan;
        self.simulated_makespan += o.simulated_makespan;
        self.lower_bound += o.lower_bound;
        self.fractional_bound += o.fractional_bound;
    }
}

/// Replays one frame (`makespan` as measured). `None` when it cannot be
/// replayed: a task undelivered or a device unknown (after a failure), or nothing measured.
pub fn replay(
    policy: Policy,
    makespan: f64,
    tasks: &[TaskStats],
    devices: &[RunDevice],
) -> Option<Replayed> {
    let position = |index: usize| devices.iter().position(|d| d.index == index);
    let measured: Option<Vec<MeasuredTask>> = tasks
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
        policy,
        planned: Costs::new(tasks.iter().map(|t| t.cost).collect()).ok()?,
        speeds: Speeds::new(devices.iter().map(|d| d.speed).collect()).ok()?,
        overheads: devices.iter().map(|d| d.launch_overhead).collect(),
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
        makespan,
        simulated_makespan: simulated,
        lower_bound: lower_bound(&work, &speeds),
        fractional_bound: fractional_bound(&work, &speeds),
    })
}
