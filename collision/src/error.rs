/// Why a collision batch could not be set up. Each names the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum CollisionError {
    /// The sampling rate is not in (0, 1].
    #[error(transparent)]
    BadSampleRate(#[from] sched::BadSampleRate),
    /// The static mesh could not be built (no triangles, bad indices…).
    #[error("building the triangle mesh: {0}")]
    Mesh(String),
    /// The scene file could not be read.
    #[error("loading the scene: {0}")]
    Scene(String),
}
