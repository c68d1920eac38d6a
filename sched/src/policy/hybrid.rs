use std::collections::VecDeque;

use super::plan_lpt;
use crate::dispatch::Orphans;
use crate::{Costs, Dispatch, Load, Speeds};

/// LPT start, then stealing of the tail.
///
/// Each device holds its LPT list, largest first, and launches the front *half* of what is
/// left each time it goes idle, so it pays O(log n) launches instead of one per task while
/// the small tasks at the back stay available. A device with nothing left looks for work in
/// this order:
/// finish what was planned for it, then take tasks orphaned by a failed device, then steal
/// the smallest unlaunched tasks of the device with the most unlaunched work, as many as it
/// can finish no later than that device would finish the rest.
///
/// That last rule is why stealing never makes the makespan worse than the LPT plan when
/// estimates are exact: the thief ends before the victim, and the victim ends earlier than
/// planned. When estimates are wrong, the tail moves to whoever is idle.
#[derive(Debug)]
pub struct HybridDispatch<'a> {
    queues: Vec<VecDeque<u32>>,
    /// Unlaunched work of each device, in time (cost / speed).
    pending: Vec<Load>,
    speeds: Vec<f64>,
    orphans: Orphans,
    costs: &'a Costs,
}

impl<'a> HybridDispatch<'a> {
    /// Plans `costs` by LPT on `speeds`.
    pub fn new(costs: &'a Costs, speeds: &Speeds) -> Self {
        let plan = plan_lpt(costs, speeds);
        let queues: Vec<VecDeque<u32>> = (0..speeds.len())
            .map(|d| plan.tasks(d).iter().copied().collect())
            .collect();
        let pending = queues
            .iter()
            .zip(speeds.as_slice())
            .map(|(q, s)| Load::sum(q.iter().map(|&t| costs[t as usize] / s)))
            .collect();
        HybridDispatch {
            queues,
            pending,
            speeds: speeds.as_slice().to_vec(),
            orphans: Orphans::default(),
            costs,
        }
    }

    fn cost(&self, task: u32) -> f64 {
        self.costs[task as usize]
    }

    fn launch_own(&mut self, device: usize, launch: &mut Vec<u32>) -> bool {
        let queue = &mut self.queues[device];
        let take = queue.len().div_ceil(2);
        launch.extend(queue.drain(..take));
        self.pending[device] = Load::sum(
            queue
                .iter()
                .map(|&t| self.costs[t as usize] / self.speeds[device]),
        );
        take > 0
    }

    fn steal(&mut self, thief: usize, launch: &mut Vec<u32>) -> bool {
        let Some(victim) = (0..self.queues.len())
            .filter(|&v| v != thief && !self.queues[v].is_empty())
            .max_by(|&a, &b| self.pending[a].cmp(&self.pending[b]).then(b.cmp(&a)))
        else {
            return false;
        };
        let (st, sv) = (self.speeds[thief], self.speeds[victim]);
        let mut stolen = Load::ZERO; // in cost units
        let mut left = self.pending[victim]; // in the victim's time
        while let Some(&t) = self.queues[victim].back() {
            let c = self.cost(t);
            let thief_ends = stolen.plus(c).value() / st;
            let victim_ends = left.plus(-c / sv).value();
            if thief_ends > victim_ends {
                break;
            }
            self.queues[victim].pop_back();
            stolen = stolen.plus(c);
            left = left.plus(-c / sv);
            launch.push(t);
        }
        // Stolen from the back, smallest first; run the largest first like everyone else.
        launch.reverse();
        self.pending[victim] = left;
        !launch.is_empty()
    }
}

impl Dispatch for HybridDispatch<'_> {
    fn next(&mut self, device: usize, launch: &mut Vec<u32>) {
        let _found = self.launch_own(device, launch)
            || {
                launch.extend(self.orphans.pop());
                !launch.is_empty()
            }
            || self.steal(device, launch);
    }

    fn fail(&mut self, device: usize, undone: &[u32]) {
        let left: Vec<u32> = self.queues[device].drain(..).collect();
        self.pending[device] = Load::ZERO;
        self.orphans
            .extend(self.costs, undone.iter().copied().chain(left));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(d: &mut HybridDispatch, device: usize) -> Vec<u32> {
        let mut launch = Vec::new();
        d.next(device, &mut launch);
        launch
    }

    #[test]
    fn launches_halves_then_steals_the_tail() {
        let costs = Costs::new(vec![8.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]).unwrap();
        let mut d = HybridDispatch::new(&costs, &Speeds::identical(2).unwrap());
        // LPT: device 0 gets 8, device 1 gets the eight 1s; device 0 then has nothing.
        assert_eq!(drain(&mut d, 0), vec![0]);
        assert_eq!(drain(&mut d, 1), vec![1, 2, 3, 4]);
        // Device 0 idle: device 1 has 4 unlaunched; stealing 2 splits them evenly.
        assert_eq!(drain(&mut d, 0), vec![7, 8]);
        assert_eq!(drain(&mut d, 1), vec![5]);
        assert_eq!(drain(&mut d, 1), vec![6]);
        assert!(drain(&mut d, 0).is_empty());
    }

    #[test]
    fn a_slow_thief_takes_nothing_it_cannot_finish_in_time() {
        let costs = Costs::new(vec![1.0, 1.0, 1.0]).unwrap();
        let mut d = HybridDispatch::new(&costs, &Speeds::new(vec![100.0, 0.01]).unwrap());
        assert_eq!(drain(&mut d, 0), vec![0, 1]);
        assert!(drain(&mut d, 1).is_empty());
    }
}
