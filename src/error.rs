use std::path::PathBuf;

/// Why a command could not run. Each names the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// A file could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A line of an input file is not what it should be.
    #[error("{path}:{line}: {message}")]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A record of a binary input file is malformed.
    #[error("{path}: {what} {index}: {message}")]
    Record {
        /// The file.
        path: PathBuf,
        /// What a record is (a ray…).
        what: &'static str,
        /// 0-based record index.
        index: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A scene could not be loaded or its BVH built.
    #[error(transparent)]
    Scene(#[from] raytrace::Error),
    /// A command-line value is malformed.
    #[error("--{flag} {value:?}: {message}")]
    Arg {
        /// The flag, without dashes.
        flag: &'static str,
        /// The value given.
        value: String,
        /// What is wrong with it.
        message: String,
    },
    /// The calibration file named by `--calibration` could not be read.
    #[error("--calibration {0}")]
    Calibration(#[from] raytrace::calibration::CalibrationError),
    /// The scheduler rejected the input.
    #[error(transparent)]
    Sched(#[from] sched::SchedError),
    /// A cost estimate or one of its metrics could not be computed.
    #[error(transparent)]
    Cost(#[from] raytrace::cost::CostError),
    /// A step of a run over MPI ranks failed on some rank (feature `mpi`).
    #[cfg(feature = "mpi")]
    #[error(transparent)]
    Cluster(#[from] sched::mpi::ClusterError),
    /// Every device the user asked for failed, and no fallback to the host was allowed.
    #[error(
        "every device of --devices {devices} failed, so nothing was written: {failures}; \
         pass --host-fallback to finish on the host's threads instead"
    )]
    DevicesFailed {
        /// `--devices` as given.
        devices: String,
        /// One entry per failure: the device and why.
        failures: String,
    },
    /// Output could not be written.
    #[error("writing output: {0}")]
    Write(String),
    /// An output path cannot be written safely, or writing it failed.
    #[error("{}{}: {message}", flag_prefix(flag), path.display())]
    Output {
        /// The flag, without dashes; empty where the path is not a flag's value.
        flag: &'static str,
        /// The path as given.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}

impl CliError {
    /// The process's exit status for this error: 3 when the devices failed (the input was
    /// fine; the hardware or its driver was not), 2 for everything else.
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::DevicesFailed { .. } => 3,
            _ => 2,
        }
    }

    /// The error for a run whose every device failed, listing each failure.
    pub fn devices_failed(devices: &str, failures: &[sched::DeviceFailure]) -> Self {
        let failures = if failures.is_empty() {
            String::from("no device was left from earlier failures")
        } else {
            failures
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("; ")
        };
        Self::DevicesFailed {
            devices: devices.to_string(),
            failures,
        }
    }

    /// A GPU's error, naming the flag that asked for the GPU (`--device gpu`).
    pub fn gpu(message: impl std::fmt::Display) -> Self {
        Self::Arg {
            flag: "device",
            value: "gpu".into(),
            message: message.to_string(),
        }
    }

    /// The error of a run on `devices` (the `--devices` text) that gave no image.
    pub fn run(devices: &str, e: raytrace::run::RunError) -> Self {
        use raytrace::run::RunError;
        match e {
            RunError::DevicesFailed(failures) => Self::devices_failed(devices, &failures),
            RunError::Sched(e) => e.into(),
            RunError::Devices(e) => e.into(),
        }
    }
}

/// Why `--device gpu` cannot be: this build has no GPU.
pub const NO_GPU: &str = "this cobalt was built without the `gpu` feature";

impl From<raytrace::bench::BenchError> for CliError {
    fn from(e: raytrace::bench::BenchError) -> Self {
        use raytrace::bench::BenchError;
        match e {
            BenchError::DevicesFailed { devices, failures } => {
                Self::devices_failed(&devices, &failures)
            }
            BenchError::Scene(e) => e.into(),
            BenchError::Sched(e) => e.into(),
            // The message the trade's estimates have always failed with.
            e @ BenchError::Estimate(_) => Self::Write(e.to_string()),
            BenchError::Unmeasured(class) => Self::Arg {
                flag: "project",
                value: class.to_string(),
                message: "no measured device of this class to project".into(),
            },
            #[cfg(feature = "mpi")]
            BenchError::Cluster(e) => e.into(),
        }
    }
}

impl From<raytrace::estimate::EstimateError> for CliError {
    fn from(e: raytrace::estimate::EstimateError) -> Self {
        use raytrace::estimate::EstimateError;
        match e {
            EstimateError::Cost(e) => e.into(),
            #[cfg(feature = "gpu")]
            EstimateError::Gpu(e) => Self::gpu(e),
            EstimateError::NoGpu => Self::gpu(NO_GPU),
        }
    }
}

fn flag_prefix(flag: &str) -> String {
    if flag.is_empty() {
        String::new()
    } else {
        format!("--{flag} ")
    }
}
