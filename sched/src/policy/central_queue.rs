use std::collections::VecDeque;

use crate::{Costs, Dispatch, Homes};

/// A central queue: an idle device takes the front task, one launch per task. A failed
/// device's unfinished task goes back to the front, where it was.
///
/// With homes ([`QueueDispatch::preferring_home`]) an idle device takes the first task, in
/// the queue's order, whose home it is, and only when none is left the front task: still a
/// list schedule (no device idles while a task waits), whose tasks stay where their data is
/// as long as their home has any left.
#[derive(Debug, Clone)]
pub struct QueueDispatch {
    queue: VecDeque<u32>,
    /// Per device, the tasks at home there in queue order, and which tasks were handed out
    /// (from either list); empty without homes.
    at_home: Vec<VecDeque<u32>>,
    taken: Vec<bool>,
}

impl QueueDispatch {
    /// Tasks in their given order (the thesis's regular centralized queue).
    pub fn fifo(costs: &Costs) -> Self {
        Self::in_order((0..costs.len() as u32).collect())
    }

    /// Tasks in decreasing cost (the thesis's cost-based centralized queue).
    pub fn sorted(costs: &Costs) -> Self {
        Self::in_order(costs.decreasing_order())
    }

    /// Tasks in any order: every such queue is a list schedule, within (2 − 1/m)·OPT.
    pub fn in_order(order: Vec<u32>) -> Self {
        QueueDispatch {
            taken: Vec::new(),
            queue: order.into(),
            at_home: Vec::new(),
        }
    }

    /// The same queue handing each of `devices` the tasks at home there first (see the
    /// type's docs). `homes` must name a home for every task of the queue.
    pub fn preferring_home(self, homes: &Homes, devices: usize) -> Self {
        let mut at_home = vec![VecDeque::new(); devices];
        for &t in &self.queue {
            if let Some(list) = at_home.get_mut(homes.home(t as usize) as usize) {
                list.push_back(t);
            }
        }
        QueueDispatch {
            taken: vec![false; homes.len()],
            at_home,
            ..self
        }
    }

    /// The next task not yet handed out from `list`.
    fn pop(list: &mut VecDeque<u32>, taken: &mut [bool]) -> Option<u32> {
        while let Some(t) = list.pop_front() {
            match taken.get_mut(t as usize) {
                Some(seen) if *seen => continue,
                Some(seen) => {
                    *seen = true;
                    return Some(t);
                }
                None => return Some(t),
            }
        }
        None
    }
}

impl Dispatch for QueueDispatch {
    fn next(&mut self, device: usize, _now: f64, launch: &mut Vec<u32>) {
        let home = self
            .at_home
            .get_mut(device)
            .and_then(|list| Self::pop(list, &mut self.taken));
        launch.extend(home.or_else(|| Self::pop(&mut self.queue, &mut self.taken)));
    }

    fn fail(&mut self, device: usize, undone: &[u32]) {
        for &t in undone.iter().rev() {
            self.queue.push_front(t);
            if let Some(seen) = self.taken.get_mut(t as usize) {
                *seen = false;
            }
        }
        // The failed device never asks again: its own tasks go to whoever reaches them in
        // the shared queue, where each still is unless it was handed out.
        if let Some(list) = self.at_home.get_mut(device) {
            list.clear();
        }
    }
}
