//! The cost counters of a walk ([`Counts`]): what every walk counts, single rays and packets
//! alike, and what the cost model and the GPU's per-task sums read.

use bytemuck::{Pod, Zeroable};

/// Cost counters of one ray: nodes entered `B` and triangles tested (or, in the reduced
/// traversal, triangles in reached leaves) `T`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Counts {
    /// `B`: nodes entered.
    pub nodes: u32,
    /// `T`: triangle tests.
    pub tris: u32,
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, o: Self) {
        self.nodes += o.nodes;
        self.tris += o.tris;
    }
}
