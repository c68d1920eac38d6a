//! The cluster tracer: each generation estimated on all ranks, planned over nodes by rank 0,
//! run on every node's own devices, and broadcast so that every rank shades the same hits.

use std::ops::Range;
use std::time::Instant;

use sched::mpi::{Cluster, RemoteNode, Wire};
use sched::{Costs, DeviceFailure, Executor, Runtime, split_ranges};

use super::node::{LocalNode, batch_work};
use super::{NodeGeneration, NodeRun};
use crate::cost::{ReducedTraversal, Work};
use crate::scheduled::{Mode, ScheduledTracer, Settings};
use crate::shade::Tracer;
use crate::traverse::batch::{any_hits, closest_hits};
use crate::{Bvh, HitBatch, RayBatch, RayKind};

/// A [`Tracer`] over the ranks of an MPI job. See the [module documentation](super).
pub struct ClusterTracer<'a, 'c> {
    cluster: &'c Cluster,
    bvh: &'a Bvh,
    local: ScheduledTracer<'a>,
    settings: Settings,
    /// Relative throughput of each rank (index = rank), measured on earlier generations.
    speeds: Vec<f64>,
    /// Busy seconds behind `speeds`, as in [`ScheduledTracer`].
    evidence: f64,
    retired: Vec<bool>,
    log: Vec<NodeGeneration>,
}

impl<'a, 'c> ClusterTracer<'a, 'c> {
    /// Rays per task of a generation of `rays`: as on one machine, with every rank counted as
    /// a device, so every rank cuts the same tasks.
    fn task_size(&self, rays: usize) -> usize {
        self.settings.task_size_for(rays, self.cluster.size())
    }

    /// A tracer over every rank of `cluster`; `local` is this rank's own devices with the
    /// local policy, and its settings (policy, mode, task size, sample rate) also plan the
    /// nodes. Every rank must build one with the same settings and the same scene.
    pub fn new(cluster: &'c Cluster, bvh: &'a Bvh, local: ScheduledTracer<'a>) -> Self {
        let settings = local.settings();
        Self {
            cluster,
            bvh,
            local,
            settings,
            speeds: vec![1.0; cluster.size()],
            evidence: 0.0,
            retired: vec![false; cluster.size()],
            log: Vec::new(),
        }
    }

    /// Every generation so far (rank 0; empty elsewhere).
    pub fn stats(&self) -> &[NodeGeneration] {
        &self.log
    }

