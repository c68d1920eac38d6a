use std::collections::VecDeque;

use crate::{Costs, Dispatch};

/// A central queue: an idle device takes the front task, one launch per task. A failed
/// device's unfinished task goes back to the front, where it was.
#[derive(Debug, Clone)]
pub struct QueueDispatch {
    queue: VecDeque<u32>,
}

impl QueueDispatch {
    /// Tasks in their given order (the thesis's regular centralized queue).
    pub fn fifo(costs: &Costs) -> Self {
        QueueDispatch {
            queue: (0..costs.len() as u32).collect(),
        }
    }

    /// Tasks in decreasing cost (the thesis's cost-based centralized queue).
    pub fn sorted(costs: &Costs) -> Self {
        QueueDispatch {
            queue: costs.decreasing_order().into(),
        }
    }

    /// Tasks in any order: every such queue is a list schedule, within (2 − 1/m)·OPT.
    pub fn in_order(order: Vec<u32>) -> Self {
        QueueDispatch {
            queue: order.into(),
        }
    }
}

impl Dispatch for QueueDispatch {
    fn next(&mut self, _device: usize, _now: f64, launch: &mut Vec<u32>) {
        launch.extend(self.queue.pop_front());
    }

    fn fail(&mut self, _device: usize, undone: &[u32]) {
        for &t in undone.iter().rev() {
            self.queue.push_front(t);
        }
    }
}
