use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::{Costs, Load, Plan, Speeds};

/// Devices of one speed, as a min-heap of (finish time, device).
type SpeedGroup = (f64, BinaryHeap<Reverse<(Load, u32)>>);

/// Longest processing time first, generalised to devices of different speeds: tasks in
/// decreasing cost, each to the device where it would *finish* earliest (ties to the lower
/// index). On identical devices this is Graham's LPT.
///
/// Devices are grouped by speed, with a min-heap of finish times per group, so a plan costs
/// O(n log n + n·(k + log m)) for `k` distinct speeds: a million tasks on 1024 identical
/// devices plan in tens of milliseconds.
pub fn plan_lpt(costs: &Costs, speeds: &Speeds) -> Plan {
    let mut groups: Vec<SpeedGroup> = Vec::new();
    for (d, &s) in speeds.as_slice().iter().enumerate() {
        let entry = Reverse((Load::ZERO, d as u32));
        match groups.iter_mut().find(|(gs, _)| *gs == s) {
            Some((_, heap)) => heap.push(entry),
            None => groups.push((s, BinaryHeap::from([entry]))),
        }
    }
    let mut lists = vec![Vec::new(); speeds.len()];
    for task in costs.decreasing_order() {
        let cost = costs[task as usize];
        let (group, finish) = groups
            .iter()
            .enumerate()
            .filter_map(|(g, (s, heap))| {
                heap.peek()
                    .map(|Reverse((load, d))| (g, (load.plus(cost / s), *d)))
            })
            .min_by(|a, b| a.1.cmp(&b.1))
            .unwrap_or_else(|| unreachable!("validated speeds name at least one device"));
        // Replacing the top in place costs one sift-down instead of a pop and a push.
        if let Some(mut top) = groups[group].1.peek_mut() {
            *top = Reverse(finish);
        }
        lists[finish.1 as usize].push(task);
    }
    Plan::from_lists(lists)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn graham_example() {
        // The classic tight instance for m = 2: 3,3,2,2,2 → LPT 7, OPT 6.
        let costs = Costs::new(vec![3.0, 3.0, 2.0, 2.0, 2.0]).unwrap();
        let plan = plan_lpt(&costs, &Speeds::identical(2).unwrap());
        assert_eq!(plan.tasks(0), &[0, 2, 4]);
        assert_eq!(plan.tasks(1), &[1, 3]);
        assert_eq!(plan.makespan(&costs, &Speeds::identical(2).unwrap()), 7.0);
    }

    #[test]
    fn fast_devices_get_more() {
        let costs = Costs::new(vec![1.0; 9]).unwrap();
        let speeds = Speeds::new(vec![1.0, 2.0]).unwrap();
        let plan = plan_lpt(&costs, &speeds);
        assert_eq!(plan.tasks(1).len(), 6);
        assert_eq!(plan.makespan(&costs, &speeds), 3.0);
    }

    #[test]
    fn huge_and_tiny_costs_stay_exact() {
        let mut c = vec![1e12, 1e12];
        c.extend(std::iter::repeat_n(1e-12, 1000));
        let costs = Costs::new(c).unwrap();
        let plan = plan_lpt(&costs, &Speeds::identical(2).unwrap());
        // The tiny tasks alternate so both devices end with exactly 1e12 + 500e-12.
        assert_eq!(plan.tasks(0).len(), 501);
        assert_eq!(plan.tasks(1).len(), 501);
    }
}
