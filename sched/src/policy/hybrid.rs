use std::collections::VecDeque;

use super::plan_lpt;
use crate::dispatch::Orphans;
use crate::{Costs, Dispatch, Homes, Load, Plan, SchedError, Speeds, plan_lpt_homed};

/// Share of its list's cost a device keeps back from its first launch when launches cost
/// time: the tail that thieves can still rebalance.
const RESERVE: f64 = 1.0 / 8.0;

/// A costly launch carries at least this many times its overhead in work.
const MIN_LAUNCH: f64 = 8.0;

/// LPT start, then stealing of the tail.
///
/// Each device holds its LPT list, the bulk of it in task order and its smallest tasks (the
/// last eighth of its cost) at the back, largest first, and launches from its front each time
/// it goes idle: one task where launching is free (see [`crate::Executor::launch_overhead`]),
/// so that every task not yet started stays within reach of a thief; where its cost is unknown,
/// the front *half* of what is left, which pays O(log n) launches instead of one per task while
/// the small tasks at the back stay available. Where a launch is known to cost `L > 0` seconds,
/// the first launch takes all but a reserve of the smallest tasks (1/8 of the list's cost),
/// later ones half of what is left, and no launch carries or leaves behind less than `8 · L` of
/// work (at the device's pace): halving down to single tasks paid `L` a dozen times per device,
/// which at a network's 200 µs cost more than the imbalance it removed. A device with nothing
/// left looks for work in this order: tasks
/// orphaned by a failed device, then the smallest unlaunched tasks of the device expected to
/// finish last, as many as it can finish no later than that device would finish the rest.
/// Stolen tasks join the thief's list and are launched like its own.
///
/// "Would finish" counts the victim's launch in flight, not only its unlaunched tasks. Each
/// device's pace (seconds per unit of cost) is measured on its own completed launches of
/// this run, so the launch in flight has `its cost × pace − time since it started` left.
/// Ignoring it, as a rule in cost units alone must, left the victim's last unlaunched task
/// unstolen even when the thief would have finished it long before the victim's launch in
/// flight ended.
///
/// That rule is why stealing never makes the makespan worse than the LPT plan when
/// estimates and paces are exact: the thief ends before the victim, and the victim ends
/// earlier than planned. When estimates are wrong, the tail moves to whoever is idle.
///
/// With homes ([`HybridDispatch::homed`]) the start is [`plan_lpt_homed`]'s plan and a thief
/// pays each stolen task's move: it steals only what it finishes, moves included, before the
/// victim would, so the same argument holds with the moves counted.
#[derive(Debug)]
pub struct HybridDispatch<'a> {
    queues: Vec<VecDeque<u32>>,
    /// Unlaunched cost of each device.
    pending: Vec<Load>,
    speeds: Vec<f64>,
    /// Each device's launch overhead in seconds, where known.
    overhead: Vec<Option<f64>>,
    /// Devices that have not yet launched from their own list.
    first: Vec<bool>,
    /// Each device's launch in flight: when it started (seconds) and its cost.
    in_flight: Vec<Option<(f64, f64)>>,
    /// Each device's completed launches: their cost and the seconds they took.
    done: Vec<(Load, f64)>,
    orphans: Orphans,
    costs: &'a Costs,
    homes: Option<&'a Homes>,
}

impl<'a> HybridDispatch<'a> {
    /// Plans `costs` by LPT on `speeds`; launch overheads unknown (launches in halves).
    pub fn new(costs: &'a Costs, speeds: &Speeds) -> Self {
        Self::with_overheads(costs, speeds, &vec![None; speeds.len()])
    }

    /// Plans `costs` by LPT on `speeds`, sizing each device's launches by its launch
    /// overhead in seconds (`None` where unknown; missing entries are unknown).
    pub fn with_overheads(costs: &'a Costs, speeds: &Speeds, overheads: &[Option<f64>]) -> Self {
        Self::from_plan(&plan_lpt(costs, speeds), costs, speeds, overheads, None)
    }

