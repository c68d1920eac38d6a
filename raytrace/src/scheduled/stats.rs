//! What one scheduled generation did: the record a report is built from.

use sched::{DeviceFailure, Policy};

use super::Mode;
use crate::RayKind;
use crate::cost::Fit;

/// One scheduled generation.
#[derive(Clone, Debug)]
pub struct GenerationStats {
    /// What the rays were for.
    pub kind: RayKind,
    /// Rays traced.
    pub rays: usize,
    /// Tasks the rays were cut into.
    pub tasks: usize,
    /// Rays in the longest task: the settings' task size, or less for a small generation
    /// (see `Settings::task_size_for`).
    pub task_size: usize,
    /// The policy that planned it.
    pub policy: Policy,
    /// Regular (uniform costs) or cost-based.
    pub mode: Mode,
    /// Wall time of the cost estimate (0 in regular mode): the estimation overhead.
    pub estimate_seconds: f64,
    /// Time the policy took to plan.
    pub plan_seconds: f64,
    /// Wall time of the run on the devices (threads started, tasks traced, outputs gathered).
    pub run_seconds: f64,
    /// From the first launch to the last output.
    pub makespan: f64,
    /// Σ busy / (makespan × devices), over the devices that took part.
    pub balance_efficiency: f64,
    /// The devices that took part, in the order of the tracer's devices.
    pub devices: Vec<DeviceStats>,
    /// Task runs lost to failures and run again.
    pub reruns: u64,
    /// Devices that failed during this generation; they take no part in later ones.
    pub failures: Vec<DeviceFailure>,
    /// Every task: its estimated cost, measured time and device.
    pub task_stats: Vec<TaskStats>,
    /// `kB`, `kT` fitted to this generation's tasks, per device (cost mode only).
    pub calibrations: Vec<DeviceFit>,
    /// Tasks whose time was too far off their prediction to learn speeds or `kB`, `kT` from
    /// (see `sched::outliers`).
    pub outliers: usize,
    /// Why the estimate failed and uniform costs were used instead, if it did.
    pub estimate_error: Option<String>,
    /// Where the estimate ran (cost mode): a device's name, or `host` (with why not on a
    /// GPU, where one was asked for); `None` when it was made elsewhere or not at all.
    pub estimated_on: Option<String>,
    /// True when no device was left and the caller's thread traced the generation.
    pub host_fallback: bool,
    /// What crossed between the host and the devices, estimate included: the generation's
    /// rays go up and their hits come back.
    pub traffic: crate::Traffic,
}

impl GenerationStats {
    /// Launches over all devices.
    pub fn launches(&self) -> u64 {
        self.devices.iter().map(|d| d.launches).sum()
    }
}

/// One device's part in a generation.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceStats {
    /// Index in the tracer's device list.
    pub index: usize,
    /// Its name.
    pub name: String,
    /// The relative speed the plan used.
    pub speed: f64,
    /// The relative speed measured on this generation (work done over busy time, in cost
    /// units, normalised over the devices); `None` when it could not be measured.
    pub measured_speed: Option<f64>,
    /// Launches (1 for a static plan, one per task for a queue).
    pub launches: u64,
    /// Tasks it delivered.
    pub tasks: usize,
    /// Time spent running tasks.
    pub busy: f64,
    /// Kernel time the device measured itself during the generation (a GPU's timestamp
    /// queries, summed over its launches); `None` where it cannot.
    pub device_seconds: Option<f64>,
    /// The launch overhead it declared to the policy, if any.
    pub launch_overhead: Option<f64>,
}

/// One task of a generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TaskStats {
    /// Its cost as planned (1 in regular mode).
    pub cost: f64,
    /// When its span started, in seconds from the run's start (the first task of a launch
    /// starts when the launch does).
    pub start: f64,
    /// Measured time, from the timeline.
    pub seconds: f64,
    /// The device (index in the tracer's list) that delivered it.
    pub device: usize,
    /// Kernel time the device measured itself for this task (a GPU's timestamp queries),
    /// where the task had a launch of its own; `None` otherwise.
    pub device_seconds: Option<f64>,
}

/// A calibration of `C = kB·B + kT·T` on one device for one kind of ray.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceFit {
    /// The device's name.
    pub device: String,
    /// The kind of ray.
    pub kind: RayKind,
    /// The least-squares fit of its task times.
    pub fit: Fit,
}
