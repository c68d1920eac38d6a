//! `mpirun -np N cobalt bench --mpi`: the thesis's comparison where dispatch latency is
//! highest, between nodes. Every rank is a node with the `--devices` of its own. For each
//! workload, task size and policy, the ranks render together and rank 0 reports the rendering
//! rate, the balance and the time it spent in MPI calls. Every other rank is a path device of
//! rank 0's renderer ([`RankPaths`]) and keeps its paths: task ranges go out, values come
//! back. Then rank 0 measures the tasks of a single-node render and replays them in `sched`'s
//! simulator on 16 and 64 nodes behind the latencies measured between the ranks.
//!
//! [`RankPaths`]: raytrace::distributed::RankPaths

use std::num::NonZeroUsize;
use std::time::Instant;

use raytrace::cost::SampleRate;
use raytrace::devices::DeviceSpec;
use raytrace::distributed::render_over_ranks;
use raytrace::paths::{Mode, PathRenderer, Settings, build_path_devices};
use raytrace::shade::{AoSettings, RenderOptions, Shader, WhittedSettings};
use raytrace::{Bvh, Camera, Scene};
use sched::mpi::Cluster;
use sched::{Costs, Policy, Simulation, Speeds};
use serde::Serialize;

use super::matrix::{Replay, Workload};
use super::paths::replay_frame;
use crate::error::CliError;

/// Node counts of the simulated clusters.
pub const SIMULATED_NODES: [usize; 2] = [16, 64];

/// Round trips timed for the latency.
const PINGS: usize = 200;

/// What to run on one scene over the ranks: its workloads, task sizes and policies.
pub struct SceneMatrix<'a> {
    pub scene_name: &'a str,
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub devices: &'a [DeviceSpec],
    pub device_list: &'a str,
    pub workloads: &'a [Workload],
    pub task_sizes: &'a [usize],
    pub policies: &'a [Policy],
    pub width: u32,
    pub height: u32,
    pub ao_samples: u32,
    pub sample_rate: SampleRate,
    /// How cost mode counts a sampled path.
    pub walk: raytrace::Walk,
}

/// One render over the ranks.
#[derive(Clone, Debug, Serialize)]
pub struct MpiRecord {
    /// Always `mpi`.
    pub source: &'static str,
    pub scene: String,
    pub shader: &'static str,
    pub policy: &'static str,
    pub task_size: usize,
    pub ranks: usize,
    pub devices_per_rank: String,
    pub rays: usize,
    /// Wall time of the render: estimate, plan and run.
    pub seconds: f64,
    pub mrays_per_s: f64,
    /// Σ busy time / Σ (makespan × executors), over rank 0's devices and the other ranks.
    pub balance_efficiency: f64,
    /// Seconds rank 0 spent inside MPI calls, and their share of `seconds`.
    pub comm_seconds: f64,
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
    pub scene: String,
    pub shader: &'static str,
    pub policy: &'static str,
    pub task_size: usize,
    pub nodes: usize,
    /// `ping-pong` (MPI's one-way latency between the ranks) or `dispatch` (what a batch's
    /// round trip cost beyond the remote work, measured in the MPI runs).
    pub link: &'static str,
    /// Latency per launch, in seconds.
    pub latency: f64,
    pub rays: usize,
    pub seconds: f64,
    pub mrays_per_s: f64,
    pub balance_efficiency: f64,
    pub launches: u64,
}

impl SceneMatrix<'_> {
    fn shader(&self, w: Workload) -> Shader {
        match w {
            Workload::Whitted => Shader::Whitted(WhittedSettings::default()),
            Workload::Ao => Shader::Ao(AoSettings {
                samples: self.ao_samples,
                ..Default::default()
            }),
        }
    }

    fn settings(&self, policy: Policy, task_size: usize) -> Settings {
        Settings {
            policy,
            mode: Mode::Cost,
            task_size: NonZeroUsize::new(task_size).unwrap_or(Settings::DEFAULT_TASK_SIZE),
            sample_rate: self.sample_rate,
            walk: self.walk,
        }
    }

    fn options(&self, w: Workload) -> RenderOptions {
        let camera = Camera::orbit(&self.scene.bounds(), 0);
        RenderOptions::new(self.width, self.height, camera, self.shader(w))
    }

    /// The tasks of a frame on this rank's devices alone.
    fn single_node(&self, w: Workload, settings: Settings) -> Result<Replay, CliError> {
        let options = self.options(w);
        let devices = build_path_devices(self.scene, self.bvh, self.devices, &[])?;
        let frame = PathRenderer::new(devices, settings)?.render(self.scene, self.bvh, &options)?;
        Ok(replay_frame(&frame.stats))
    }

    /// Every rank: renders each (workload, task size, policy) together; rank 0 gets the
    /// records, the others an empty list.
    pub fn run(&self, cluster: &Cluster) -> Result<Vec<MpiRecord>, CliError> {
        let mut out = Vec::new();
        // Untimed warm-up: page in the scene, the BVH and the thread pools on every rank.
        if let Some(&w) = self.workloads.first() {
            self.render_once(cluster, w, self.settings(Policy::StaticLpt, 4096))?;
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
                        task_size,
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
    ) -> Result<(usize, f64, f64), CliError> {
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

    /// Rank 0 alone: the tasks of a single-node, cost-based StaticLpt render on this rank's
    /// devices, replayed on 16 and 64 simulated nodes of equal speed behind each of `links`,
    /// with each policy planning from the same estimates.
    pub fn simulate(
        &self,
        links: &[(&'static str, f64)],
    ) -> Result<Vec<ClusterSimRecord>, CliError> {
        let mut out = Vec::new();
        for &w in self.workloads {
            for &task_size in self.task_sizes {
                let settings = self.settings(Policy::StaticLpt, task_size);
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
                            task_size,
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

/// Runs the whole MPI bench on every rank; rank 0 returns the report text and the records
/// as JSON values, the other ranks `None`.
pub fn bench(
    cluster: &Cluster,
    matrices: &[SceneMatrix<'_>],
) -> Result<Option<(String, Vec<serde_json::Value>)>, CliError> {
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
    if !cluster.is_root() {
        return Ok(None);
    }
    let mut text = format!(
        "Over MPI: {} rank(s), devices per rank {}, one-way latency {:.1} µs (median of {PINGS} ping-pongs, slowest rank)\n\n",
        cluster.size(),
        matrices.first().map_or("", |p| p.device_list),
        latency * 1e6,
    );
    text += "| scene | shader | task size | policy | MRays/s | balance | MPI s | MPI share | dispatch overhead s | batches |\n";
    text += "|---|---|---:|---|---:|---:|---:|---:|---:|---:|\n";
    for r in &records {
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
    for r in &sims {
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
    let mut json = Vec::new();
    for r in &records {
        json.push(serde_json::to_value(r).map_err(|e| CliError::Write(e.to_string()))?);
    }
    for r in &sims {
        json.push(serde_json::to_value(r).map_err(|e| CliError::Write(e.to_string()))?);
    }
    Ok(Some((text, json)))
}