    /// [`HybridDispatch::with_overheads`] for tasks with `homes`: planned by
    /// [`plan_lpt_homed`], stealing with each move paid (see the type's docs).
    ///
    /// # Errors
    /// [`SchedError::LengthMismatch`] when `homes` and `costs` differ in length.
    pub fn homed(
        costs: &'a Costs,
        speeds: &Speeds,
        overheads: &[Option<f64>],
        homes: &'a Homes,
    ) -> Result<Self, SchedError> {
        let plan = plan_lpt_homed(costs, speeds, homes)?;
        Ok(Self::from_plan(
            &plan,
            costs,
            speeds,
            overheads,
            Some(homes),
        ))
    }

    fn from_plan(
        plan: &Plan,
        costs: &'a Costs,
        speeds: &Speeds,
        overheads: &[Option<f64>],
        homes: Option<&'a Homes>,
    ) -> Self {
        let queues: Vec<VecDeque<u32>> = (0..speeds.len())
            .map(|d| bulk_in_order(plan.tasks(d), costs).into())
            .collect();
        let load = |t: u32, d: usize| {
            costs[t as usize] + homes.map_or(0.0, |h| h.extra(t as usize, d) * speeds[d])
        };
        let pending = queues
            .iter()
            .enumerate()
            .map(|(d, q)| Load::sum(q.iter().map(|&t| load(t, d))))
            .collect();
        HybridDispatch {
            queues,
            pending,
            speeds: speeds.as_slice().to_vec(),
            overhead: (0..speeds.len())
                .map(|d| overheads.get(d).copied().flatten())
                .collect(),
            first: vec![true; speeds.len()],
            in_flight: vec![None; speeds.len()],
            done: vec![(Load::ZERO, 0.0); speeds.len()],
            orphans: Orphans::default(),
            costs,
            homes,
        }
    }

    /// What `task` weighs on `device`, in cost units: its cost, and its move away from home
    /// as the work the device could have done meanwhile. Paces and finish times count moves
    /// this way, so a device's measured pace is not inflated by the moves it made.
    fn load(&self, task: u32, device: usize) -> f64 {
        let moving = self.homes.map_or(0.0, |h| {
            h.extra(task as usize, device) * self.speeds[device]
        });
        self.costs[task as usize] + moving
    }

    /// Seconds per unit of cost on `device`: measured on its own completed launches, else on
    /// everyone's, scaled by the planned speeds; `None` before any launch completed.
    fn pace(&self, device: usize) -> Option<f64> {
        let measured = |(cost, secs): (Load, f64)| {
            (cost.value() > 0.0 && secs > 0.0).then(|| secs / cost.value())
        };
        measured(self.done[device]).or_else(|| {
            let (mut cost, mut secs) = (0.0, 0.0);
            for (d, &(c, s)) in self.done.iter().enumerate() {
                if measured((c, s)).is_some() {
                    cost += c.value();
                    secs += s * self.speeds[d];
                }
            }
            (cost > 0.0).then(|| secs / cost / self.speeds[device])
        })
    }

    /// How many tasks from the front of `device`'s list its next launch takes; see the
    /// type's docs.
    fn launch_size(&self, device: usize) -> usize {
        let queue = &self.queues[device];
        match self.overhead[device] {
            Some(0.0) => queue.len().min(1),
            Some(l) if l > 0.0 => {
                let left = self.pending[device].value();
                let pace = self.pace(device).unwrap_or(1.0 / self.speeds[device]);
                // Work (in cost units) worth paying `l` for once more.
                let least = MIN_LAUNCH * l / pace;
                let keep = if self.first[device] {
                    left * RESERVE
                } else {
                    left / 2.0
                };
                let work = if keep < least {
                    left
                } else {
                    (left - keep).max(least)
                };
                self.front_covering(device, work)
            }
            _ => queue.len().div_ceil(2),
        }
    }

    /// The fewest tasks from the front of `device`'s list whose cost reaches `work` (at
    /// least one, at most all).
    fn front_covering(&self, device: usize, work: f64) -> usize {
        let queue = &self.queues[device];
        let mut taken = Load::ZERO;
        let reach = queue
            .iter()
            .position(|&t| {
                taken = taken.plus(self.load(t, device));
                taken.value() >= work
            })
            .map_or(queue.len(), |k| k + 1);
        reach.max(1).min(queue.len())
    }

