//! `mpirun -np N cobalt bench --mpi`: the thesis's comparison where dispatch latency is
//! highest, between nodes. Every rank is a node with the `--devices` of its own. The matrix
//! ([`SceneMatrix::run`], given the job in [`SceneMatrix::cluster`]) renders each cell over
//! the ranks: every other rank is a path device of rank 0's renderer ([`RankPaths`]) and keeps
//! its paths: task ranges go out, values come back. Rank 0's records add the time it spent in
//! MPI calls and what the batches cost beyond their work. Then rank 0 measures the tasks of a
//! single-node render and replays them in `sched`'s simulator on 16 and 64 nodes behind the
//! latencies measured between the ranks.
//!
//! [`RankPaths`]: crate::distributed::RankPaths

use sched::Policy;
use sched::mpi::Cluster;

use super::error::BenchError;
use super::matrix::{CellRun, SceneMatrix};
use super::record::{MpiFigures, Record};
use super::simulate::{Fleet, Machines, SimRecord, simulate};
use crate::distributed::render_over_ranks;
use crate::paths::{Frame, Mode, Settings, build_path_devices};

/// Node counts of the simulated clusters.
pub const SIMULATED_NODES: [usize; 2] = [16, 64];

/// Round trips timed for the latency.
const PINGS: usize = 200;

impl SceneMatrix<'_> {
    /// One run of a cell over the ranks: every rank opens its devices anew for each camera,
    /// and rank 0 renders the frame with every other rank as one more path device, which
    /// renders the task ranges it is sent until rank 0 ends the frame. Rank 0's record adds
    /// the MPI figures; the other ranks' records are empty.
    pub(super) fn run_over_ranks(
        &self,
        cluster: &Cluster,
        w: crate::shade::Shader,
        settings: Settings,
    ) -> Result<CellRun, BenchError> {
        let links_before = cluster.links();
        let comm_before = cluster.comm_seconds();
        let mut frames = Vec::with_capacity(self.cameras);
        for cam in 0..self.cameras {
            let local = build_path_devices(self.scene, self.bvh, self.devices, &[], &[]);
            // Also the start line: every rank begins the frame together.
            let devices = cluster.agree("opening this rank's devices", local)?;
            let options = self.options(w, cam);
            let frame = Frame {
                scene: self.scene,
                bvh: self.bvh,
                options: &options,
            };
            let rendered = render_over_ranks(cluster, devices, settings, &frame, |mut r| {
                r.render(self.scene, self.bvh, &options)
            })
            .map_err(|e| self.failed(e))?;
            frames.extend(rendered.map(|frame| frame.stats));
        }
        let mut record = self.frames_record(w, settings, &frames);
        record.source = "mpi";
        let comm_seconds = cluster.comm_seconds() - comm_before;
        let (mut overhead, mut batches) = (0.0, 0);
        for (after, before) in cluster.links().iter().zip(&links_before) {
            overhead += after.overhead_seconds() - before.overhead_seconds();
            batches += after.batches - before.batches;
        }
        record.mpi = Some(MpiFigures {
            ranks: cluster.size(),
            comm_seconds,
            comm_share: comm_seconds / record.seconds.max(1e-12),
            dispatch_overhead_seconds: overhead,
            batches,
        });
        Ok(CellRun {
            record,
            frames,
            error: None,
        })
    }

    /// Rank 0 alone: the tasks of a single-node, cost-based render on this rank's devices
    /// under a queue (one task a launch, so each task's time is its own; see
    /// `replay_policy` in `matrix.rs`), replayed on 16 and 64 simulated nodes of equal speed
    /// behind each of `links`, with each policy planning from the same estimates.
    fn simulate_nodes(&self, links: &[(&'static str, f64)]) -> Result<Vec<SimRecord>, BenchError> {
        let alone = SceneMatrix {
            policies: &[Policy::QueueSorted],
            modes: &[Mode::Cost],
            calibration: None,
            path_devices: Default::default(),
            cluster: None,
            ..*self
        };
        let (_, replays) = alone.run(|_| {})?;
        let machines = Machines {
            source: "simulated-cluster",
            fleet: Fleet::Simulated {
                counts: &SIMULATED_NODES,
                speeds: |nodes| vec![1.0; nodes],
                links,
            },
            policies: self.policies,
            modes: &[Mode::Cost],
            spread_estimate: true,
        };
        simulate(self.scene_name, &replays, &machines, None)
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
    /// One record per render over the ranks (`source`: `mpi`).
    pub records: Vec<Record>,
    /// One record per replay on a simulated cluster.
    pub sims: Vec<SimRecord>,
}

/// Runs the whole MPI bench on every rank, each matrix over `cluster` (its
/// [`SceneMatrix::cluster`]); rank 0 returns what it measured, the other ranks `None`.
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
        let (runs, _) = matrix.run(|_| {})?;
        // What a batch really cost beyond its work, over every run so far: the latency of
        // this implementation's dispatch, polling and (de)serialising included.
        let figures = || runs.iter().filter_map(|r| r.mpi);
        let batches: u64 = figures().map(|f| f.batches).sum();
        let overhead: f64 = figures().map(|f| f.dispatch_overhead_seconds).sum();
        let dispatch = if batches > 0 {
            overhead / batches as f64
        } else {
            latency
        };
        records.extend(runs);
        // Rank 0 measures alone; the others sleep until it is done.
        let simulated = if cluster.is_root() {
            matrix.simulate_nodes(&[("ping-pong", latency), ("dispatch", dispatch)])
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
        for (r, m) in self.records.iter().filter_map(|r| Some((r, r.mpi?))) {
            text += &format!(
                "| {} | {} | {} | {} | {:.3} | {:.1} % | {:.3} | {:.1} % | {:.4} | {} |\n",
                r.scene,
                r.shader,
                r.task_size,
                r.policy,
                r.mrays_per_s,
                100.0 * r.balance_efficiency,
                m.comm_seconds,
                100.0 * m.comm_share,
                m.dispatch_overhead_seconds,
                m.batches,
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
                r.devices,
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
