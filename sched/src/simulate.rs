use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::{
    Costs, DeviceFailure, Homes, Load, Metrics, Policy, SchedError, Span, Speeds, Timeline,
};

/// A device that stops at a given time: what it is running then is lost and re-run elsewhere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fault {
    /// The device that fails.
    pub device: usize,
    /// When, in the same unit as the costs.
    pub at: f64,
}

/// A discrete-event replay of a policy on virtual devices.
///
/// Task costs are read as time on a device of speed 1. Each launch pays `latency` before its
/// first task starts (a PCIe kernel launch is about 10 µs, a network hop about 50 µs, in
/// seconds). The policy sees the *estimated* costs; time follows the *actual* ones, so the
/// effect of estimation error can be measured.
///
/// ```
/// use sched::{Costs, Policy, Simulation, Speeds};
/// let costs = Costs::new(vec![3.0, 3.0, 2.0, 2.0, 2.0])?;
/// let sim = Simulation::new(Policy::StaticLpt, Speeds::identical(2)?).run(&costs)?;
/// assert_eq!(sim.metrics.makespan, 7.0); // Graham's tight case: OPT is 6.
/// # Ok::<(), sched::SchedError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Simulation {
    policy: Policy,
    speeds: Speeds,
    latency: f64,
    /// Per-device latencies, where they differ (a replay of a measured run).
    latencies: Option<Vec<f64>>,
    /// What the policy is told each launch costs, where that is not the latency itself.
    told: Option<Vec<Option<f64>>>,
    faults: Vec<Fault>,
    record: bool,
    homes: Option<Homes>,
}

/// What a simulation found.
#[derive(Debug, Clone, PartialEq)]
pub struct SimReport {
    /// Makespan, busy and idle time, balance efficiency.
    pub metrics: Metrics,
    /// The device that delivered each task, in task order.
    pub assignment: Vec<u32>,
    /// Launches per device: each paid the latency once.
    pub launches: Vec<u64>,
    /// Task runs lost to faults and run again.
    pub reruns: u64,
    /// Wall time the policy took to plan (build its dispatcher), in real seconds.
    pub plan_seconds: f64,
    /// Every delivered task, if recording was asked for.
    pub timeline: Option<Timeline>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    // At equal times a fault comes first: a device that fails at t does not start at t.
    Fault,
    Ready,
}

impl Simulation {
    /// Simulates `policy` on devices of the given speeds, with no latency and no faults.
    pub fn new(policy: Policy, speeds: Speeds) -> Self {
        Simulation {
            policy,
            speeds,
            latency: 0.0,
            latencies: None,
            told: None,
            faults: Vec::new(),
            record: false,
            homes: None,
        }
    }

    /// Each device's launches wait its own latency (one per device, in order) instead of
    /// [`Simulation::latency`]: a replay of a run whose devices were measured apart.
    #[must_use]
    pub fn device_latencies(mut self, latencies: Vec<f64>) -> Self {
        self.latencies = Some(latencies);
        self
    }

    /// What the policy plans with as each device's launch overhead (as
    /// [`crate::Executor::launch_overhead`] tells the runtime), where it is not the simulated
    /// latency: a replay plans as the real run did, and pays what that run measured.
    #[must_use]
    pub fn planned_overheads(mut self, overheads: Vec<Option<f64>>) -> Self {
        self.told = Some(overheads);
        self
    }

    /// Each launch waits this long before its first task starts.
    #[must_use]
    pub fn latency(mut self, latency: f64) -> Self {
        self.latency = latency;
        self
    }

    /// Adds a device failure.
    #[must_use]
    pub fn fault(mut self, fault: Fault) -> Self {
        self.faults.push(fault);
        self
    }

    /// Keeps every span, for charts and for comparing with a real run.
    #[must_use]
    pub fn record_timeline(mut self, record: bool) -> Self {
        self.record = record;
        self
    }

    /// Replays `costs`, taking them as both the estimate and the truth.
    pub fn run(&self, costs: &Costs) -> Result<SimReport, SchedError> {
        self.run_actual(costs, costs)
    }