    fn launch_own(&mut self, device: usize, launch: &mut Vec<u32>) -> bool {
        let take = self.launch_size(device);
        self.first[device] &= take == 0;
        let first = launch.len();
        launch.extend(self.queues[device].drain(..take));
        // Subtracted, not re-summed: with one task per launch, re-summing the list each
        // time made dispatch quadratic in the tasks (tens of ms for 4000 of them).
        self.pending[device] = if self.queues[device].is_empty() {
            Load::ZERO
        } else {
            launch[first..]
                .iter()
                .fold(self.pending[device], |p, &t| p.plus(-self.load(t, device)))
        };
        take > 0
    }

    /// When `device` would finish what it holds, counted from `now`: in seconds once paces
    /// are measured (`paces` is the thief's and this device's), else in planned time (cost /
    /// speed, nothing in flight).
    fn finish(&self, device: usize, now: f64, paces: Option<(f64, f64)>) -> f64 {
        match paces {
            Some((_, pace)) => {
                let flight = self.in_flight[device]
                    .map_or(0.0, |(at, cost)| (cost * pace - (now - at)).max(0.0));
                flight + self.pending[device].value() * pace
            }
            None => self.pending[device].value() / self.speeds[device],
        }
    }

    /// Moves the smallest unlaunched tasks of the device expected to finish last into the
    /// (idle, empty-handed) thief's list; see the type's docs for how many.
    fn steal(&mut self, thief: usize, now: f64) -> bool {
        let pace: Vec<Option<f64>> = (0..self.queues.len()).map(|d| self.pace(d)).collect();
        let paces_of = |v: usize| pace[thief].zip(pace[v]);
        let Some(victim) = (0..self.queues.len())
            .filter(|&v| v != thief && !self.queues[v].is_empty())
            .max_by(|&a, &b| {
                let fa = self.finish(a, now, paces_of(a));
                let fb = self.finish(b, now, paces_of(b));
                fa.total_cmp(&fb).then(b.cmp(&a))
            })
        else {
            return false;
        };
        let paces = paces_of(victim);
        // Time per unit of cost on the thief and on the victim, in one unit.
        let (pt, pv) = paces.unwrap_or((1.0 / self.speeds[thief], 1.0 / self.speeds[victim]));
        let mut stolen = Load::ZERO;
        let mut victim_ends = self.finish(victim, now, paces);
        let mut took = Vec::new();
        while let Some(&t) = self.queues[victim].back() {
            // With homes a task weighs differently on the two devices (see `load`).
            let (on_thief, on_victim) = (self.load(t, thief), self.load(t, victim));
            if stolen.plus(on_thief).value() * pt > victim_ends - on_victim * pv {
                break;
            }
            self.queues[victim].pop_back();
            stolen = stolen.plus(on_thief);
            victim_ends -= on_victim * pv;
            self.pending[victim] = self.pending[victim].plus(-on_victim);
            took.push(t);
        }
        // Taken from the back, smallest first; the thief runs the largest first like
        // everyone else.
        self.queues[thief].extend(took.iter().rev());
        self.pending[thief] = self.pending[thief].plus_load(stolen);
        !took.is_empty()
    }
}

/// A device's LPT list (largest first) in the order it runs: the largest tasks, up to all but
/// [`RESERVE`] of the list's cost, in the caller's order, then the smallest, largest first.
///
/// The caller's order is usually memory order (neighbouring rays, neighbouring points), and
/// running a device's bulk in it keeps the caches warm from one task to the next; cost order
/// jumped across the image: on forest's 512-ray AO tasks the two devices were busy 7 % longer
/// (1.358 against 1.267 s, medians of six renders).
/// The smallest tasks stay at the back, where thieves take them, so the tail still balances.
fn bulk_in_order(list: &[u32], costs: &Costs) -> Vec<u32> {
    let total = Load::sum(list.iter().map(|&t| costs[t as usize])).value();
    let mut taken = Load::ZERO;
    let bulk = list
        .iter()
        .position(|&t| {
            let reached = taken.value() >= total * (1.0 - RESERVE);
            taken = taken.plus(costs[t as usize]);
            reached
        })
        .unwrap_or(list.len());
    let mut out = list.to_vec();
    out[..bulk].sort_unstable();
    out
}

