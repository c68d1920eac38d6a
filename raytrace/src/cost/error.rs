//! Why an estimate, a calibration or a metric could not be computed.

/// Every variant names the input that was rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CostError {
    /// The sampling rate is not a number in `(0, 1]`.
    #[error(transparent)]
    BadRate(#[from] sched::BadSampleRate),
    /// A task holds no rays, so no ray can represent it.
    #[error("task {task} is empty: every task needs at least one ray")]
    EmptyTask {
        /// Index of the task.
        task: usize,
    },
    /// A task reaches past the end of the ray batch.
    #[error("task {task} is rays {start}..{end}, but the batch has {rays} rays")]
    TaskOutOfRange {
        /// Index of the task.
        task: usize,
        /// First ray of the task.
        start: usize,
        /// One past its last ray.
        end: usize,
        /// Rays in the batch.
        rays: usize,
    },
    /// The ray batch's eight columns have different lengths.
    #[error("the ray batch is inconsistent: its columns have different lengths")]
    InconsistentBatch,
    /// The input carries no information for the quantity asked (all zero, or constant).
    #[error("{what} is undefined: {why}")]
    Degenerate {
        /// The metric or fit.
        what: &'static str,
        /// Why it is undefined.
        why: &'static str,
    },
}
