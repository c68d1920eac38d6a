//! `cobalt bench --simulate 2,4,8,64`: the measured tasks of a run replayed in `sched`'s
//! simulator on machines this one is not: more devices, of mixed speeds, behind a PCIe-like or
//! a network-like launch latency. Each frame is planned with the estimates the real run made
//! (cost mode) or with equal costs (regular mode) and advances with the measured task times,
//! one frame after another.

use sched::bounds::lower_bound;
use sched::{Costs, Policy, Simulation, Speeds};
use serde::Serialize;

use super::error::BenchError;
use super::matrix::{Replays, ray_kind};
use crate::paths::Mode;

/// Launch latencies: a kernel launch over PCIe, and a message to another node.
pub const LINKS: [(&str, f64); 2] = [("pcie", 10e-6), ("network", 200e-6)];

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
    /// The link: `pcie` or `network`; over MPI, `ping-pong` (MPI's one-way latency between the
    /// ranks) or `dispatch` (what a batch's round trip cost beyond the remote work).
    pub link: &'static str,
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

/// The machines measured tasks are replayed on: every device count, behind every link, under
/// every policy and mode.
pub struct Machines<'a> {
    /// What the records are: `simulated`, or `simulated-cluster` (`cobalt bench --mpi`).
    pub source: &'static str,
    /// Devices of each machine.
    pub counts: &'a [usize],
    /// The speeds of a machine of so many devices.
    pub speeds: fn(usize) -> Vec<f64>,
    /// Each link's name and launch latency, in seconds.
    pub links: &'a [(&'static str, f64)],
    /// The policies that plan the frames.
    pub policies: &'a [Policy],
    /// Regular (equal costs) or cost (the real run's estimates).
    pub modes: &'a [Mode],
    /// Whether `seconds` includes the real run's estimate split over the devices (nodes of a
    /// cluster each estimating their share), or is the makespans alone.
    pub spread_estimate: bool,
}

impl<'a> Machines<'a> {
    /// `cobalt bench --simulate`: machines of `counts` devices of mixed speeds, behind each
    /// link of `LINKS` (PCIe-like and network-like), under every policy in both modes.
    pub fn mixed(counts: &'a [usize]) -> Self {
        Self {
            source: "simulated",
            counts,
            // A repeating pattern of slow and fast devices (CPU sockets and GPUs of two
            // generations), so no two neighbours are alike.
            speeds: |m| (0..m).map(|d| [1.0, 4.0, 2.0, 8.0][d % 4]).collect(),
            links: &LINKS,
            policies: &Policy::ALL,
            modes: &Mode::ALL,
            spread_estimate: false,
        }
    }
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
        for &m in machines.counts {
            let speeds = Speeds::new((machines.speeds)(m))?;
            for &(link, latency) in machines.links {
                for &policy in machines.policies {
                    for &mode in machines.modes {
                        let cost = mode == Mode::Cost;
                        let (mut seconds, mut bound, mut busy, mut capacity) = (0.0, 0.0, 0.0, 0.0);
                        let (mut rays, mut launches) = (0usize, 0u64);
                        let (mut est, mut plan_s) = (0.0, 0.0);
                        for g in &rep.frames {
                            let tasks = &g.task_stats;
                            let actual = Costs::new(tasks.iter().map(|t| t.seconds).collect())?;
                            let plan = if cost {
                                Costs::new(tasks.iter().map(|t| t.cost).collect())?
                            } else {
                                Costs::uniform(actual.len())
                            };
                            let r = Simulation::new(policy, speeds.clone())
                                .latency(latency)
                                .run_actual(&plan, &actual)?;
                            seconds += r.metrics.makespan;
                            busy += r.metrics.busy.iter().sum::<f64>();
                            capacity += r.metrics.makespan * m as f64;
                            bound += lower_bound(&actual, &speeds);
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
                            link,
                            latency,
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
    }
    Ok(out)
}
