use std::collections::BinaryHeap;

use crate::Costs;

/// The run-time half of a policy: hands each idle device its next launch.
///
/// Both the threaded [`Runtime`](crate::Runtime) and the [`Simulation`](crate::Simulation)
/// drive the same `Dispatch`, so a simulated schedule follows exactly the decisions the real
/// one would make given the same completion order. Implement it to add a policy.
pub trait Dispatch: Send {
    /// Fills `launch` (given empty) with the tasks `device` should run next, as one launch.
    /// Leaving it empty means "nothing for you now"; the caller waits until a failure
    /// releases work or every task is done. `now` is the time of the call in seconds since
    /// the run started, on the runtime's wall clock or the simulation's clock; a device asks
    /// only once its previous launch is done, so a policy can time launches with it.
    fn next(&mut self, device: usize, now: f64, launch: &mut Vec<u32>);

    /// `device` has failed and will never ask again; `undone` are tasks it was given but did
    /// not finish. They, and anything else the device still held, must be handed out again.
    fn fail(&mut self, device: usize, undone: &[u32]);
}

/// Tasks released by failed devices, handed out largest first, one per launch: a cost-sorted
/// list schedule of whatever a failure leaves behind.
#[derive(Debug, Default)]
pub(crate) struct Orphans {
    heap: BinaryHeap<(CostKey, std::cmp::Reverse<u32>)>,
}

impl Orphans {
    pub(crate) fn extend(&mut self, costs: &Costs, tasks: impl IntoIterator<Item = u32>) {
        self.heap.extend(
            tasks
                .into_iter()
                .map(|t| (CostKey(costs[t as usize]), std::cmp::Reverse(t))),
        );
    }

    pub(crate) fn pop(&mut self) -> Option<u32> {
        self.heap.pop().map(|(_, std::cmp::Reverse(t))| t)
    }
}

/// A validated (finite) cost with a total order.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CostKey(f64);

impl Eq for CostKey {}

impl PartialOrd for CostKey {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for CostKey {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}
