//! What a frame did, for reports: the plan, each device's share, and what crossed the links.

use sched::{DeviceFailure, Policy};

use super::Mode;
use super::Traffic;
use crate::cost::CostModel;

/// One task of a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskStats {
    /// Its cost as planned (1 in regular mode).
    pub cost: f64,
    /// When its span started, in seconds from the run's start (the first task of a launch
    /// starts when the launch does).
    pub start: f64,
    /// Measured time, from the timeline.
    pub seconds: f64,
    /// The device (index among the renderer's devices) that delivered it.
    pub device: usize,
    /// Kernel time the device measured itself for this task (a GPU's timestamp queries),
    /// where the task had a launch of its own; `None` otherwise.
    pub device_seconds: Option<f64>,
}

/// One device's part of a frame, as a run's report lists it (the JSON field names are what
/// users read).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PathDeviceStats {
    /// Index among the renderer's devices.
    #[serde(skip)]
    pub index: usize,
    /// Its name.
    pub name: String,
    /// The relative speed the frame was planned with.
    pub speed: f64,
    /// Tasks it delivered.
    pub tasks: usize,
    /// Paths of the tasks it delivered: over its launches, what it takes at once.
    pub paths: usize,
    /// Launches it ran.
    pub launches: u64,
    /// Seconds busy (wall time of its launches).
    #[serde(rename = "busy_seconds")]
    pub busy: f64,
    /// CPU time its host thread (the scheduler's, which drives it) spent in its launches,
    /// where the platform can tell: for a GPU, the submission, read-back and gather, the
    /// thread waiting on the GPU for the rest; for a CPU device, whose own worker threads
    /// trace, the hand-off alone. What a GPU's host side takes of a core the CPU devices also
    /// want.
    #[serde(rename = "host_cpu_seconds", skip_serializing_if = "Option::is_none")]
    pub host_cpu: Option<f64>,
    /// Rays it traced.
    pub rays: usize,
    /// What crossed between the host and it, the paths' values excepted.
    #[serde(flatten)]
    pub traffic: Traffic,
    /// Bytes of paths' values it sent to the host.
    pub film_bytes: u64,
    /// Kernel seconds it measured itself, where it can.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_seconds: Option<f64>,
    /// The launch overhead it declared to the policy, if any.
    #[serde(skip)]
    pub launch_overhead: Option<f64>,
}

/// One rendered frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameStats {
    /// Paths (pixels) of the frame.
    pub paths: usize,
    /// Tasks the paths were cut into.
    pub tasks: usize,
    /// Paths of the largest task.
    pub task_size: usize,
    /// The policy.
    pub policy: Policy,
    /// Regular (equal costs) or cost-based.
    pub mode: Mode,
    /// Rays traced over all generations and devices.
    pub rays: usize,
    /// Whether the tasks were estimated: in cost mode, unless one device rendered the frame
    /// (any plan then takes as long, so the tasks cost alike).
    pub estimated: bool,
    /// Whether the estimate was the previous one's, taken at no cost: the frame had the same
    /// scene, tree, options, tasks and sampling as the last frame estimated.
    pub estimate_reused: bool,
    /// Seconds spent estimating the tasks' costs (0 when not estimated).
    pub estimate_seconds: f64,
    /// Seconds the policy spent planning.
    pub plan_seconds: f64,
    /// Wall seconds of the run on the devices.
    pub run_seconds: f64,
    /// Wall seconds of the whole frame: estimate, plan, run and the film.
    pub seconds: f64,
    /// Wall seconds from the run's start to the last task's delivery.
    pub makespan: f64,
    /// The makespan predicted before the run, from the estimates and each device class's
    /// paths per second measured on earlier frames or recalled; `None` while a class has none.
    pub predicted_makespan: Option<f64>,
    /// Busy time summed over devices / (makespan × devices).
    pub balance_efficiency: f64,
    /// Each task's planned cost, measured time and device (an index among the renderer's
    /// devices), in task order.
    pub task_stats: Vec<TaskStats>,
    /// Each device's part.
    pub devices: Vec<PathDeviceStats>,
    /// Task runs lost to failed devices and run again elsewhere.
    pub reruns: u64,
    /// Whether idle devices could run backup copies ([`super::Settings::backups`]).
    pub backups: bool,
    /// Backup copies launched.
    pub copies: u64,
    /// Seconds devices spent on task runs whose values were dropped, another copy's having
    /// come first.
    pub wasted_seconds: f64,
    /// Devices that failed during the frame.
    pub failures: Vec<DeviceFailure>,
    /// Devices left idle because the fastest class alone rendered frames faster (see
    /// [`crate::paths::PathRenderer::render`]).
    pub left_idle: Vec<String>,
    /// The model that turned the estimated work into the planned costs.
    pub cost_model: CostModel,
    /// Launches whose time was far off their planned cost (timing spikes), left out of what
    /// the frame taught the next plan.
    pub spikes: usize,
}

impl FrameStats {
    /// Rendering efficiency: rays over the frame's wall time, in millions per second.
    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.seconds.max(1e-12) / 1e6
    }

    /// What crossed between the host and every device, the paths' values excepted.
    pub fn traffic(&self) -> Traffic {
        let mut t = Traffic::default();
        for d in &self.devices {
            t += d.traffic;
        }
        t
    }

    /// Bytes of paths' values sent to the host over all devices.
    pub fn film_bytes(&self) -> u64 {
        self.devices.iter().map(|d| d.film_bytes).sum()
    }

    /// Launches over all devices.
    pub fn launches(&self) -> u64 {
        self.devices.iter().map(|d| d.launches).sum()
    }
}
