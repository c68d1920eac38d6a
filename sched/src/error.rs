use std::fmt;

/// Why a workload could not be scheduled or run.
///
/// Every variant names the input that was rejected, so a caller can report it as is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SchedError {
    /// A task cost is NaN, infinite or negative.
    #[error("cost of task {task} is {value}: costs must be finite and non-negative")]
    BadCost {
        /// Index of the task in the workload.
        task: usize,
        /// The rejected value.
        value: f64,
    },
    /// What moving a task from its home costs is NaN, infinite or negative.
    #[error("moving task {task} from its home costs {value}: must be finite and non-negative")]
    BadMoveCost {
        /// Index of the task in the workload.
        task: usize,
        /// The rejected value.
        value: f64,
    },
    /// A task's home is not one of the devices.
    #[error("task {task} has its home on device {device}, but there are {devices} devices")]
    BadHome {
        /// Index of the task in the workload.
        task: usize,
        /// The home it was given.
        device: u32,
        /// Devices of the run.
        devices: usize,
    },
    /// The costs are each finite, but their sum is not.
    #[error(
        "cost of task {task} is {value:e}: the sum of the costs up to it overflows (exceeds {max:e})",
        max = f64::MAX
    )]
    CostOverflow {
        /// Index of the task whose cost made the sum overflow.
        task: usize,
        /// Its cost.
        value: f64,
    },
    /// A device speed is NaN, infinite, zero or negative.
    #[error("speed of device {device} is {value}: speeds must be finite and positive")]
    BadSpeed {
        /// Index of the device.
        device: usize,
        /// The rejected value.
        value: f64,
    },
    /// More tasks than a `u32` index can name.
    #[error("{tasks} tasks: at most {} are supported", u32::MAX)]
    TooManyTasks {
        /// How many were given.
        tasks: usize,
    },
    /// A dispatch latency is NaN, infinite or negative.
    #[error("dispatch latency {value} is invalid: it must be finite and non-negative")]
    BadLatency {
        /// The rejected value.
        value: f64,
    },
    /// There is no device to run on.
    #[error("no devices: at least one device is needed")]
    NoDevices,
    /// Two inputs that must describe the same tasks or devices have different lengths.
    #[error("{what}: expected {expected}, got {got}")]
    LengthMismatch {
        /// What was being compared.
        what: &'static str,
        /// The length that was required.
        expected: usize,
        /// The length that was given.
        got: usize,
    },
    /// A fault names a device that does not exist.
    #[error("fault on device {device}, but there are only {devices} devices")]
    BadFault {
        /// The device named by the fault.
        device: usize,
        /// How many devices there are.
        devices: usize,
    },
    /// Every device failed before all tasks were done.
    #[error("all {devices} devices failed; {unfinished} of {tasks} tasks were not run: {}", Failures(.failures))]
    AllDevicesFailed {
        /// How many devices there were.
        devices: usize,
        /// How many tasks there were.
        tasks: usize,
        /// How many tasks got no output.
        unfinished: usize,
        /// One line per failed device.
        failures: Vec<DeviceFailure>,
    },
    /// The operating system refused to start the threads the devices need.
    #[error("starting {threads} device threads: {why}; use fewer devices")]
    Threads {
        /// Threads asked for.
        threads: usize,
        /// The system's reason.
        why: String,
    },
    /// An unknown policy name was given.
    #[error(
        "unknown policy {0:?}: expected static-equal, static-lpt, queue-fifo, queue-sorted or hybrid"
    )]
    UnknownPolicy(String),
}

/// A device that stopped during a run, and why.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct DeviceFailure {
    /// Index of the device.
    pub device: usize,
    /// Its name, as reported by its executor.
    pub name: String,
    /// The error it returned, or the panic message.
    pub reason: String,
    /// How many tasks it left undone; they were re-run elsewhere if any device remained.
    pub orphaned: usize,
}

impl fmt::Display for DeviceFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "device {} ({}) failed: {} ({} tasks orphaned)",
            self.device, self.name, self.reason, self.orphaned
        )
    }
}

struct Failures<'a>(&'a [DeviceFailure]);

impl fmt::Display for Failures<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, failure) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(f, "{failure}")?;
        }
        Ok(())
    }
}
