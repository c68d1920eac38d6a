//! What each generation did across the nodes, for reports.

use sched::DeviceFailure;

use crate::RayKind;

/// How one generation went across the nodes (kept on rank 0; the other ranks only count
/// their communication).
#[derive(Clone, Debug)]
pub struct NodeGeneration {
    /// The ray kind.
    pub kind: RayKind,
    /// Rays traced.
    pub rays: usize,
    /// Tasks planned over the nodes.
    pub tasks: usize,
    /// Wall time of the estimate: this rank's slice and the all-gather.
    pub estimate_seconds: f64,
    /// Wall time from the plan to the last node's outputs.
    pub run_seconds: f64,
    /// Wall time of broadcasting the hits.
    pub broadcast_seconds: f64,
    /// Makespan of the run over the nodes.
    pub makespan: f64,
    /// Balance efficiency over the nodes (thesis definition).
    pub balance_efficiency: f64,
    /// Per rank that took part: the rank, the speed it was planned at, its busy seconds and
    /// launches (batches sent to it).
    pub nodes: Vec<NodeRun>,
    /// Nodes that failed; their tasks were re-run on the others.
    pub failures: Vec<DeviceFailure>,
    /// Every node failed and rank 0 traced the generation itself.
    pub host_fallback: bool,
}

/// One rank in one generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeRun {
    /// Its rank.
    pub rank: usize,
    /// The relative speed the plan used.
    pub speed: f64,
    /// Seconds it was busy (for another rank: round trips included).
    pub busy: f64,
    /// Batches it ran.
    pub launches: u64,
    /// Tasks it ran.
    pub tasks: usize,
}
