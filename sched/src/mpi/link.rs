//! What dispatching to one rank cost ([`Link`]): kept by the cluster per rank, added to by
//! each remote dispatch.

/// What the dispatch to one rank cost, seen from rank 0.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Link {
    /// Batches sent (a static plan sends one per round, a queue one per task).
    pub batches: u64,
    /// Seconds from sending each batch to having its outputs, summed.
    pub round_trip_seconds: f64,
    /// Seconds the rank spent running those batches, as it reported them.
    pub remote_seconds: f64,
}

impl Link {
    /// Seconds lost to communication: round trips minus the remote work inside them.
    pub fn overhead_seconds(&self) -> f64 {
        (self.round_trip_seconds - self.remote_seconds).max(0.0)
    }
}
