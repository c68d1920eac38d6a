//! `cobalt bench --simulate 2,4,8,64`: the measured tasks of a run replayed in `sched`'s
//! simulator on machines this one is not: more devices, of mixed speeds, behind a PCIe-like or
//! a network-like launch latency. Each frame is planned with the estimates the real run made
//! (cost mode) or with equal costs (regular mode) and advances with the measured task times,
//! one frame after another. `cobalt bench --project gpu:2,gpu:4` replays them alike on
//! machines of identical devices of a class the run measured ([`Projected`]): each task's
//! time scaled to that class's measured rate, each launch delayed by the class's measured
//! launch overhead.

use std::str::FromStr;

use sched::bounds::lower_bound;
use sched::{Costs, Policy, Simulation, Speeds};
use serde::Serialize;

use super::error::BenchError;
use super::matrix::{Replays, ray_kind};
use crate::devices::{DeviceSpec, GpuSelect, parse_devices};
use crate::paths::{FrameStats, Mode, TaskStats};

/// Launch latencies: a kernel launch over PCIe, and a message to another node.
pub const LINKS: [(&str, f64); 2] = [("pcie", 10e-6), ("network", 200e-6)];

/// Most devices of a simulated or projected machine: the simulator plans every task on every
/// device.
pub const MAX_DEVICES: usize = 65536;

/// One simulated run.
#[derive(Clone, Debug, Serialize)]
pub struct SimRecord {
    /// `simulated`, or `simulated-cluster` (`cobalt bench --mpi`).
    pub source: &'static str,
    /// The scene (`--scene`).
    pub scene: String,
    /// The workload: `whitted` or `ao`.
    pub shader: &'static str,
    /// Its rays: `coherent` or `diffuse`.
    pub ray_kind: &'static str,
    /// The policy that planned the run.
    pub policy: &'static str,
    /// `regular` (equal costs) or `cost` (estimates).
    pub mode: &'static str,
    /// Paths (rays) per task.
    pub task_size: usize,
    /// Devices the run used.
    pub devices: usize,
    /// The simulated devices' speeds.
    pub speeds: Vec<f64>,
    /// The link: `pcie` or `network`; projected, `measured` (the class's measured launch
    /// overhead) or `pcie` (where the run measured none); over MPI, `ping-pong` (MPI's one-way latency between the
    /// ranks) or `dispatch` (what a batch's round trip cost beyond the remote work).
    pub link: &'static str,
    /// The projected machine as a device list entry (`gpu:4`; `projected` records only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_list: Option<String>,
    /// Launch latency of the link, in seconds.
    pub latency: f64,
    /// Rays traced over the frames.
    pub rays: usize,
    /// Σ of the frames' simulated makespans; over MPI, with the estimate split over the nodes.
    pub seconds: f64,
    /// Rays over `seconds`, in millions per second.
    pub mrays_per_s: f64,
    /// Σ device busy time / Σ (makespan × devices).
    pub balance_efficiency: f64,
    /// The real run's estimation time (cost mode), which a simulated machine would also pay.
    pub estimate_seconds: f64,
    /// The simulator's planning time.
    pub plan_seconds: f64,
    /// Σ|estimated − full| / Σ full (cost mode).
    pub prediction_error: Option<f64>,
    /// `seconds` over Σ of each frame's lower bound on the optimal makespan (`sched`'s
    /// `lower_bound`: total work over total speed, or more where a few large tasks need the
    /// fastest devices): 1 is an optimal plan with free launches.
    pub makespan_over_bound: f64,
    /// Launches over the devices.
    pub launches: u64,
    /// The simulator's error bar: the median `|simulated / measured − 1|` of its replays of
    /// this scene's measured runs.
    pub replay_error: Option<f64>,
}

/// The machines measured tasks are replayed on: every machine of a fleet, under every policy
/// and mode.
pub struct Machines<'a> {
    /// What the records are: `simulated`, `simulated-cluster` (`cobalt bench --mpi`) or
    /// `projected` (`cobalt bench --project`).
    pub source: &'static str,
    /// The machines.
    pub fleet: Fleet<'a>,
    /// The policies that plan the frames.
    pub policies: &'a [Policy],
    /// Regular (equal costs) or cost (the real run's estimates).
    pub modes: &'a [Mode],
    /// Whether `seconds` includes the real run's estimate split over the devices (nodes of a
    /// cluster each estimating their share), or is the makespans alone.
    pub spread_estimate: bool,
}

/// What machines the measured tasks are replayed on.
pub enum Fleet<'a> {
    /// Machines of each of `counts` devices, of the speeds `speeds` gives so many, behind
    /// every link of `links` (name, launch latency in seconds); the tasks take their measured
    /// times on a device of speed 1.
    Simulated {
        /// Devices of each machine.
        counts: &'a [usize],
        /// The speeds of a machine of so many devices.
        speeds: fn(usize) -> Vec<f64>,
        /// Each link's name and launch latency, in seconds.
        links: &'a [(&'static str, f64)],
    },
    /// Machines of identical devices of one measured class each.
    Projected(&'a [Projected]),
}

