//! Where a task's data already is, and what moving the task away from it costs.
//!
//! A task produced on one device (the parent rays of a generation, the points of a slab, the
//! paths of a progressive frame) is cheapest to run there: elsewhere it first pays for its
//! data to cross a link. [`plan_lpt_homed`] plans with that price, as HEFT and StarPU's `dmda`
//! do: tasks in decreasing cost, each to the device where it would finish earliest *including*
//! the move. Where every move is free it is [`plan_lpt`] exactly, so the bounds proven for LPT
//! still hold; where moves cost something it is never worse than leaving every task at home.

use crate::{Costs, Load, Plan, SchedError, Speeds, plan_lpt};

/// Each task's home device and the seconds moving it to another device takes (its bytes over
/// the link's bandwidth, plus the link's latency), in the units of `cost / speed`.
#[derive(Clone, Debug, PartialEq)]
pub struct Homes {
    home: Vec<u32>,
    moving: Vec<f64>,
}

impl Homes {
    /// `home[t]` is task `t`'s device and `moving[t]` what moving it elsewhere costs.
    ///
    /// # Errors
    /// [`SchedError::LengthMismatch`] when the two lengths differ, and
    /// [`SchedError::BadMoveCost`] for a move cost that is negative or not finite.
    pub fn new(home: Vec<u32>, moving: Vec<f64>) -> Result<Self, SchedError> {
        if home.len() != moving.len() {
            return Err(SchedError::LengthMismatch {
                what: "move costs",
                expected: home.len(),
                got: moving.len(),
            });
        }
        if let Some((task, &value)) = moving
            .iter()
            .enumerate()
            .find(|(_, c)| !c.is_finite() || **c < 0.0)
        {
            return Err(SchedError::BadMoveCost { task, value });
        }
        Ok(Self { home, moving })
    }

    /// Every task at home on `device`, each move costing `seconds`.
    pub fn all_on(device: u32, tasks: usize, seconds: f64) -> Result<Self, SchedError> {
        Self::new(vec![device; tasks], vec![seconds; tasks])
    }

    /// `Ok` when there is a home for each of `tasks` tasks, each on one of `devices`.
    ///
    /// # Errors
    /// [`SchedError::LengthMismatch`] and [`SchedError::BadHome`], naming the task.
    pub fn check(&self, tasks: usize, devices: usize) -> Result<(), SchedError> {
        if self.home.len() != tasks {
            return Err(SchedError::LengthMismatch {
                what: "homes",
                expected: tasks,
                got: self.home.len(),
            });
        }
        if let Some((task, &device)) = self
            .home
            .iter()
            .enumerate()
            .find(|(_, h)| **h as usize >= devices)
        {
            return Err(SchedError::BadHome {
                task,
                device,
                devices,
            });
        }
        Ok(())
    }

    /// Task `t`'s home device.
    pub fn home(&self, t: usize) -> u32 {
        self.home[t]
    }

    /// What running task `t` on `device` adds to its time: nothing at home.
    pub fn extra(&self, t: usize, device: usize) -> f64 {
        if self.home[t] as usize == device {
            0.0
        } else {
            self.moving[t]
        }
    }

    /// True when no move costs anything: then every policy plans as without homes.
    pub fn is_free(&self) -> bool {
        self.moving.iter().all(|&m| m == 0.0)
    }

    /// Tasks.
    pub fn len(&self) -> usize {
        self.home.len()
    }

    /// Whether there are no tasks.
    pub fn is_empty(&self) -> bool {
        self.home.is_empty()
    }

    /// The makespan of `plan`, the moves included.
    pub fn makespan(&self, plan: &Plan, costs: &Costs, speeds: &Speeds) -> f64 {
        (0..plan.devices())
            .map(|d| {
                let s = speeds.as_slice()[d];
                plan.tasks(d)
                    .iter()
                    .fold(Load::ZERO, |l, &t| {
                        let t = t as usize;
                        l.plus(costs[t] / s).plus(self.extra(t, d))
                    })
                    .value()
            })
            .fold(0.0, f64::max)
    }

    /// Every task on its home device (a home beyond the last device counts as the last).
    pub fn stay_home(&self, devices: usize) -> Plan {
        let mut lists = vec![Vec::new(); devices];
        for (t, &h) in self.home.iter().enumerate() {
            lists[(h as usize).min(devices - 1)].push(t as u32);
        }
        Plan::from_lists(lists)
    }
}

