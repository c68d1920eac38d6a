//! `mpirun -np N cobalt bench --mpi`: the thesis's comparison where dispatch latency is
//! highest, between nodes. Every rank is a node with the `--devices` of its own. For each
//! workload, task size and policy, the ranks render together and rank 0 reports the rendering
//! rate, the balance and the time it spent in MPI calls. Every other rank is a path device of
//! rank 0's renderer ([`RankPaths`]) and keeps its paths: task ranges go out, values come
//! back. Then rank 0 measures the tasks of a single-node render and replays them in `sched`'s
//! simulator on 16 and 64 nodes behind the latencies measured between the ranks.
//!
//! [`RankPaths`]: crate::distributed::RankPaths

use std::num::NonZeroUsize;
use std::time::Instant;

use sched::mpi::Cluster;
use sched::{Costs, Policy, Simulation, Speeds};
use serde::Serialize;

use super::error::BenchError;
use super::matrix::{Replay, Workload};
use super::paths::replay_frame;
use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::cost::SampleRate;
use crate::devices::DeviceSpec;
use crate::distributed::render_over_ranks;
use crate::paths::{Mode, PathRenderer, Settings, build_path_devices};
use crate::scene::Scene;
use crate::shade::RenderOptions;

/// Node counts of the simulated clusters.
pub const SIMULATED_NODES: [usize; 2] = [16, 64];

/// Round trips timed for the latency.
const PINGS: usize = 200;

/// What to run on one scene over the ranks: its workloads, task sizes and policies.
pub struct SceneMatrix<'a> {
    /// The scene as the records name it (`--scene`).
    pub scene_name: &'a str,
    /// The scene, loaded on every rank.
    pub scene: &'a Scene,
    /// The BVH of `scene`.
    pub bvh: &'a Bvh,
    /// This rank's devices.
    pub devices: &'a [DeviceSpec],
    /// The devices as the records list them (`--devices`).
    pub device_list: &'a str,
    /// The workloads rendered.
    pub workloads: &'a [Workload],
    /// Paths per task, each a run of every workload.
    pub task_sizes: &'a [NonZeroUsize],
    /// The policies, each in cost mode.
    pub policies: &'a [Policy],
    /// The image width.
    pub width: u32,
    /// The image height.
    pub height: u32,
    /// AO probes per primary hit.
    pub ao_samples: u32,
    /// The share of each task's paths the estimate samples.
    pub sample_rate: SampleRate,
    /// How cost mode counts a sampled path.
    pub walk: crate::traverse::Walk,
}

/// One render over the ranks.
#[derive(Clone, Debug, Serialize)]
pub struct MpiRecord {
    /// Always `mpi`.
    pub source: &'static str,
    /// The scene (`--scene`).
    pub scene: String,
    /// The workload: `whitted` or `ao`.
    pub shader: &'static str,
    /// The policy that planned the run.
    pub policy: &'static str,
    /// Paths (rays) per task.
    pub task_size: usize,
    /// Ranks of the MPI job.
    pub ranks: usize,
    /// Every rank's devices (`--devices`).
    pub devices_per_rank: String,
    /// Rays traced over the frames.
    pub rays: usize,
    /// Wall time of the render: estimate, plan and run.
    pub seconds: f64,
    /// Rays over `seconds`, in millions per second.
    pub mrays_per_s: f64,
    /// Σ busy time / Σ (makespan × executors), over rank 0's devices and the other ranks.
    pub balance_efficiency: f64,
    /// Seconds rank 0 spent inside MPI calls, and their share of `seconds`.
    pub comm_seconds: f64,
    /// `comm_seconds` over `seconds`.
    pub comm_share: f64,
    /// Σ over the other ranks of their round trips' time not spent working.
    pub dispatch_overhead_seconds: f64,
    /// Batches sent to the other ranks.
    pub batches: u64,
}

/// One replay on a simulated cluster.
#[derive(Clone, Debug, Serialize)]
pub struct ClusterSimRecord {
    /// Always `simulated-cluster`.
    pub source: &'static str,
    /// The scene (`--scene`).
    pub scene: String,
    /// The workload: `whitted` or `ao`.
    pub shader: &'static str,
    /// The policy that planned the run.
    pub policy: &'static str,
    /// Paths (rays) per task.
    pub task_size: usize,
    /// Nodes of the simulated cluster.
    pub nodes: usize,
    /// `ping-pong` (MPI's one-way latency between the ranks) or `dispatch` (what a batch's
    /// round trip cost beyond the remote work, measured in the MPI runs).
    pub link: &'static str,
    /// Latency per launch, in seconds.
    pub latency: f64,
    /// Rays traced over the frames.
    pub rays: usize,
    /// Simulated seconds: the makespan, and the estimate split over the nodes.
    pub seconds: f64,
    /// Rays over `seconds`, in millions per second.
    pub mrays_per_s: f64,
    /// Σ device busy time / Σ (makespan × devices).
    pub balance_efficiency: f64,
    /// Launches over the devices.
    pub launches: u64,
}

