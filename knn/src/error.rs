/// Why a kNN batch could not be set up. Each names the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum KnnError {
    /// `k` must be at least 1 and at most the number of points.
    #[error("k = {k} must be between 1 and the number of points ({points})")]
    BadK {
        /// The `k` asked for.
        k: usize,
        /// Points in the cloud.
        points: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("point {index} has a non-finite coordinate {point:?}")]
    NonFinite {
        /// Index of the point in the cloud (or in the queries).
        index: usize,
        /// The point.
        point: [f32; 3],
    },
    /// The sampling rate is not in (0, 1].
    #[error(transparent)]
    BadSampleRate(#[from] sched::BadSampleRate),
    /// kiddo could not build its tree.
    #[error("building the k-d tree: {0}")]
    Tree(String),
}