impl<'a> Machines<'a> {
    /// `cobalt bench --simulate`: machines of `counts` devices of mixed speeds, behind each
    /// link of `LINKS` (PCIe-like and network-like), under every policy in both modes.
    pub fn mixed(counts: &'a [usize]) -> Self {
        Self {
            source: "simulated",
            fleet: Fleet::Simulated {
                counts,
                // A repeating pattern of slow and fast devices (CPU sockets and GPUs of two
                // generations), so no two neighbours are alike.
                speeds: |m| (0..m).map(|d| [1.0, 4.0, 2.0, 8.0][d % 4]).collect(),
                links: &LINKS,
            },
            policies: &Policy::ALL,
            modes: &Mode::ALL,
            spread_estimate: false,
        }
    }

    /// `cobalt bench --project`: the machines of `projected`, under `policies` in both modes.
    pub fn projected(projected: &'a [Projected], policies: &'a [Policy]) -> Self {
        Self {
            source: "projected",
            fleet: Fleet::Projected(projected),
            policies,
            modes: &Mode::ALL,
            spread_estimate: false,
        }
    }
}

/// A projected machine: `devices` identical devices of a device class the run measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Projected {
    /// `cpu` or `gpu`.
    pub class: &'static str,
    /// Devices of the machine.
    pub devices: usize,
}

impl std::fmt::Display for Projected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.class, self.devices)
    }
}

/// The machines of `cobalt bench --project`, as typed and as parsed.
#[derive(Clone, Debug)]
pub struct Projection {
    /// The list as typed.
    pub list: String,
    /// One machine per entry.
    pub machines: Vec<Projected>,
}

impl FromStr for Projection {
    type Err = crate::Error;

    /// A device list ([`parse_devices`]) whose every entry is a machine: `cpu:N` (or
    /// `cpu:N/T`) is N devices of the measured CPU class, `gpu:N` N devices of the measured
    /// GPU class.
    fn from_str(list: &str) -> Result<Self, crate::Error> {
        let bad = |s: &DeviceSpec, why: &str| crate::Error::DeviceArg {
            arg: s.to_string(),
            why: why.to_string(),
        };
        let machines = parse_devices(list)?
            .iter()
            .map(|s| {
                let p = match *s {
                    DeviceSpec::Cpu { count, .. } => ("cpu", count),
                    DeviceSpec::Gpu(GpuSelect::Index(n)) if n > 0 => ("gpu", n),
                    _ => return Err(bad(s, "a projection counts its GPUs: gpu:N, N > 0")),
                };
                if p.1 > MAX_DEVICES {
                    return Err(bad(s, &format!("at most {MAX_DEVICES} devices")));
                }
                Ok(Projected {
                    class: p.0,
                    devices: p.1,
                })
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            list: list.to_string(),
            machines,
        })
    }
}

impl Projection {
    /// Refuses a projected class that none of the `measured` devices is.
    pub fn check(&self, measured: &[DeviceSpec]) -> Result<(), BenchError> {
        let has = |class| measured.iter().any(|s| spec_class(s) == class);
        match self.machines.iter().find(|p| !has(p.class)) {
            Some(p) => Err(BenchError::Unmeasured(p.class)),
            None => Ok(()),
        }
    }
}

fn spec_class(s: &DeviceSpec) -> &'static str {
    match s {
        DeviceSpec::Cpu { .. } => "cpu",
        DeviceSpec::Gpu(_) => "gpu",
    }
}

/// The class of a measured device, from its name (`cpu0`, `gpu1`).
fn class_of(name: &str) -> &str {
    name.trim_end_matches(|c: char| c.is_ascii_digit())
}

/// One machine of a fleet, as one replay runs on it: projected, with its class's rays per
/// second of work over the workload's replays.
struct Machine {
    speeds: Speeds,
    link: &'static str,
    latency: f64,
    projected: Option<(Projected, f64)>,
}

impl Fleet<'_> {
    /// Every machine `rep` is replayed on, those projected measured over the replays of
    /// `rep`'s workload among `all`.
    fn machines(&self, rep: &Replays, all: &[Replays]) -> Result<Vec<Machine>, BenchError> {
        let mut out = Vec::new();
        match self {
            Fleet::Simulated {
                counts,
                speeds,
                links,
            } => {
                for &m in *counts {
                    for &(link, latency) in *links {
                        let speeds = Speeds::new(speeds(m))?;
                        out.push(Machine {
                            speeds,
                            link,
                            latency,
                            projected: None,
                        });
                    }
                }
            }
            Fleet::Projected(machines) => {
                // A cell may have left a class idle; the workload's other cells measured it.
                let frames = || {
                    (all.iter()
                        .filter(|r| r.workload.name() == rep.workload.name()))
                    .flat_map(|r| &r.frames)
                };
                for &p in *machines {
                    // A class left idle in every cell of the workload has no rate to project
                    // (its machines get no record of it), and the rest of the bench stands.
                    let Some(rate) = mean(frames().flat_map(|f| class_rates(f, p.class))) else {
                        continue;
                    };
                    let mut seen: Vec<f64> = (frames().flat_map(|f| &f.devices))
                        .filter(|d| class_of(&d.name) == p.class)
                        .filter_map(|d| d.launch_overhead)
                        .collect();
                    seen.sort_by(f64::total_cmp);
                    let (link, latency) =
                        (seen.get(seen.len() / 2)).map_or(LINKS[0], |&l| ("measured", l));
                    out.push(Machine {
                        speeds: Speeds::new(vec![1.0; p.devices])?,
                        link,
                        latency,
                        projected: Some((p, rate)),
                    });
                }
            }
        }
        Ok(out)
    }
}

