//! Rendering on the ranks of an MPI job (feature `mpi`): [`ClusterTracer`].
//!
//! Every rank loads the scene, builds the same BVH and runs the same shader, so every rank
//! holds every generation's rays and only task ranges and hits cross the network. Per
//! generation:
//! 1. every rank estimates the work of a slice of the tasks (reduced traversal of sampled
//!    rays) and an all-gather gives every rank all of it;
//! 2. rank 0 plans the tasks over the nodes with the policy of the [`Settings`]
//!    (`StaticLpt` weighted by each node's measured speed sends each node one batch; a queue
//!    sends one task at a time, served by rank 0) and runs its own share;
//! 3. each other rank runs the batches it is sent on its own devices, planned there by the
//!    same settings (a [`ScheduledTracer`]), and sends the hits back;
//! 4. rank 0 broadcasts the generation's hits in ray order, and every rank shades them into
//!    the next generation.
//!
//! Each ray is traced whole by one device, whichever node it lands on, so the image is the
//! same byte for byte as one process's, whatever the ranks, policy and task size.
//!
//! [`Settings`]: crate::scheduled::Settings
//! [`ScheduledTracer`]: crate::scheduled::ScheduledTracer

mod node;
mod paths;
mod stats;
mod tracer;
mod wire;

pub use paths::{PathOutput, RankPaths, render_over_ranks, serve_paths};
pub use stats::{NodeGeneration, NodeRun};
pub use tracer::ClusterTracer;