impl SceneMatrix<'_> {
    fn settings(&self, policy: Policy, task_size: NonZeroUsize) -> Settings {
        Settings {
            policy,
            mode: Mode::Cost,
            task_size,
            sample_rate: self.sample_rate,
            walk: self.walk,
        }
    }

    fn options(&self, w: Workload) -> RenderOptions {
        let camera = Camera::orbit(&self.scene.bounds(), 0);
        RenderOptions::new(self.width, self.height, camera, w.shader(self.ao_samples))
    }

    /// The tasks of a frame on this rank's devices alone.
    fn single_node(&self, w: Workload, settings: Settings) -> Result<Replay, BenchError> {
        let options = self.options(w);
        let devices = build_path_devices(self.scene, self.bvh, self.devices, &[])?;
        let frame = PathRenderer::new(devices, settings)?.render(self.scene, self.bvh, &options)?;
        Ok(replay_frame(&frame.stats))
    }

    /// Every rank: renders each (workload, task size, policy) together; rank 0 gets the
    /// records, the others an empty list.
    pub fn run(&self, cluster: &Cluster) -> Result<Vec<MpiRecord>, BenchError> {
        let mut out = Vec::new();
        // Untimed warm-up: page in the scene, the BVH and the thread pools on every rank.
        if let Some(&w) = self.workloads.first() {
            self.render_once(
                cluster,
                w,
                self.settings(Policy::StaticLpt, Settings::DEFAULT_TASK_SIZE),
            )?;
        }
        for &w in self.workloads {
            for &task_size in self.task_sizes {
                for &policy in self.policies {
                    let settings = self.settings(policy, task_size);
                    let links_before: Vec<_> = cluster.links();
                    let comm_before = cluster.comm_seconds();
                    let (rays, seconds, balance) = self.render_once(cluster, w, settings)?;
                    if !cluster.is_root() {
                        continue;
                    }
                    let comm_seconds = cluster.comm_seconds() - comm_before;
                    let links = cluster.links();
                    let (mut overhead, mut batches) = (0.0, 0);
                    for (after, before) in links.iter().zip(&links_before) {
                        overhead += after.overhead_seconds() - before.overhead_seconds();
                        batches += after.batches - before.batches;
                    }
                    out.push(MpiRecord {
                        source: "mpi",
                        scene: self.scene_name.to_string(),
                        shader: w.name(),
                        policy: policy.name(),
                        task_size: task_size.get(),
                        ranks: cluster.size(),
                        devices_per_rank: self.device_list.to_string(),
                        rays,
                        seconds,
                        mrays_per_s: rays as f64 / seconds.max(1e-12) / 1e6,
                        balance_efficiency: balance,
                        comm_seconds,
                        comm_share: comm_seconds / seconds.max(1e-12),
                        dispatch_overhead_seconds: overhead,
                        batches,
                    });
                }
            }
        }
        Ok(out)
    }

    /// Every rank renders once over the cluster; returns rays, wall seconds and the balance
    /// (meaningful on rank 0). On rank 0 the other ranks are path devices beside its own; they
    /// render the task ranges they are sent until rank 0 ends the frame.
    fn render_once(
        &self,
        cluster: &Cluster,
        w: Workload,
        settings: Settings,
    ) -> Result<(usize, f64, f64), BenchError> {
        let local = build_path_devices(self.scene, self.bvh, self.devices, &[]);
        // Also the start line: every rank begins the render together.
        let devices = cluster.agree("opening this rank's devices", local)?;
        let options = self.options(w);
        let start = Instant::now();
        let rendered =
            render_over_ranks(cluster, devices, settings, self.scene, self.bvh, &options)?;
        Ok(rendered.map_or((0, 0.0, 1.0), |frame| {
            (
                frame.stats.rays,
                start.elapsed().as_secs_f64(),
                frame.stats.balance_efficiency,
            )
        }))
    }

    /// Rank 0 alone: the tasks of a single-node, cost-based render on this rank's devices
    /// under a queue (one task a launch, so each task's time is its own; see
    /// `replay_policy` in `matrix.rs`), replayed on 16 and 64 simulated nodes of equal speed
    /// behind each of `links`, with each policy planning from the same estimates.
    pub fn simulate(
        &self,
        links: &[(&'static str, f64)],
    ) -> Result<Vec<ClusterSimRecord>, BenchError> {
        let mut out = Vec::new();
        for &w in self.workloads {
            for &task_size in self.task_sizes {
                let settings = self.settings(Policy::QueueSorted, task_size);
                let frame = self.single_node(w, settings)?;
                for (nodes, &(link, latency)) in SIMULATED_NODES
                    .into_iter()
                    .flat_map(|n| links.iter().map(move |l| (n, l)))
                {
                    let speeds = Speeds::new(vec![1.0; nodes])?;
                    for &policy in self.policies {
                        let actual = Costs::new(frame.seconds.clone())?;
                        let plan = Costs::new(frame.estimated.clone())?;
                        let r = Simulation::new(policy, speeds.clone())
                            .latency(latency)
                            .run_actual(&plan, &actual)?;
                        // The estimate is paid once per frame, split over the nodes.
                        let seconds = r.metrics.makespan + frame.estimate_seconds / nodes as f64;
                        let busy = r.metrics.busy.iter().sum::<f64>();
                        let capacity = r.metrics.makespan * nodes as f64;
                        let (rays, launches) = (frame.rays, r.launches.iter().sum::<u64>());
                        out.push(ClusterSimRecord {
                            source: "simulated-cluster",
                            scene: self.scene_name.to_string(),
                            shader: w.name(),
                            policy: policy.name(),
                            task_size: task_size.get(),
                            nodes,
                            link,
                            latency,
                            rays,
                            seconds,
                            mrays_per_s: rays as f64 / seconds.max(1e-12) / 1e6,
                            balance_efficiency: if capacity > 0.0 { busy / capacity } else { 1.0 },
                            launches,
                        });
                    }
                }
            }
        }
        Ok(out)
    }
}

/// What rank 0 measured over the ranks: the one-way latency, the renders over the ranks and
/// their replays on simulated clusters.
#[derive(Clone, Debug)]
pub struct MpiBench {
    /// The ranks.
    pub ranks: usize,
    /// Every rank's devices (`--devices`).
    pub device_list: String,
    /// The slowest rank's one-way latency: the median of its ping-pongs, in seconds.
    pub latency: f64,
    /// One record per render over the ranks.
    pub records: Vec<MpiRecord>,
    /// One record per replay on a simulated cluster.
    pub sims: Vec<ClusterSimRecord>,
}

/// Runs the whole MPI bench on every rank; rank 0 returns what it measured, the other ranks
/// `None`.
pub fn bench(
    cluster: &Cluster,
    matrices: &[SceneMatrix<'_>],
) -> Result<Option<MpiBench>, BenchError> {
    let latencies = cluster.latency(PINGS);
    // The slowest link is the one a queue waits on.
    let latency = latencies.iter().copied().fold(0.0, f64::max);
    let mut records = Vec::new();
    let mut sims = Vec::new();
    for matrix in matrices {
        let runs = matrix.run(cluster)?;
        // What a batch really cost beyond its work, over every run so far: the latency of
        // this implementation's dispatch, polling and (de)serialising included.
        let batches: u64 = runs.iter().map(|r| r.batches).sum();
        let overhead: f64 = runs.iter().map(|r| r.dispatch_overhead_seconds).sum();
        let dispatch = if batches > 0 {
            overhead / batches as f64
        } else {
            latency
        };
        records.extend(runs);
        // Rank 0 measures alone; the others sleep until it is done.
        let simulated = if cluster.is_root() {
            matrix.simulate(&[("ping-pong", latency), ("dispatch", dispatch)])
        } else {
            Ok(Vec::new())
        };
        cluster.hold();
        sims.extend(cluster.agree("simulating", simulated)?);
    }
    Ok(cluster.is_root().then(|| MpiBench {
        ranks: cluster.size(),
        device_list: matrices.first().map_or("", |p| p.device_list).to_string(),
        latency,
        records,
        sims,
    }))
}

impl MpiBench {
    /// The report's tables: the renders over the ranks, then the simulated clusters.
    pub fn table(&self) -> String {
        let mut text = format!(
            "Over MPI: {} rank(s), devices per rank {}, one-way latency {:.1} µs (median of {PINGS} ping-pongs, slowest rank)\n\n",
            self.ranks,
            self.device_list,
            self.latency * 1e6,
        );
        text += "| scene | shader | task size | policy | MRays/s | balance | MPI s | MPI share | dispatch overhead s | batches |\n";
        text += "|---|---|---:|---|---:|---:|---:|---:|---:|---:|\n";
        for r in &self.records {
            text += &format!(
                "| {} | {} | {} | {} | {:.3} | {:.1} % | {:.3} | {:.1} % | {:.4} | {} |\n",
                r.scene,
                r.shader,
                r.task_size,
                r.policy,
                r.mrays_per_s,
                100.0 * r.balance_efficiency,
                r.comm_seconds,
                100.0 * r.comm_share,
                r.dispatch_overhead_seconds,
                r.batches,
            );
        }
        text += "\nSimulated clusters of equal nodes, replaying a single-node render's tasks behind the measured latencies (ping-pong: MPI's one-way latency; dispatch: a batch's measured round trip beyond its work):\n\n";
        text += "| scene | shader | task size | nodes | link | latency µs | policy | MRays/s | balance | launches |\n";
        text += "|---|---|---:|---:|---|---:|---|---:|---:|---:|\n";
        for r in &self.sims {
            text += &format!(
                "| {} | {} | {} | {} | {} | {:.1} | {} | {:.3} | {:.1} % | {} |\n",
                r.scene,
                r.shader,
                r.task_size,
                r.nodes,
                r.link,
                r.latency * 1e6,
                r.policy,
                r.mrays_per_s,
                100.0 * r.balance_efficiency,
                r.launches,
            );
        }
        text
    }
}