impl Dispatch for HybridDispatch<'_> {
    fn next(&mut self, device: usize, now: f64, launch: &mut Vec<u32>) {
        // Asking again means the last launch is done: it measures the device's pace.
        if let Some((at, cost)) = self.in_flight[device].take() {
            let (c, s) = self.done[device];
            self.done[device] = (c.plus(cost), s + (now - at).max(0.0));
        }
        if self.queues[device].is_empty() {
            launch.extend(self.orphans.pop());
            if launch.is_empty() {
                self.steal(device, now);
            }
        }
        if launch.is_empty() {
            self.launch_own(device, launch);
        }
        if !launch.is_empty() {
            let cost = launch.iter().map(|&t| self.load(t, device)).sum();
            self.in_flight[device] = Some((now, cost));
        }
    }

    fn fail(&mut self, device: usize, undone: &[u32]) {
        let left: Vec<u32> = self.queues[device].drain(..).collect();
        self.pending[device] = Load::ZERO;
        self.in_flight[device] = None;
        self.orphans
            .extend(self.costs, undone.iter().copied().chain(left));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drain(d: &mut HybridDispatch, device: usize, now: f64) -> Vec<u32> {
        let mut launch = Vec::new();
        d.next(device, now, &mut launch);
        launch
    }

    #[test]
    fn launches_halves_then_steals_the_tail() {
        let costs = Costs::new(vec![8.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]).unwrap();
        let mut d = HybridDispatch::new(&costs, &Speeds::identical(2).unwrap());
        // LPT: device 0 gets 8, device 1 gets the eight 1s; device 0 then has nothing.
        assert_eq!(drain(&mut d, 0, 0.0), vec![0]);
        assert_eq!(drain(&mut d, 1, 0.0), vec![1, 2, 3, 4]);
        // Device 0 idle, no pace measured yet: device 1 has 4 unlaunched; stealing 2 splits
        // them evenly, and the thief launches them in halves too.
        assert_eq!(drain(&mut d, 0, 0.0), vec![7]);
        assert_eq!(drain(&mut d, 1, 0.0), vec![5]);
        assert_eq!(drain(&mut d, 1, 0.0), vec![6]);
        assert_eq!(drain(&mut d, 0, 0.0), vec![8]);
        assert!(drain(&mut d, 0, 0.0).is_empty());
    }

    #[test]
    fn the_victims_launch_in_flight_counts() {
        let costs = Costs::new(vec![5.0, 2.0, 1.0, 1.0, 1.0]).unwrap();
        let mut d = HybridDispatch::new(&costs, &Speeds::identical(2).unwrap());
        assert_eq!(drain(&mut d, 0, 0.0), vec![0]);
        assert_eq!(drain(&mut d, 1, 0.0), vec![1, 2]);
        // Device 1 took 3 s for 3 units of cost and launches one of its last two tasks.
        assert_eq!(drain(&mut d, 1, 3.0), vec![3]);
        // Device 0 ran faster than planned (5 units in 3.2 s). Device 1 will finish its
        // launch at 4.0 and then its last task at 5.0; the thief finishes that task at 3.84.
        // Counting unlaunched work only (1 unit, nothing to gain), it would stay idle.
        assert_eq!(drain(&mut d, 0, 3.2), vec![4]);
        assert!(drain(&mut d, 1, 4.0).is_empty());
    }

    #[test]
    fn a_slow_thief_takes_nothing_it_cannot_finish_in_time() {
        let costs = Costs::new(vec![1.0; 4]).unwrap();
        let mut d = HybridDispatch::new(&costs, &Speeds::new(vec![100.0, 0.01]).unwrap());
        assert_eq!(drain(&mut d, 0, 0.0), vec![0, 1]);
        assert!(drain(&mut d, 1, 0.0).is_empty());
        // Device 0 did 2 units in 0.02 s; device 1, 10⁴ times slower, would need 100 s for
        // a task that device 0 ends in 0.02 s with its last one.
        assert_eq!(drain(&mut d, 0, 0.02), vec![2]);
        assert!(drain(&mut d, 1, 0.02).is_empty());
    }

    #[test]
    fn free_launches_take_one_task_unknown_ones_halves_and_costly_ones_all_but_a_reserve() {
        let costs = Costs::new(vec![1.0; 16]).unwrap();
        let one = Speeds::identical(1).unwrap();
        let mut free = HybridDispatch::with_overheads(&costs, &one, &[Some(0.0)]);
        assert_eq!(drain(&mut free, 0, 0.0), vec![0]);
        assert_eq!(drain(&mut free, 0, 1.0), vec![1]);
        let mut unknown = HybridDispatch::with_overheads(&costs, &one, &[None]);
        assert_eq!(drain(&mut unknown, 0, 0.0), (0..8).collect::<Vec<_>>());
        assert_eq!(drain(&mut unknown, 0, 8.0), (8..12).collect::<Vec<_>>());
        // 1/8 of the cost (two tasks) held back from the first launch; then halves of what
        // is left, but never under 8 overheads of work (here 0.25 s, a quarter of a task).
        let mut costly = HybridDispatch::with_overheads(&costs, &one, &[Some(1.0 / 32.0)]);
        assert_eq!(drain(&mut costly, 0, 0.0), (0..14).collect::<Vec<_>>());
        assert_eq!(drain(&mut costly, 0, 14.0), vec![14]);
        assert_eq!(drain(&mut costly, 0, 15.0), vec![15]);
        // At 1 s per launch, a reserve of 2 s is not worth another launch (8 s would be); at
        // 0.25 s it is (2 s), but half of the 2 s then left is not.
        let mut slow = HybridDispatch::with_overheads(&costs, &one, &[Some(1.0)]);
        assert_eq!(drain(&mut slow, 0, 0.0), (0..16).collect::<Vec<_>>());
        let mut slow = HybridDispatch::with_overheads(&costs, &one, &[Some(0.25)]);
        assert_eq!(drain(&mut slow, 0, 0.0), (0..14).collect::<Vec<_>>());
        assert_eq!(drain(&mut slow, 0, 14.0), vec![14, 15]);
    }

    #[test]
    fn the_bulk_runs_in_task_order_and_the_smallest_tasks_wait_at_the_back() {
        let costs = Costs::new(vec![3.0, 9.0, 1.0, 7.0, 2.0, 8.0, 0.5, 0.5]).unwrap();
        // LPT order 1, 5, 3, 0, 4, 2, 6, 7; the first five reach 7/8 of the cost (31).
        let mut d =
            HybridDispatch::with_overheads(&costs, &Speeds::identical(1).unwrap(), &[Some(0.0)]);
        let order: Vec<u32> = (0..8).flat_map(|k| drain(&mut d, 0, k as f64)).collect();
        assert_eq!(order, vec![0, 1, 3, 4, 5, 2, 6, 7]);
        // A thief takes from the back: the smallest tasks.
        let two = Speeds::identical(2).unwrap();
        let costs = Costs::new(vec![20.0, 1.0, 1.0, 4.0, 3.0, 2.0, 6.0]).unwrap();
        let mut d = HybridDispatch::with_overheads(&costs, &two, &[Some(0.0), Some(0.0)]);
        // LPT: device 0 gets 20; device 1 gets 6, 4, 3, 2, 1, 1 (tasks 6, 3, 4, 5, 1, 2) and
        // runs 3, 4, 5, 6 in task order before its reserve 1, 2.
        assert_eq!(drain(&mut d, 0, 0.0), vec![0]);
        assert_eq!(drain(&mut d, 1, 0.0), vec![3]);
        assert_eq!(d.queues[1], [4, 5, 6, 1, 2]);
    }
}
