//! Why a bench could not finish: the error of every step of [`super`], each naming what
//! failed.

use sched::{DeviceFailure, SchedError};

use crate::estimate::EstimateError;

/// Why the bench stopped.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// Every device of a cell's renderer failed (none is left to finish the frame).
    #[error("every device of {devices} failed")]
    DevicesFailed {
        /// The devices, as the matrix lists them (`--devices`).
        devices: String,
        /// One entry per failure, in order; none when every device had failed before.
        failures: Vec<DeviceFailure>,
    },
    /// A scene, a BVH or the devices could not be made.
    #[error(transparent)]
    Scene(#[from] crate::Error),
    /// The scheduler rejected a plan or a simulation.
    #[error(transparent)]
    Sched(#[from] SchedError),
    /// An estimate of the sampling trade could not be made or judged.
    #[error("estimate: {0}")]
    Estimate(#[from] EstimateError),
    /// A projected device class (`cpu` or `gpu`) that no device of the run was.
    #[error("{0}: no measured device of this class to project")]
    Unmeasured(&'static str),
    /// A step of the bench over MPI ranks failed on some rank.
    #[cfg(feature = "mpi")]
    #[error(transparent)]
    Cluster(#[from] sched::mpi::ClusterError),
}
