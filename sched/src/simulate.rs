use std::cmp::Reverse;
use std::collections::{BinaryHeap, VecDeque};

use crate::backup::{Backup, Backups, Held};
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
    backups: bool,
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
    /// Backup copies launched (see [`Simulation::backups`]).
    pub copies: u64,
    /// Time devices spent on copies whose output was dropped because another copy's came
    /// first: not counted in the busy time.
    pub wasted: f64,
    /// Wall time the policy took to plan (build its dispatcher), in real seconds.
    pub plan_seconds: f64,
    /// Every delivered task, if recording was asked for.
    pub timeline: Option<Timeline>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    // At equal times a task that ends is delivered first, then a fault: a device that fails
    // at t delivers what ends at t, and does not start anything at t.
    End,
    Fault,
    Ready,
}

/// A simulated device: the launch it runs and the task it runs now.
#[derive(Debug, Default)]
struct Device {
    /// The rest of its launch, after the task it runs now.
    queue: VecDeque<u32>,
    /// The task it runs now, with its start and end.
    head: Option<(u32, Load, Load)>,
    /// Whether its launch is of backup copies.
    copy: bool,
    /// Counts the heads it started, so that the end event of one that was cut is ignored.
    generation: u64,
    dead: bool,
    waiting: bool,
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
            backups: true,
        }
    }

    /// Whether an idle device may run backup copies of tasks other devices hold (on by
    /// default), as [`crate::Runtime::backups`]: the same rule decides, from the estimated
    /// costs, the speeds and the latencies the policy is told. A copy's output or the
    /// original's, whichever ends first, is delivered; the other run stops there.
    #[must_use]
    pub fn backups(mut self, on: bool) -> Self {
        self.backups = on;
        self
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
        let backups = self.backups.then(|| {
            Backups::new(
                estimated,
                self.speeds.as_slice(),
                &told,
                self.homes.as_ref(),
            )
        });
        let plan_seconds = planning.elapsed().as_secs_f64();

        let mut run = Run {
            events: (0..m as u32)
                .map(|d| Reverse((Load::ZERO, Kind::Ready, d, 0)))
                .collect(),
            devices: (0..m).map(|_| Device::default()).collect(),
            assignment: vec![u32::MAX; n],
            delivered: 0,
            busy: vec![Load::ZERO; m],
            wasted: Load::ZERO,
            makespan: Load::ZERO,
            spans: Vec::new(),
            record: self.record,
            fault_at,
            seconds,
        };
        for (d, &at) in run.fault_at.iter().enumerate() {
            if at.is_finite() {
                run.events
                    .push(Reverse((Load::new(at), Kind::Fault, d as u32, 0)));
            }
        }
        let mut launches = vec![0u64; m];
        let mut reruns = 0u64;
        let mut copies = 0u64;
        let mut failures = Vec::new();
        let mut launch = Vec::new();

        while let Some(Reverse((now, kind, d, generation))) = run.events.pop() {
            let du = d as usize;
            if run.devices[du].dead {
                continue;
            }
            match kind {
                Kind::End => {
                    if run.devices[du].generation == generation {
                        run.end_head(du, now);
                    }
                }
                Kind::Fault => {
                    let dev = &mut run.devices[du];
                    dev.dead = true;
                    let mut undone: Vec<u32> = Vec::new();
                    if let Some((t, start, _)) = dev.head.take() {
                        // Work up to the fault was spent.
                        run.busy[du] = run.busy[du].plus((now.value() - start.value()).max(0.0));
                        undone.push(t);
                    }
                    undone.extend(dev.queue.drain(..));
                    // A copy's tasks are still held by the devices they were copied from.
                    if dev.copy {
                        undone.clear();
                    }
                    undone.retain(|&t| run.assignment[t as usize] == u32::MAX);
                    reruns += undone.len() as u64;
                    failures.push(DeviceFailure {
                        device: du,
                        name: format!("simulated device {du}"),
                        reason: format!("fault at {}", now.value()),
                        orphaned: undone.len(),
                    });
                    dispatch.fail(du, &undone);
                    run.wake_waiting(now);
                }
                Kind::Ready => {
                    let dev = &mut run.devices[du];
                    if dev.head.is_some() || run.delivered == n {
                        continue;
                    }
                    dev.waiting = false;
                    launch.clear();
                    dispatch.next(du, now.value(), &mut launch);
                    let mut copy = false;
                    if launch.is_empty() {
                        let Some(backups) = &backups else {
                            run.devices[du].waiting = true;
                            continue;
                        };
                        match run.choose(backups, du, now) {
                            Backup::Copy(tasks) => {
                                launch = tasks;
                                copy = true;
                                copies += launch.len() as u64;
                            }
                            Backup::Wait(at) => {
                                run.devices[du].waiting = true;
                                if let Some(at) = at {
                                    run.events.push(Reverse((Load::new(at), Kind::Ready, d, 0)));
                                }
                                continue;
                            }
                        }
                    }
                    launches[du] += 1;
                    let dev = &mut run.devices[du];
                    dev.copy = copy;
                    dev.queue.extend(launch.iter().copied());
                    run.start_next(du, now.plus(latencies[du]));
                    if backups.is_some() {
                        // Devices waiting for work weigh copies of what this launch holds.
                        run.wake_waiting(now);
                    }
                }
            }
        }

        let delivered = run.delivered;
        if delivered < n {
            return Err(SchedError::AllDevicesFailed {
                devices: m,
                tasks: n,
                unfinished: n - delivered,
                failures,
            });
        }
        Ok(SimReport {
            metrics: Metrics::new(
                run.makespan.value(),
                run.busy.iter().map(|b| b.value()).collect(),
            ),
            assignment: run.assignment,
            launches,
            reruns,
            copies,
            wasted: run.wasted.value(),
            plan_seconds,
            timeline: self.record.then_some(Timeline {
                devices: m,
                spans: run.spans,
            }),
        })
    }
}

