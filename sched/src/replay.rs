//! A measured run replayed in the [`Simulation`]: the same policy, planning with the same
//! costs, speeds and declared launch overheads as the real run, while time follows what the
//! run measured: each task's own time on the device it ran on, each device's own delay before
//! its launches.
//!
//! A task that the replay puts on another device than the real run did takes its measured time
//! scaled by the two devices' measured rates (planned cost per busy second), so a dynamic
//! policy can move work as it would have. A static plan is the same plan in both, and then the
//! replay reproduces the run's makespan: what is left between the two is what the simulator
//! does not model.

use crate::{Costs, Policy, SchedError, SimReport, Simulation, Speeds};

/// One task of a measured run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredTask {
    /// The device that delivered it (an index into the run's devices).
    pub device: usize,
    /// When its span started, in seconds from the run's start.
    pub start: f64,
    /// Its span's length in seconds: the first task of a launch carries the launch's cost.
    pub seconds: f64,
}

/// What a run was planned with and what it measured.
#[derive(Clone, Debug)]
pub struct MeasuredRun {
    /// The policy that planned it.
    pub policy: Policy,
    /// The costs the plan used.
    pub planned: Costs,
    /// The speeds the plan used, one per device.
    pub speeds: Speeds,
    /// Each device's declared launch overhead, as the runtime told the policy.
    pub overheads: Vec<Option<f64>>,
    /// Every task, in task order.
    pub tasks: Vec<MeasuredTask>,
}

impl MeasuredRun {
    /// Each device's mean delay before a launch started: from the run's start to its first
    /// launch, and from the end of one launch to the start of the next (waiting for the
    /// dispatcher, a thread to wake). Spans of one launch follow each other without a gap,
    /// which is how launches are told apart. A device that ran nothing gets 0.
    pub fn launch_delays(&self) -> Vec<f64> {
        let m = self.speeds.len();
        let mut per: Vec<Vec<(f64, f64)>> = vec![Vec::new(); m];
        for t in &self.tasks {
            if let Some(spans) = per.get_mut(t.device) {
                spans.push((t.start, t.start + t.seconds));
            }
        }
        per.into_iter()
            .map(|mut spans| {
                spans.sort_by(|a, b| a.0.total_cmp(&b.0));
                let (mut waited, mut launches, mut end) = (0.0, 0usize, 0.0);
                for (k, &(start, stop)) in spans.iter().enumerate() {
                    // A relative tolerance: a launch's next span starts where the last ended,
                    // up to the rounding of the clock's conversion to seconds.
                    if k == 0 || start - end > 1e-9 * end.max(1.0) {
                        waited += (start - end).max(0.0);
                        launches += 1;
                    }
                    end = stop;
                }
                if launches == 0 {
                    0.0
                } else {
                    waited / launches as f64
                }
            })
            .collect()
    }

    /// Each device's measured rate, planned cost per busy second; a device that ran nothing
    /// gets its planned speed in the measured devices' unit.
    pub fn rates(&self) -> Vec<f64> {
        let m = self.speeds.len();
        let (mut cost, mut busy) = (vec![0.0; m], vec![0.0; m]);
        for (t, task) in self.tasks.iter().enumerate() {
            if task.device < m {
                cost[task.device] += self.planned[t];
                busy[task.device] += task.seconds;
            }
        }
        let measured: Vec<Option<f64>> = (0..m)
            .map(|d| {
                let r = cost[d] / busy[d];
                (r.is_finite() && r > 0.0).then_some(r)
            })
            .collect();
        // Rate per unit of planned speed over the devices that ran: the unit for the others.
        let (sum, n) = measured
            .iter()
            .enumerate()
            .filter_map(|(d, r)| r.map(|r| r / self.speeds[d]))
            .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
        let unit = if n > 0 { sum / n as f64 } else { 1.0 };
        (0..m)
            .map(|d| measured[d].unwrap_or(self.speeds[d] * unit))
            .collect()
    }