/// LPT with homes: tasks in decreasing cost, each to the device where it finishes earliest
/// once the move is paid (ties to the lower index); then the better of that plan and leaving
/// every task at home, by makespan with the moves. Costs O(n·m) for `n` tasks on `m` devices.
/// With every move free, the plan is [`plan_lpt`]'s.
///
/// # Errors
/// [`SchedError::LengthMismatch`] when `homes` and `costs` differ in length.
pub fn plan_lpt_homed(costs: &Costs, speeds: &Speeds, homes: &Homes) -> Result<Plan, SchedError> {
    if homes.len() != costs.len() {
        return Err(SchedError::LengthMismatch {
            what: "homes",
            expected: costs.len(),
            got: homes.len(),
        });
    }
    if homes.is_free() {
        return Ok(plan_lpt(costs, speeds));
    }
    let m = speeds.len();
    let mut loads = vec![Load::ZERO; m];
    let mut lists = vec![Vec::new(); m];
    for task in costs.decreasing_order() {
        let t = task as usize;
        let (d, finish) = (0..m)
            .map(|d| {
                let f = loads[d]
                    .plus(costs[t] / speeds.as_slice()[d])
                    .plus(homes.extra(t, d));
                (d, f)
            })
            .min_by(|a, b| a.1.cmp(&b.1).then(a.0.cmp(&b.0)))
            .unwrap_or_else(|| unreachable!("validated speeds name at least one device"));
        loads[d] = finish;
        lists[d].push(task);
    }
    let greedy = Plan::from_lists(lists);
    let home = homes.stay_home(m);
    Ok(
        if homes.makespan(&home, costs, speeds) < homes.makespan(&greedy, costs, speeds) {
            home
        } else {
            greedy
        },
    )
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn instance() -> impl Strategy<Value = (Vec<f64>, Vec<f64>, Vec<u32>, Vec<f64>)> {
        (1usize..40, 1usize..6).prop_flat_map(|(n, m)| {
            (
                proptest::collection::vec(0.0f64..100.0, n),
                proptest::collection::vec(0.25f64..4.0, m),
                proptest::collection::vec(0u32..m as u32, n),
                proptest::collection::vec(0.0f64..50.0, n),
            )
        })
    }

    proptest! {
        /// A free move changes nothing: the plan is LPT's, so its proven bounds hold.
        #[test]
        fn free_moves_plan_as_lpt((c, s, h, _) in instance()) {
            let costs = Costs::new(c).unwrap();
            let speeds = Speeds::new(s).unwrap();
            let homes = Homes::new(h.clone(), vec![0.0; h.len()]).unwrap();
            let homed = plan_lpt_homed(&costs, &speeds, &homes).unwrap();
            prop_assert_eq!(homed, plan_lpt(&costs, &speeds));
        }

        /// Paying for moves, the plan is never worse than leaving every task at home, and
        /// every task runs exactly once.
        #[test]
        fn never_worse_than_home((c, s, h, mv) in instance()) {
            let costs = Costs::new(c).unwrap();
            let speeds = Speeds::new(s).unwrap();
            let homes = Homes::new(h, mv).unwrap();
            let plan = plan_lpt_homed(&costs, &speeds, &homes).unwrap();
            let home = homes.stay_home(speeds.len());
            prop_assert!(
                homes.makespan(&plan, &costs, &speeds)
                    <= homes.makespan(&home, &costs, &speeds)
            );
            let mut seen = plan.assignment(costs.len());
            seen.sort_unstable();
            prop_assert_eq!(seen.len(), costs.len());
        }
    }

    /// A move dearer than the whole work keeps every task at home.
    #[test]
    fn dear_moves_stay_home() {
        let costs = Costs::new(vec![4.0, 3.0, 2.0, 1.0]).unwrap();
        let speeds = Speeds::identical(2).unwrap();
        let homes = Homes::new(vec![0, 1, 0, 1], vec![100.0; 4]).unwrap();
        let plan = plan_lpt_homed(&costs, &speeds, &homes).unwrap();
        assert_eq!(plan, homes.stay_home(2));
    }

    /// All work born on one device spreads out when moving is cheap: the other device takes
    /// tasks once its finish time with the move beats waiting.
    #[test]
    fn cheap_moves_spread_the_work() {
        let costs = Costs::new(vec![1.0; 8]).unwrap();
        let speeds = Speeds::identical(2).unwrap();
        let homes = Homes::all_on(0, 8, 0.5).unwrap();
        let plan = plan_lpt_homed(&costs, &speeds, &homes).unwrap();
        assert_eq!(plan.tasks(0).len(), 5);
        assert_eq!(homes.makespan(&plan, &costs, &speeds), 5.0);
        let bad = Homes::new(vec![0, 0], vec![1.0]).unwrap_err();
        assert!(bad.to_string().contains("move costs"), "{bad}");
    }

    fn simulated(
        policy: crate::Policy,
        costs: &Costs,
        speeds: &Speeds,
        homes: Option<&Homes>,
    ) -> crate::SimReport {
        let sim = crate::Simulation::new(policy, speeds.clone());
        let sim = match homes {
            Some(h) => sim.homes(h.clone()),
            None => sim,
        };
        sim.run(costs).unwrap()
    }

    proptest! {
        /// Under every policy, homes whose moves are free change nothing: the same tasks on
        /// the same devices at the same times as without homes.
        #[test]
        fn free_homes_change_no_policy((c, s, h, _) in instance()) {
            let costs = Costs::new(c).unwrap();
            let speeds = Speeds::new(s).unwrap();
            let homes = Homes::new(h.clone(), vec![0.0; h.len()]).unwrap();
            for policy in crate::Policy::ALL {
                let with = simulated(policy, &costs, &speeds, Some(&homes));
                let without = simulated(policy, &costs, &speeds, None);
                prop_assert_eq!(&with.assignment, &without.assignment, "{}", policy);
                prop_assert_eq!(with.metrics.makespan, without.metrics.makespan);
            }
        }

        /// With moves priced, static LPT and Hybrid (exact costs, no latency) finish no later
        /// than every task left at home, the moves' time included; every policy delivers
        /// every task once, also when a device fails halfway.
        #[test]
        fn priced_moves_never_lose_to_staying_home((c, s, h, mv) in instance()) {
            let costs = Costs::new(c).unwrap();
            let speeds = Speeds::new(s).unwrap();
            let homes = Homes::new(h, mv).unwrap();
            let home = homes.makespan(&homes.stay_home(speeds.len()), &costs, &speeds);
            for policy in crate::Policy::ALL {
                let run = simulated(policy, &costs, &speeds, Some(&homes));
                prop_assert!(run.assignment.iter().all(|&d| (d as usize) < speeds.len()));
                if matches!(policy, crate::Policy::StaticLpt | crate::Policy::Hybrid) {
                    prop_assert!(
                        run.metrics.makespan <= home * (1.0 + 1e-9) + 1e-9,
                        "{}: {} against {} at home", policy, run.metrics.makespan, home
                    );
                }
                if speeds.len() > 1 {
                    let faulty = crate::Simulation::new(policy, speeds.clone())
                        .homes(homes.clone())
                        .fault(crate::Fault { device: 0, at: home / 2.0 })
                        .run(&costs)
                        .unwrap();
                    prop_assert!(faulty.assignment.iter().all(|&d| d != u32::MAX));
                }
            }
        }
    }

    /// A queue hands each device its own tasks first: with two devices each holding half the
    /// tasks and dear moves, nothing moves; once a device's own run out it takes the other's.
    #[test]
    fn queues_prefer_home() {
        let costs = Costs::new(vec![1.0; 8]).unwrap();
        let speeds = Speeds::identical(2).unwrap();
        let homes = Homes::new(vec![0, 1, 0, 1, 0, 1, 0, 1], vec![10.0; 8]).unwrap();
        for policy in [crate::Policy::QueueFifo, crate::Policy::QueueSorted] {
            let run = simulated(policy, &costs, &speeds, Some(&homes));
            assert_eq!(run.assignment, [0, 1, 0, 1, 0, 1, 0, 1], "{policy}");
            assert_eq!(run.metrics.makespan, 4.0);
        }
        let lopsided = Homes::new(vec![0, 0, 0, 0, 0, 0, 1, 0], vec![0.5; 8]).unwrap();
        let run = simulated(crate::Policy::QueueFifo, &costs, &speeds, Some(&lopsided));
        // Device 1 runs its own task 6 first, then takes from the front of the queue.
        assert_eq!(run.assignment.iter().filter(|&&d| d == 1).count(), 3);
        assert_eq!(run.assignment[6], 1);
        let wrong = Homes::new(vec![0, 2], vec![1.0; 2]).unwrap();
        let err = crate::Policy::QueueFifo
            .dispatcher_homed(&Costs::new(vec![1.0; 2]).unwrap(), &speeds, &[], &wrong)
            .err()
            .expect("a home beyond the devices");
        assert!(err.to_string().contains("task 1"), "{err}");
    }

    /// The runtime plans with homes too: a static LPT run puts every task where
    /// `plan_lpt_homed` does, each exactly once. Backups are off: with them an idle device
    /// may rightly copy a held task whose device the OS has not yet scheduled.
    #[test]
    fn the_runtime_runs_the_homed_plan() {
        struct Echo;
        impl crate::Executor<std::ops::Range<usize>> for Echo {
            type Output = usize;
            fn run(&mut self, task: &std::ops::Range<usize>) -> Result<usize, crate::DeviceError> {
                Ok(task.start)
            }
        }
        let costs = Costs::new(vec![1.0; 8]).unwrap();
        let speeds = Speeds::identical(2).unwrap();
        let homes = Homes::all_on(0, 8, 0.5).unwrap();
        let tasks = crate::split_ranges(8, 1);
        let run = crate::Runtime::new(crate::Policy::StaticLpt)
            .backups(false)
            .with_homes(homes.clone())
            .run(&tasks, &costs, &mut [Echo, Echo])
            .unwrap();
        assert_eq!(run.outputs, (0..8).collect::<Vec<_>>());
        let plan = plan_lpt_homed(&costs, &speeds, &homes).unwrap();
        let mut on_1: Vec<u32> = run
            .timeline
            .spans
            .iter()
            .filter(|s| s.device == 1)
            .map(|s| s.task)
            .collect();
        on_1.sort_unstable();
        let mut planned = plan.tasks(1).to_vec();
        planned.sort_unstable();
        assert_eq!(on_1, planned);
    }
}
