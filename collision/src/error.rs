/// Why a collision batch could not be set up. Each names the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum CollisionError {
    /// The sampling rate is not in (0, 1].
    #[error(transparent)]
    BadSampleRate(#[from] sched::BadSampleRate),
    /// A vertex of the static mesh is NaN or infinite.
    #[error("mesh vertex {index} has a non-finite coordinate {vertex:?}")]
    NonFinite {
        /// Index of the vertex.
        index: usize,
        /// The vertex.
        vertex: [f32; 3],
    },
    /// The static mesh could not be built (no triangles, bad indices…).
    #[error("building the triangle mesh: {0}")]
    Mesh(String),
}