    /// Replays the run: see the module documentation.
    pub fn replay(&self) -> Result<SimReport, SchedError> {
        let n = self.planned.len();
        if self.tasks.len() != n {
            return Err(SchedError::LengthMismatch {
                what: "one measured task per planned cost",
                expected: n,
                got: self.tasks.len(),
            });
        }
        let m = self.speeds.len();
        if let Some(t) = self.tasks.iter().find(|t| t.device >= m) {
            return Err(SchedError::BadFault {
                device: t.device,
                devices: m,
            });
        }
        let rates = self.rates();
        let tasks = &self.tasks;
        let seconds = |t: usize, d: usize| {
            let own = tasks[t].device;
            if own == d {
                tasks[t].seconds
            } else {
                tasks[t].seconds * rates[own] / rates[d]
            }
        };
        // The measured plan is replayed: a copy's time on another device was not measured.
        Simulation::new(self.policy, self.speeds.clone())
            .backups(false)
            .device_latencies(self.launch_delays())
            .planned_overheads(self.overheads.clone())
            .run_timed(&self.planned, &seconds)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn task(device: usize, start: f64, seconds: f64) -> MeasuredTask {
        MeasuredTask {
            device,
            start,
            seconds,
        }
    }

    #[test]
    fn delays_are_the_gaps_before_launches() {
        let run = MeasuredRun {
            policy: Policy::QueueFifo,
            planned: Costs::new(vec![1.0; 4]).unwrap(),
            speeds: Speeds::identical(3).unwrap(),
            overheads: vec![None; 3],
            // Device 0: one launch at 0.5 of two tasks; device 1: launches at 0.1 and 1.3.
            tasks: vec![
                task(0, 0.5, 1.0),
                task(0, 1.5, 1.0),
                task(1, 0.1, 1.0),
                task(1, 1.3, 1.0),
            ],
        };
        let d = run.launch_delays();
        assert!((d[0] - 0.5).abs() < 1e-12, "{d:?}");
        assert!((d[1] - 0.15).abs() < 1e-12, "{d:?}");
        assert_eq!(d[2], 0.0);
        let r = run.rates();
        assert_eq!((r[0], r[1], r[2]), (1.0, 1.0, 1.0));
    }

    /// Spins for a time proportional to its task's length over its speed.
    struct Spinner {
        speed: f64,
    }

    impl crate::Executor<std::ops::Range<usize>> for Spinner {
        type Output = usize;
        fn run(&mut self, task: &std::ops::Range<usize>) -> Result<usize, crate::DeviceError> {
            let until = std::time::Duration::from_secs_f64(task.len() as f64 * 2e-6 / self.speed);
            let start = std::time::Instant::now();
            while start.elapsed() < until {
                std::hint::spin_loop();
            }
            Ok(task.len())
        }
        fn speed(&self) -> f64 {
            self.speed
        }
    }

    /// Replaying a real run's own times reproduces a static plan's makespan exactly (the
    /// plan is the same, and each device's delay and task times are the measured ones), and
    /// a queue's closely, whatever the machine's noise did to the run.
    #[test]
    fn a_replay_reproduces_a_measured_static_run() {
        let mut rng = crate::Rng::new(7);
        let mut tasks = Vec::new();
        let mut at = 0;
        for _ in 0..40 {
            let len = 50 + (rng.next_u64() % 400) as usize;
            tasks.push(at..at + len);
            at += len;
        }
        let planned = Costs::new(tasks.iter().map(|t| t.len() as f64).collect()).unwrap();
        for policy in Policy::ALL {
            let mut devices = [Spinner { speed: 1.0 }, Spinner { speed: 2.0 }];
            let run = crate::Runtime::new(policy)
                .backups(false)
                .run(&tasks, &planned, &mut devices)
                .expect("run");
            let mut measured = vec![
                MeasuredTask {
                    device: 0,
                    start: 0.0,
                    seconds: 0.0
                };
                tasks.len()
            ];
            for s in &run.timeline.spans {
                measured[s.task as usize] = MeasuredTask {
                    device: s.device as usize,
                    start: s.start,
                    seconds: s.end - s.start,
                };
            }
            let replay = MeasuredRun {
                policy,
                planned: planned.clone(),
                speeds: Speeds::new(vec![1.0, 2.0]).unwrap(),
                overheads: vec![None, None],
                tasks: measured,
            }
            .replay()
            .expect("replay");
            let (sim, real) = (replay.metrics.makespan, run.metrics.makespan);
            if matches!(policy, Policy::StaticEqual | Policy::StaticLpt) {
                assert!((sim / real - 1.0).abs() < 1e-9, "{policy}: {sim} vs {real}");
                assert_eq!(replay.assignment, run.timeline.assignment(tasks.len()));
            } else {
                assert!(
                    sim > 0.0 && (sim / real - 1.0).abs() < 0.5,
                    "{policy}: {sim} vs {real}"
                );
            }
        }
    }
}
