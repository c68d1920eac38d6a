use thiserror::Error;

/// Why a cluster step failed. Every rank that reaches an agreement point returns the same
/// kind of error, so the whole job ends together instead of leaving ranks waiting.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum ClusterError {
    /// `MPI_Init_thread` failed, or MPI was already initialised in this process.
    #[error("MPI could not be initialised (is this process already running MPI?)")]
    Init,
    /// The MPI library cannot call MPI from more than one thread, which rank 0 needs to talk to
    /// several nodes at once.
    #[error("the MPI library offers thread support {got}; cobalt needs at least `serialized`")]
    Threading {
        /// The level the library granted.
        got: String,
    },
    /// A step failed on some ranks, so every rank stops.
    #[error("{step} failed on {}", reasons.iter().map(|(r, why)| format!("rank {r}: {why}")).collect::<Vec<_>>().join("; "))]
    Failed {
        /// What the ranks were doing (e.g. `loading the scene`).
        step: String,
        /// Each rank that failed, in order, with its reason.
        reasons: Vec<(usize, String)>,
    },
    /// A message between ranks could not be read: a protocol bug or a mismatched build.
    #[error("malformed message from rank {rank}: {why}")]
    Wire {
        /// The sender.
        rank: usize,
        /// What was wrong with it.
        why: String,
    },
}