    /// This rank's own scheduled tracer, whose stats are its node's local runs.
    pub fn local(&self) -> &ScheduledTracer<'a> {
        &self.local
    }

    /// Each task's work, estimated on every rank for a slice of the tasks and all-gathered;
    /// `None` in regular mode or if any rank's estimate failed (then every rank plans equal
    /// costs, since every rank sees the same gathered values).
    fn estimate(
        &self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
    ) -> Option<Vec<Work>> {
        if self.settings.mode == Mode::Regular {
            return None;
        }
        let (rank, size) = (self.cluster.rank(), self.cluster.size());
        let mine = &tasks[tasks.len() * rank / size..tasks.len() * (rank + 1) / size];
        let estimator = ReducedTraversal::new(self.bvh, rays, self.settings.sample_rate)
            .with_walk(self.settings.walk.for_kind(kind))
            .with_sample_error(self.settings.sample_error);
        let flat: Vec<f64> = match estimator.try_work(mine) {
            Ok(work) => work
                .iter()
                .flat_map(|w| [w.nodes, w.tris, w.rays])
                .collect(),
            Err(_) => vec![f64::NAN; 3 * mine.len()],
        };
        let all = self.cluster.all_gather_f64(&flat);
        let work: Vec<Work> = all
            .chunks_exact(3)
            .map(|c| Work {
                nodes: c[0],
                tris: c[1],
                rays: c[2],
            })
            .collect();
        let usable = work.len() == tasks.len()
            && work
                .iter()
                .all(|w| w.nodes.is_finite() && w.tris.is_finite() && w.rays.is_finite());
        usable.then_some(work)
    }

    /// Rank 0: plans the tasks over the nodes, runs them and returns the hits in ray order.
    fn lead(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        work: Option<&[Work]>,
        stats: &mut NodeGeneration,
    ) -> HitBatch {
        let costs = work
            .and_then(|w| Costs::new(self.local.cost_model(kind).costs(w)).ok())
            .unwrap_or_else(|| Costs::uniform(tasks.len()));
        let active: Vec<usize> = (0..self.cluster.size())
            .filter(|&r| !self.retired[r])
            .collect();
        let task_size = self.task_size(rays.len());
        let result = {
            let mut nodes: Vec<Box<dyn Executor<Range<usize>, Output = HitBatch> + '_>> =
                Vec::with_capacity(active.len());
            let mut local = Some(&mut self.local);
            for &rank in &active {
                let speed = self.speeds[rank];
                if rank == 0
                    && let Some(tracer) = local.take()
                {
                    nodes.push(Box::new(LocalNode {
                        tracer,
                        kind,
                        rays,
                        tasks,
                        work,
                        task_size,
                        speed,
                    }));
                } else {
                    nodes.push(Box::new(RemoteNode::new(self.cluster, rank, speed)));
                }
            }
            Runtime::new(self.settings.policy).run(tasks, &costs, &mut nodes)
        };
        // Whatever happened, every other rank is serving and must be released.
        self.cluster.finish();

        let report = match result {
            Ok(report) => report,
            Err(e) => {
                // Every node failed: the image must still be complete, so rank 0 traces the
                // generation itself, and the report says so.
                if let sched::SchedError::AllDevicesFailed { failures, .. } = e {
                    stats.failures = failures;
                }
                stats.host_fallback = true;
                return if kind.is_occlusion() {
                    any_hits(self.bvh, rays)
                } else {
                    closest_hits(self.bvh, rays)
                };
            }
        };
        let mut done_cost = vec![0.0; active.len()];
        let mut done_tasks = vec![0usize; active.len()];
        for s in &report.timeline.spans {
            done_cost[s.device as usize] += costs[s.task as usize];
            done_tasks[s.device as usize] += 1;
        }
        stats.makespan = report.metrics.makespan;
        stats.balance_efficiency = report.metrics.balance_efficiency;
        stats.nodes = active
            .iter()
            .enumerate()
            .map(|(i, &rank)| NodeRun {
                rank,
                speed: self.speeds[rank],
                busy: report.metrics.busy[i],
                launches: report.launches[i],
                tasks: done_tasks[i],
            })
            .collect();
        self.learn_speeds(&active, &done_cost, &report.metrics.busy);
        stats.failures = report
            .failures
            .into_iter()
            .map(|f| DeviceFailure {
                device: active[f.device],
                ..f
            })
            .collect();
        for f in &stats.failures {
            self.retired[f.device] = true;
        }

        let mut hits = HitBatch {
            t: Vec::with_capacity(rays.len()),
            prim: Vec::with_capacity(rays.len()),
        };
        for out in report.outputs {
            hits.t.extend_from_slice(&out.t);
            hits.prim.extend_from_slice(&out.prim);
        }
        hits
    }

    /// Blends each node's measured throughput (planned cost per busy second, round trips
    /// included, which is what the next plan pays) into its speed, weighed by busy time.
    fn learn_speeds(&mut self, active: &[usize], done_cost: &[f64], busy: &[f64]) {
        let rates: Vec<Option<f64>> = done_cost
            .iter()
            .zip(busy)
            .map(|(&c, &b)| (b > 0.0 && c > 0.0).then(|| c / b))
            .collect();
        let measured: Vec<f64> = rates.iter().flatten().copied().collect();
        if measured.is_empty() {
            return;
        }
        let mean = measured.iter().sum::<f64>() / measured.len() as f64;
        let weight: f64 = busy.iter().sum();
        if !(mean > 0.0 && weight.is_finite() && weight > 0.0) {
            return;
        }
        let prior = self.evidence;
        for (i, &rank) in active.iter().enumerate() {
            if let Some(rate) = rates[i] {
                let new = rate / mean;
                let old = self.speeds[rank];
                self.speeds[rank] = (prior * old + weight * new) / (prior + weight);
            }
        }
        self.evidence = prior + weight;
    }

    /// A rank other than 0: runs the batches rank 0 sends until the generation ends.
    fn follow(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        work: Option<&[Work]>,
    ) {
        let task_size = self.task_size(rays.len());
        let local = &mut self.local;
        self.cluster.serve(|batch: Vec<Range<usize>>| {
            let part = batch_work(&batch, tasks, work, task_size)?;
            Ok(local.trace_tasks(kind, rays, &batch, part.as_deref()))
        });
    }
}

impl Tracer for ClusterTracer<'_, '_> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        let tasks = split_ranges(rays.len(), self.task_size(rays.len()));
        let mut stats = NodeGeneration {
            kind,
            rays: rays.len(),
            tasks: tasks.len(),
            estimate_seconds: 0.0,
            run_seconds: 0.0,
            broadcast_seconds: 0.0,
            makespan: 0.0,
            balance_efficiency: 1.0,
            nodes: Vec::new(),
            failures: Vec::new(),
            host_fallback: false,
        };
        let start = Instant::now();
        let work = self.estimate(kind, rays, &tasks);
        stats.estimate_seconds = start.elapsed().as_secs_f64();

        let start = Instant::now();
        let mut bytes = Vec::new();
        if self.cluster.is_root() {
            let hits = self.lead(kind, rays, &tasks, work.as_deref(), &mut stats);
            hits.encode(&mut bytes);
        } else {
            self.follow(kind, rays, &tasks, work.as_deref());
        }
        stats.run_seconds = start.elapsed().as_secs_f64();

        let start = Instant::now();
        self.cluster.broadcast(&mut bytes);
        stats.broadcast_seconds = start.elapsed().as_secs_f64();
        let hits = match HitBatch::decode(&mut &bytes[..]) {
            Ok(hits) if hits.len() == rays.len() => hits,
            // Only a bug could get here; the hits traced here are the same ones.
            _ if kind.is_occlusion() => any_hits(self.bvh, rays),
            _ => closest_hits(self.bvh, rays),
        };
        if self.cluster.is_root() {
            self.log.push(stats);
        }
        hits
    }
}
