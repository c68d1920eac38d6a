//! Backup copies: when a device has nothing left to do, it may run a copy of a task that
//! another device holds, and the first result is kept.
//!
//! A plan is only as good as its model. A slow device whose task runs longer than estimated,
//! or a queue that hands the last task to whichever device asks first, leaves a fast device
//! idle while the frame waits for the slow one. [`Backups::choose`] is the one rule by which
//! both the [`crate::Runtime`] and the [`crate::Simulation`] decide, from the model (a task's
//! estimated cost over a device's speed, plus its launch overhead and the move to it) and the
//! time a running copy has already taken, whether an idle device's copy can still help.

use crate::{Costs, Homes};

/// One device's launch as the rule sees it: the tasks it has not delivered, in the order it
/// runs them, the first one running since `head_started` (a time in the future while the
/// launch waits its latency).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Held<'a> {
    /// The device holding the tasks.
    pub device: usize,
    /// Its launch's tasks from the one it runs now on; tasks already delivered elsewhere are
    /// skipped through `done`.
    pub tasks: &'a [u32],
    /// When the first of `tasks` started (or starts).
    pub head_started: f64,
}

/// What an idle device should do.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Backup {
    /// Launch copies of these tasks, in this order.
    Copy(Vec<u32>),
    /// Nothing now; ask again at this time if nothing else happens first (`None`: only when
    /// something else happens).
    Wait(Option<f64>),
}

/// The model the rule decides by: what every task is estimated to cost, and how fast each
/// device is and what a launch costs it, as the policy was told.
#[derive(Debug)]
pub(crate) struct Backups<'a> {
    costs: &'a Costs,
    speeds: Vec<f64>,
    overheads: Vec<f64>,
    homes: Option<&'a Homes>,
}

impl<'a> Backups<'a> {
    /// The rule for devices of `speeds`, whose launches cost `overheads` (unknown: 0).
    pub(crate) fn new(
        costs: &'a Costs,
        speeds: &[f64],
        overheads: &[Option<f64>],
        homes: Option<&'a Homes>,
    ) -> Self {
        Backups {
            costs,
            speeds: speeds.to_vec(),
            overheads: (0..speeds.len())
                .map(|d| overheads.get(d).copied().flatten().unwrap_or(0.0))
                .collect(),
            homes,
        }
    }

    /// The model's time for task `t` on device `d`, its move there included.
    fn seconds(&self, t: u32, d: usize) -> f64 {
        let t = t as usize;
        self.costs[t] / self.speeds[d] + self.homes.map_or(0.0, |h| h.extra(t, d))
    }

    /// What idle device `idle` should do at `now`, given what the others hold.
    ///
    /// Each held task is expected to finish when its holder gets to it: the running one at
    /// its start plus its model time or, once it has run past that, after as long again as it
    /// has already run (the model was wrong about it, and nothing says by how much); the
    /// others one after another behind it. Going from the task expected to finish last, the
    /// idle device takes every task whose copy it would start before the holder is expected
    /// to finish it, run one after another in one launch (latest first, so that it meets the
    /// holder, which goes first to last, in the middle). A task held by several devices
    /// counts at its earliest expected finish. When it takes nothing, it asks again when the
    /// model's expectation changes: when a running task reaches its model time, has run as
    /// long as the idle device's copy would take, or is expected to end.
    ///
    /// Starting, rather than finishing, sooner is the test because the model can be wrong
    /// by any factor: a copy that the model says would finish later may still be the one
    /// that finishes first, and the idle device has nothing else to do. This way the fastest
    /// device never idles while a task it has not run is undelivered (without latency), so
    /// no run ends after that device would alone, whatever the estimates and speeds; the
    /// price is work wasted on copies that lose, reported by the runtime and the simulator.
    pub(crate) fn choose(
        &self,
        idle: usize,
        now: f64,
        held: &[Held<'_>],
        done: &dyn Fn(u32) -> bool,
    ) -> Backup {
        let mut expected: Vec<(u32, f64)> = Vec::new();
        let mut recheck = f64::INFINITY;
        for h in held.iter().filter(|h| h.device != idle) {
            let mut clock = now.max(h.head_started);
            // A running task delivered elsewhere is being dropped: the next starts now.
            let s = match h.tasks.first() {
                Some(&t) if done(t) => clock,
                _ => h.head_started,
            };
            let mut tasks = h.tasks.iter().copied().filter(|&t| !done(t));
            if let Some(head) = tasks.next() {
                let model = self.seconds(head, h.device);
                clock = if now < s + model {
                    s + model
                } else {
                    now + (now - s)
                };
                let copy = self.overheads[idle] + self.seconds(head, idle);
                for at in [s + model, s + copy, clock] {
                    if at > now {
                        recheck = recheck.min(at);
                    }
                }
                expected.push((head, clock));
            }
            for t in tasks {
                clock += self.seconds(t, h.device);
                expected.push((t, clock));
            }
        }
        expected.sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        expected.dedup_by_key(|e| e.0);
        expected.sort_unstable_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));

        let mut clock = now + self.overheads[idle];
        let mut copies = Vec::new();
        for (t, finish) in expected {
            let end = clock + self.seconds(t, idle);
            if clock < finish {
                copies.push(t);
                clock = end;
            }
        }
        if copies.is_empty() {
            // Strictly later, so that a simulation asking again at that time moves on.
            Backup::Wait(recheck.is_finite().then(|| recheck.next_up()))
        } else {
            Backup::Copy(copies)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rule<'a>(costs: &'a Costs, speeds: &[f64]) -> Backups<'a> {
        Backups::new(costs, speeds, &[], None)
    }

    #[test]
    fn a_fast_idle_device_copies_what_a_slow_one_holds() {
        let costs = Costs::new(vec![1.0, 1.0, 1.0]).unwrap();
        let b = rule(&costs, &[1.0, 0.1]);
        let held = [Held {
            device: 1,
            tasks: &[0, 1, 2],
            head_started: 0.0,
        }];
        // Device 1 expects to finish at 10, 20, 30; device 0's copies start at 1, 2, 3.
        assert_eq!(
            b.choose(0, 1.0, &held, &|_| false),
            Backup::Copy(vec![2, 1, 0])
        );
        // What is delivered is not copied.
        assert_eq!(b.choose(0, 1.0, &held, &|t| t != 2), Backup::Copy(vec![2]));
    }

    #[test]
    fn an_idle_device_waits_for_a_task_expected_before_its_copy_could_start() {
        let costs = Costs::new(vec![2.0]).unwrap();
        let b = Backups::new(&costs, &[1.0, 1.0], &[Some(1.5), None], None);
        let held = [Held {
            device: 1,
            tasks: &[0],
            head_started: 0.0,
        }];
        // Expected at 2; a copy launched at 1 starts at 2.5: wait until the model time, 2.
        let Backup::Wait(Some(at)) = b.choose(0, 1.0, &held, &|_| false) else {
            panic!("expected a wait");
        };
        assert!(at > 2.0 && at < 2.0 + 1e-9);
        // At 2.5 it has run 2.5, so it is expected at 5: a copy starts at 4.
        assert_eq!(b.choose(0, 2.5, &held, &|_| false), Backup::Copy(vec![0]));
    }
}