/// A task's time of work: the kernel time the device measured where it did (a launch's
/// overhead is the simulated latency's part), else its measured time.
fn work(t: &TaskStats) -> f64 {
    t.device_seconds.unwrap_or(t.seconds)
}

/// Each device of `f` that worked, with its class and its rays per second of work.
fn device_rates(f: &FrameStats) -> impl Iterator<Item = (usize, &str, f64)> {
    f.devices.iter().filter_map(|d| {
        let tasks = f.task_stats.iter().filter(|t| t.device == d.index);
        let rate = d.rays as f64 / tasks.map(work).sum::<f64>();
        (rate.is_finite() && rate > 0.0).then_some((d.index, class_of(&d.name), rate))
    })
}

/// The rays per second of work of each of `f`'s devices of `class`.
fn class_rates<'f>(f: &'f FrameStats, class: &'f str) -> impl Iterator<Item = f64> + 'f {
    device_rates(f).filter(move |r| r.1 == class).map(|r| r.2)
}

fn mean(xs: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Each task's seconds on the machine: as measured, or projected: its work at the rate of the
/// device that ran it over the projected class's rate (the frame's own devices of the class,
/// else the workload's).
fn task_seconds(f: &FrameStats, projected: Option<(Projected, f64)>) -> Vec<f64> {
    let Some((p, pooled)) = projected else {
        return f.task_stats.iter().map(|t| t.seconds).collect();
    };
    let rate = mean(class_rates(f, p.class)).unwrap_or(pooled);
    let rates: Vec<(usize, &str, f64)> = device_rates(f).collect();
    (f.task_stats.iter())
        .map(|t| {
            let own = rates.iter().find(|r| r.0 == t.device).map_or(rate, |r| r.2);
            work(t) * own / rate
        })
        .collect()
}

/// Replays every (workload, task size) on every machine of `machines`.
pub fn simulate(
    scene: &str,
    replays: &[Replays],
    machines: &Machines<'_>,
    replay_error: Option<f64>,
) -> Result<Vec<SimRecord>, BenchError> {
    let mut out = Vec::new();
    for rep in replays {
        let (w, task_size) = (rep.workload, rep.task_size);
        for machine in machines.fleet.machines(rep, replays)? {
            let (speeds, m) = (&machine.speeds, machine.speeds.len());
            for &policy in machines.policies {
                for &mode in machines.modes {
                    let cost = mode == Mode::Cost;
                    let (mut seconds, mut bound, mut busy, mut capacity) = (0.0, 0.0, 0.0, 0.0);
                    let (mut rays, mut launches) = (0usize, 0u64);
                    let (mut est, mut plan_s) = (0.0, 0.0);
                    for g in &rep.frames {
                        let tasks = &g.task_stats;
                        let actual = Costs::new(task_seconds(g, machine.projected))?;
                        let plan = if cost {
                            Costs::new(tasks.iter().map(|t| t.cost).collect())?
                        } else {
                            Costs::uniform(actual.len())
                        };
                        let r = Simulation::new(policy, speeds.clone())
                            .latency(machine.latency)
                            .run_actual(&plan, &actual)?;
                        seconds += r.metrics.makespan;
                        busy += r.metrics.busy.iter().sum::<f64>();
                        capacity += r.metrics.makespan * m as f64;
                        bound += lower_bound(&actual, speeds);
                        rays += g.rays;
                        launches += r.launches.iter().sum::<u64>();
                        plan_s += r.plan_seconds;
                        if cost {
                            est += g.estimate_seconds;
                        }
                    }
                    if machines.spread_estimate {
                        seconds += est / m as f64;
                    }
                    out.push(SimRecord {
                        source: machines.source,
                        scene: scene.to_string(),
                        shader: w.name(),
                        ray_kind: ray_kind(&w),
                        policy: policy.name(),
                        mode: mode.name(),
                        task_size,
                        devices: m,
                        speeds: speeds.as_slice().to_vec(),
                        link: machine.link,
                        device_list: machine.projected.map(|(p, _)| p.to_string()),
                        latency: machine.latency,
                        rays,
                        seconds,
                        mrays_per_s: rays as f64 / seconds.max(1e-12) / 1e6,
                        balance_efficiency: if capacity > 0.0 { busy / capacity } else { 1.0 },
                        estimate_seconds: est,
                        plan_seconds: plan_s,
                        prediction_error: rep.prediction_error.filter(|_| cost),
                        makespan_over_bound: seconds / bound.max(1e-300),
                        launches,
                        replay_error,
                    });
                }
            }
        }
    }
    Ok(out)
}