    /// Tasks that live on one device each: the policy weighs their moves (see
    /// [`Policy::dispatcher_homed`]), and in [`Simulation::run`] and
    /// [`Simulation::run_actual`] a task away from home takes its move's time more.
    pub fn homes(mut self, homes: Homes) -> Self {
        self.homes = Some(homes);
        self
    }

    /// Plans with `estimated` costs and advances time with `actual` ones.
    pub fn run_actual(&self, estimated: &Costs, actual: &Costs) -> Result<SimReport, SchedError> {
        if actual.len() != estimated.len() {
            return Err(SchedError::LengthMismatch {
                what: "actual costs for the estimated tasks",
                expected: estimated.len(),
                got: actual.len(),
            });
        }
        let speeds = &self.speeds;
        let homes = self.homes.as_ref();
        self.run_timed(estimated, &|t, d| {
            actual[t] / speeds[d] + homes.map_or(0.0, |h| h.extra(t, d))
        })
    }

    /// Plans with `estimated` costs; task `t` takes `seconds(t, d)` on device `d`. A replay
    /// of a measured run gives each task its measured time on the device it ran on (see
    /// [`crate::MeasuredRun`]).
    pub fn run_timed(
        &self,
        estimated: &Costs,
        seconds: &dyn Fn(usize, usize) -> f64,
    ) -> Result<SimReport, SchedError> {
        let m = self.speeds.len();
        let latencies = self
            .latencies
            .clone()
            .unwrap_or_else(|| vec![self.latency; m]);
        if latencies.len() != m {
            return Err(SchedError::LengthMismatch {
                what: "one latency per device",
                expected: m,
                got: latencies.len(),
            });
        }
        if let Some(&value) = latencies.iter().find(|l| !(l.is_finite() && **l >= 0.0)) {
            return Err(SchedError::BadLatency { value });
        }
        let told = self
            .told
            .clone()
            .unwrap_or_else(|| latencies.iter().map(|&l| Some(l)).collect());
        if told.len() != m {
            return Err(SchedError::LengthMismatch {
                what: "one planned overhead per device",
                expected: m,
                got: told.len(),
            });
        }
        let n = estimated.len();
        let mut fault_at = vec![f64::INFINITY; m];
        for f in &self.faults {
            if f.device >= m {
                return Err(SchedError::BadFault {
                    device: f.device,
                    devices: m,
                });
            }
            fault_at[f.device] = fault_at[f.device].min(f.at.max(0.0));
        }

        let planning = std::time::Instant::now();
        let mut dispatch = match &self.homes {
            Some(homes) => self
                .policy
                .dispatcher_homed(estimated, &self.speeds, &told, homes)?,
            None => self
                .policy
                .dispatcher_with_overheads(estimated, &self.speeds, &told),
        };
        let plan_seconds = planning.elapsed().as_secs_f64();
        let mut events: BinaryHeap<Reverse<(Load, Kind, u32)>> = (0..m as u32)
            .map(|d| Reverse((Load::ZERO, Kind::Ready, d)))
            .collect();
        for (d, &at) in fault_at.iter().enumerate() {
            if at.is_finite() {
                events.push(Reverse((Load::new(at), Kind::Fault, d as u32)));
            }
        }

        let mut assignment = vec![u32::MAX; n];
        let mut delivered = 0usize;
        let mut busy = vec![Load::ZERO; m];
        let mut makespan = Load::ZERO;
        let mut launches = vec![0u64; m];
        let mut reruns = 0u64;
        let mut dead = vec![false; m];
        let mut undone: Vec<Vec<u32>> = vec![Vec::new(); m];
        let mut waiting: Vec<u32> = Vec::new();
        let mut failures = Vec::new();
        let mut spans = Vec::new();
        let mut launch = Vec::new();

        while let Some(Reverse((now, kind, d))) = events.pop() {
            let du = d as usize;
            if dead[du] {
                continue;
            }
            if kind == Kind::Fault {
                dead[du] = true;
                reruns += undone[du].len() as u64;
                failures.push(DeviceFailure {
                    device: du,
                    name: format!("simulated device {du}"),
                    reason: format!("fault at {}", now.value()),
                    orphaned: undone[du].len(),
                });
                dispatch.fail(du, &undone[du]);
                for w in waiting.drain(..) {
                    events.push(Reverse((now, Kind::Ready, w)));
                }
                continue;
            }
            if delivered == n {
                continue;
            }
            launch.clear();
            dispatch.next(du, now.value(), &mut launch);
            if launch.is_empty() {
                waiting.push(d);
                continue;
            }
            launches[du] += 1;
            let mut clock = now.plus(latencies[du]);
            for (k, &t) in launch.iter().enumerate() {
                let took = seconds(t as usize, du);
                let end = clock.plus(took);
                if end.value() > fault_at[du] {
                    // Cut short: work up to the fault was spent, the rest waits for the fault
                    // event, which releases it at the right moment.
                    busy[du] = busy[du].plus((fault_at[du] - clock.value()).max(0.0));
                    undone[du] = launch[k..].to_vec();
                    break;
                }
                busy[du] = busy[du].plus(took);
                assignment[t as usize] = d;
                delivered += 1;
                if self.record {
                    spans.push(Span {
                        device: d,
                        task: t,
                        start: clock.value(),
                        end: end.value(),
                        device_seconds: None,
                    });
                }
                clock = end;
            }
            makespan = makespan.max(clock);
            if undone[du].is_empty() {
                events.push(Reverse((clock, Kind::Ready, d)));
            }
        }

        if delivered < n {
            return Err(SchedError::AllDevicesFailed {
                devices: m,
                tasks: n,
                unfinished: n - delivered,
                failures,
            });
        }
        Ok(SimReport {
            metrics: Metrics::new(makespan.value(), busy.iter().map(|b| b.value()).collect()),
            assignment,
            launches,
            reruns,
            plan_seconds,
            timeline: self.record.then_some(Timeline { devices: m, spans }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn costs(c: &[f64]) -> Costs {
        Costs::new(c.to_vec()).unwrap()
    }

    #[test]
    fn queue_pays_latency_per_task_static_per_device() {
        let c = costs(&[1.0; 8]);
        let speeds = Speeds::identical(2).unwrap();
        let st = Simulation::new(Policy::StaticEqual, speeds.clone())
            .latency(0.5)
            .run(&c)
            .unwrap();
        let q = Simulation::new(Policy::QueueFifo, speeds)
            .latency(0.5)
            .run(&c)
            .unwrap();
        assert_eq!(st.metrics.makespan, 4.5);
        assert_eq!(q.metrics.makespan, 6.0);
        assert_eq!(st.launches, vec![1, 1]);
        assert_eq!(q.launches, vec![4, 4]);
    }

    #[test]
    fn a_fault_reruns_the_lost_work_elsewhere() {
        let c = costs(&[2.0, 2.0, 2.0, 2.0]);
        let sim = Simulation::new(Policy::StaticEqual, Speeds::identical(2).unwrap())
            .fault(Fault { device: 1, at: 1.0 })
            .record_timeline(true)
            .run(&c)
            .unwrap();
        assert_eq!(sim.assignment, vec![0, 0, 0, 0]);
        assert_eq!(sim.reruns, 2);
        assert_eq!(sim.metrics.makespan, 8.0);
        assert_eq!(sim.timeline.unwrap().spans.len(), 4);
    }

    #[test]
    fn all_devices_failing_is_an_error_not_a_hang() {
        for policy in Policy::ALL {
            let err = Simulation::new(policy, Speeds::identical(2).unwrap())
                .fault(Fault { device: 0, at: 0.5 })
                .fault(Fault { device: 1, at: 1.5 })
                .run(&costs(&[1.0; 10]))
                .unwrap_err();
            assert!(
                matches!(err, SchedError::AllDevicesFailed { unfinished, .. } if unfinished > 0)
            );
        }
    }

    #[test]
    fn zero_tasks_and_more_devices_than_tasks() {
        for policy in Policy::ALL {
            let sim = Simulation::new(policy, Speeds::identical(4).unwrap());
            assert_eq!(sim.run(&costs(&[])).unwrap().metrics.makespan, 0.0);
            let r = sim.run(&costs(&[5.0, 1.0])).unwrap();
            assert_eq!(r.metrics.makespan, 5.0, "{policy}");
        }
    }
}
