//! Ranks of an MPI job as the nodes of one run (feature `mpi`; Open MPI through rsmpi).
//!
//! Every rank holds the same data (each loads the scene and builds the same rays), so only
//! tasks and outputs cross the network. A round goes:
//! 1. every rank estimates a slice of the tasks and [`Cluster::all_gather_f64`] gives every
//!    rank all the estimates;
//! 2. rank 0 runs a [`crate::Runtime`] whose devices are its own node and a [`RemoteNode`]
//!    per other rank, with any [`crate::Policy`]: a static plan sends each node one batch,
//!    a queue sends one task at a time and so pays a round trip per task;
//! 3. the other ranks [`Cluster::serve`] those batches on their own devices (planned there
//!    by a local policy) until rank 0 calls [`Cluster::finish`];
//! 4. rank 0 has every output in task order and [`Cluster::broadcast`]s what the next round
//!    needs.
//!
//! Each fallible step ends with [`Cluster::agree`], so a failure on one rank (a scene that
//! does not load) ends every rank with an error that names it, instead of a hang.

mod cluster;
mod error;
mod link;
mod remote;
mod wire;

pub use cluster::Cluster;
pub use error::ClusterError;
pub use link::Link;
pub use remote::RemoteNode;
pub use wire::{Wire, WireError, take};
