//! Why an estimate could not be judged.

use crate::cost::CostError;

/// Why [`super::measure`] stopped.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// An estimate, a full count, a timing or a metric could not be made.
    #[error(transparent)]
    Cost(#[from] CostError),
    /// The GPU could not be opened, or its estimate or trace failed.
    #[cfg(feature = "gpu")]
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// The GPU was asked for, and this build has none (feature `gpu`).
    #[error("built without the `gpu` feature")]
    NoGpu,
}