type Event = Reverse<(Load, Kind, u32, u64)>;

/// The state of one simulated run.
struct Run<'s> {
    events: BinaryHeap<Event>,
    devices: Vec<Device>,
    assignment: Vec<u32>,
    delivered: usize,
    busy: Vec<Load>,
    wasted: Load,
    makespan: Load,
    spans: Vec<Span>,
    record: bool,
    fault_at: Vec<f64>,
    seconds: &'s dyn Fn(usize, usize) -> f64,
}

impl Run<'_> {
    fn is_done(&self, t: u32) -> bool {
        self.assignment[t as usize] != u32::MAX
    }

    /// Device `d` starts the next task of its launch not yet delivered, at `at`, or, with
    /// none left, asks for work then.
    fn start_next(&mut self, d: usize, at: Load) {
        let dev = &mut self.devices[d];
        dev.generation += 1;
        dev.head = None;
        while let Some(t) = dev.queue.pop_front() {
            if self.assignment[t as usize] != u32::MAX {
                continue;
            }
            let end = at.plus((self.seconds)(t as usize, d));
            dev.head = Some((t, at, end));
            // A task that would end after the device's fault never ends: the fault cuts it.
            // (A time that overflowed still ends, so that the caller sees it.)
            if end.value() <= self.fault_at[d] || end.value().is_nan() {
                self.events
                    .push(Reverse((end, Kind::End, d as u32, dev.generation)));
            }
            return;
        }
        self.events.push(Reverse((at, Kind::Ready, d as u32, 0)));
    }

    /// Device `d`'s running task ends at `now`: delivered, unless another copy was first,
    /// and every other copy of it stops.
    fn end_head(&mut self, d: usize, now: Load) {
        let Some((t, start, end)) = self.devices[d].head else {
            return;
        };
        let took = end.value() - start.value();
        self.busy[d] = self.busy[d].plus(took);
        self.assignment[t as usize] = d as u32;
        self.delivered += 1;
        self.makespan = self.makespan.max(now);
        if self.record {
            self.spans.push(Span {
                device: d as u32,
                task: t,
                start: start.value(),
                end: end.value(),
                device_seconds: None,
            });
        }
        self.start_next(d, now);
        for e in 0..self.devices.len() {
            if let Some((u, from, _)) = self.devices[e].head
                && u == t
                && !self.devices[e].dead
            {
                self.wasted = self.wasted.plus((now.value() - from.value()).max(0.0));
                self.start_next(e, now.max(from));
            }
        }
    }

    /// Devices that found nothing to do ask again now.
    fn wake_waiting(&mut self, now: Load) {
        for (d, dev) in self.devices.iter_mut().enumerate() {
            if dev.waiting && !dev.dead {
                dev.waiting = false;
                self.events.push(Reverse((now, Kind::Ready, d as u32, 0)));
            }
        }
    }

    /// What the backup rule says idle device `d` should do at `now`.
    fn choose(&self, backups: &Backups<'_>, d: usize, now: Load) -> Backup {
        let rests: Vec<(usize, Vec<u32>, f64)> = self
            .devices
            .iter()
            .enumerate()
            .filter(|(_, dev)| !dev.dead)
            .filter_map(|(e, dev)| {
                let (head, start, _) = dev.head?;
                let tasks = std::iter::once(head).chain(dev.queue.iter().copied());
                Some((e, tasks.collect(), start.value()))
            })
            .collect();
        let held: Vec<Held<'_>> = rests
            .iter()
            .map(|(e, tasks, start)| Held {
                device: *e,
                tasks,
                head_started: *start,
            })
            .collect();
        backups.choose(d, now.value(), &held, &|t| self.is_done(t))
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
