//! The scheduled tracer: every generation cut into tasks, costed, planned by a policy and run
//! on devices by `sched`'s runtime (see ARCHITECTURE.md).

use std::ops::Range;
use std::time::Instant;

use sched::{Costs, DeviceFailure, RunReport, Runtime, SchedError, split_ranges};

use super::learn::{fit_devices, learnable, measured_speeds};
use super::speeds::SpeedBook;
use super::{
    Bound, DeviceStats, EstimateOn, GenerationStats, Mode, RayDevice, Settings, TaskStats,
};
use crate::cost::{Calibrations, CostModel, ReducedTraversal, Traced, Work};
use crate::shade::Tracer;
use crate::traverse::batch::{any_hits, closest_hits, closest_hits_counted};
use crate::traverse::counts::Counts;
use crate::{Bvh, HitBatch, RayBatch, RayKind};

/// A [`Tracer`] that schedules every generation over devices. See the module documentation
/// of [`crate::scheduled`].
///
/// Each ray is traced by itself on whichever device gets its task, so the hits, and the
/// image, are the same whatever the policy, mode, task size and devices.
pub struct ScheduledTracer<'a> {
    bvh: &'a Bvh,
    devices: Vec<Box<dyn RayDevice + 'a>>,
    settings: Settings,
    speeds: SpeedBook,
    retired: Vec<bool>,
    calibrations: Calibrations,
    log: Vec<GenerationStats>,
}

impl<'a> ScheduledTracer<'a> {
    /// A tracer over `devices`, all of speed 1 until the first generation is measured.
    pub fn new(
        bvh: &'a Bvh,
        devices: Vec<Box<dyn RayDevice + 'a>>,
        settings: Settings,
    ) -> Result<Self, SchedError> {
        if devices.is_empty() {
            return Err(SchedError::NoDevices);
        }
        let m = devices.len();
        // Before the first generation, which would otherwise wait for them.
        Runtime::start_threads(m);
        Ok(Self {
            bvh,
            devices,
            settings,
            speeds: SpeedBook::new(m),
            retired: vec![false; m],
            calibrations: Calibrations::default(),
            log: Vec::new(),
        })
    }

    /// The settings.
    pub fn settings(&self) -> Settings {
        self.settings
    }

    /// Every generation traced so far, in order.
    pub fn stats(&self) -> &[GenerationStats] {
        &self.log
    }

    /// The relative speeds measured so far, one per device, blended over every ray kind: what
    /// a generation of a kind not measured yet is planned with.
    pub fn speeds(&self) -> &[f64] {
        self.speeds.all()
    }

    /// The relative speeds the next generation of `kind` is planned with: that kind's own once
    /// a generation of it was measured (a GPU's speed against a CPU's depends on the rays),
    /// else [`ScheduledTracer::speeds`].
    pub fn speeds_for(&self, kind: RayKind) -> &[f64] {
        self.speeds.for_kind(kind)
    }

    /// The device names, in order.
    pub fn device_names(&self) -> Vec<String> {
        self.devices.iter().map(|d| d.name()).collect()
    }

    /// `kB`, `kT` calibrated so far, per device and ray kind (cost mode).
    pub fn calibrations(&self) -> &Calibrations {
        &self.calibrations
    }

    /// The model the next generation of `kind` is costed with: the calibration of the first
    /// working device that has one (costs must share one unit within a plan; speeds carry
    /// the differences between devices), else the default.
    fn planning_model(&self, kind: RayKind) -> CostModel {
        self.devices
            .iter()
            .zip(&self.retired)
            .filter(|(_, retired)| !**retired)
            .find_map(|(d, _)| self.calibrations.get(&d.name(), kind))
            .unwrap_or_default()
    }

    /// Task costs of `tasks`, the work behind them (cost mode), why an estimate failed and
    /// where it ran.
    fn costs(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[std::ops::Range<usize>],
    ) -> Costed {
        let uniform = |error: Option<String>, on: Option<String>| Costed {
            costs: Costs::uniform(tasks.len()),
            work: None,
            traced: None,
            error,
            on,
        };
        if self.settings.mode == Mode::Regular {
            return uniform(None, None);
        }
        let model = self.planning_model(kind);
        // Tasks come from `split_ranges` over a non-empty batch, so neither step can fail;
        // if one did, the generation is planned in regular mode and the report says why.
        match self.estimate_work(kind, rays, tasks) {
            Ok((work, traced, on)) => match Costs::new(model.costs(&work)) {
                Ok(costs) => Costed {
                    costs,
                    work: Some(work),
                    traced,
                    error: None,
                    on: Some(on),
                },
                Err(e) => uniform(Some(e.to_string()), Some(on)),
            },
            Err(e) => uniform(Some(e), None),
        }
    }
}

impl<'a> ScheduledTracer<'a> {
    /// The sampled work of `tasks`: on the first working device that estimates, when the
    /// settings ask for a GPU and one does (a device that fails to estimate is not retired:
    /// the host estimates instead, and tracing will show whether the device still works);
    /// else on the host.
    ///
    /// Returns the work, the sample's hits where the walk traced it for real (on the host),
    /// and where it was estimated: a device's name, or `host` (with why no device did, when
    /// one was asked for).
    fn estimate_work(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
    ) -> Result<(Vec<Work>, Option<Traced>, String), String> {
        let rate = self.settings.sample_rate;
        let walk = self.settings.walk.for_kind(kind);
        let mut on = String::from("host");
        if self.settings.estimate_on == EstimateOn::Gpu {
            on.push_str(" (no GPU among the devices)");
            for (device, retired) in self.devices.iter_mut().zip(&self.retired) {
                if *retired {
                    continue;
                }
                match device.estimate_work(rays, tasks, rate, walk) {
                    Some(Ok(work)) => return Ok((work, None, device.name())),
                    Some(Err(e)) => on = format!("host ({} could not: {e})", device.name()),
                    None => {}
                }
            }
        }
        let (work, traced) = ReducedTraversal::new(self.bvh, rays, rate)
            .with_walk(walk)
            .with_sample_error(self.settings.sample_error)
            .try_work_traced(tasks)
            .map_err(|e| e.to_string())?;
        Ok((work, traced, on))
    }

    /// The cost model the next plan of `kind` uses (see `planning_model`): what another
    /// process planning this tracer's work needs to turn estimated work into costs.
    pub fn cost_model(&self, kind: RayKind) -> CostModel {
        self.planning_model(kind)
    }

    /// Traces `tasks` (ranges of `rays`, any subset of a generation, each traced whole) on
    /// this tracer's devices with its policy, and returns their hits in the order of `tasks`.
    /// `work` is each task's estimated work, made elsewhere (a cluster estimates once, on all
    /// ranks in parallel); in cost mode without it, tasks are planned as equal.
    pub fn trace_tasks(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        work: Option<&[Work]>,
    ) -> Vec<HitBatch> {
        let work = work.filter(|w| self.settings.mode == Mode::Cost && w.len() == tasks.len());
        let costs = work.and_then(|w| Costs::new(self.planning_model(kind).costs(w)).ok());
        let planned = match costs {
            Some(costs) => Planned {
                costs,
                work,
                known: &[],
                estimate_seconds: 0.0,
                estimate_error: None,
                estimated_on: None,
            },
            None => Planned {
                costs: Costs::uniform(tasks.len()),
                work: None,
                known: &[],
                estimate_seconds: 0.0,
                estimate_error: None,
                estimated_on: None,
            },
        };
        self.run_tasks(kind, rays, tasks, planned)
    }

    /// Runs `tasks` as `planned`, logs the generation and returns one hit batch per task.
    fn run_tasks(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        planned: Planned<'_>,
    ) -> Vec<HitBatch> {
        let Planned {
            costs,
            work,
            known,
            estimate_seconds,
            estimate_error,
            estimated_on,
        } = planned;
        let active: Vec<usize> = (0..self.devices.len())
            .filter(|&d| !self.retired[d])
            .collect();
        let speeds = self.speeds.for_kind(kind);
        let retired = &self.retired;
        let mut bound: Vec<Bound<'_, 'a>> = self
            .devices
            .iter_mut()
            .enumerate()
            .filter(|(d, _)| !retired[*d])
            .map(|(d, device)| Bound::new(device.as_mut(), kind, rays, speeds[d]).knowing(known))
            .collect();
        let running = Instant::now();
        let result = Runtime::new(self.settings.policy).run(tasks, &costs, &mut bound);
        let run_seconds = running.elapsed().as_secs_f64();
        drop(bound);

        let mut stats = GenerationStats {
            kind,
            rays: tasks.iter().map(|t| t.len()).sum(),
            tasks: tasks.len(),
            task_size: tasks.iter().map(|t| t.len()).max().unwrap_or(0),
            policy: self.settings.policy,
            mode: self.settings.mode,
            estimate_seconds,
            plan_seconds: 0.0,
            run_seconds,
            makespan: run_seconds,
            balance_efficiency: 1.0,
            devices: Vec::new(),
            reruns: 0,
            failures: Vec::new(),
            task_stats: Vec::new(),
            calibrations: Vec::new(),
            outliers: 0,
            estimate_error,
            estimated_on,
            host_fallback: false,
            traffic: active.iter().map(|&d| self.devices[d].take_traffic()).fold(
                Default::default(),
                |mut all, t| {
                    all += t;
                    all
                },
            ),
        };
        let hits = match result {
            Ok(report) => self.learn(&mut stats, &active, &costs, work, report),
            Err(e) => {
                // Every device failed (or none was left): the image must still be complete,
                // so the caller's thread traces the generation, and the report says so.
                // (Lengths match and speeds are positive by construction, so the only other
                // error is that no device is left, after earlier failures.)
                if let SchedError::AllDevicesFailed { failures, .. } = e {
                    stats.reruns = tasks.len() as u64;
                    stats.failures = failures
                        .into_iter()
                        .map(|f| DeviceFailure {
                            device: active[f.device],
                            ..f
                        })
                        .collect();
                }
                for &d in &active {
                    self.retired[d] = true;
                }
                stats.host_fallback = true;
                let start = Instant::now();
                let hits = tasks
                    .iter()
                    .map(|t| {
                        let part: RayBatch = t.clone().map(|i| rays.get(i)).collect();
                        if kind.is_occlusion() {
                            any_hits(self.bvh, &part)
                        } else {
                            closest_hits(self.bvh, &part)
                        }
                    })
                    .collect();
                stats.run_seconds += start.elapsed().as_secs_f64();
                hits
            }
        };
        self.log.push(stats);
        hits
    }
}

impl<'a> Tracer for ScheduledTracer<'a> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        let active = self.retired.iter().filter(|r| !**r).count();
        let tasks = split_ranges(rays.len(), self.settings.task_size_for(rays.len(), active));

        let estimating = Instant::now();
        let costed = self.costs(kind, rays, &tasks);
        // Regular mode has nothing to estimate: no overhead to report.
        let estimate_seconds = match self.settings.mode {
            Mode::Regular => 0.0,
            Mode::Cost => estimating.elapsed().as_secs_f64(),
        };
        // The sample's hits replace its rays' trace only where every device skips them: a
        // device that traced them anyway would be measured on more work than the others.
        let skipping = self
            .devices
            .iter()
            .zip(&self.retired)
            .all(|(d, retired)| *retired || d.skips_known());
        let traced = costed.traced.filter(|_| skipping);
        let planned = Planned {
            costs: costed.costs,
            work: costed.work.as_deref(),
            known: traced.as_ref().map_or(&[], |t| &t.index[..]),
            estimate_seconds,
            estimate_error: costed.error,
            estimated_on: costed.on,
        };
        let outputs = self.run_tasks(kind, rays, &tasks, planned);
        let mut hits = HitBatch {
            t: Vec::with_capacity(rays.len()),
            prim: Vec::with_capacity(rays.len()),
        };
        for out in outputs {
            hits.t.extend_from_slice(&out.t);
            hits.prim.extend_from_slice(&out.prim);
        }
        if let Some(traced) = traced {
            traced.write_into(&mut hits);
        }
        hits
    }

    /// Counts on the caller's threads: the cost image is an extra, unscheduled pass.
    fn counts(&mut self, rays: &RayBatch) -> Option<Vec<Counts>> {
        Some(closest_hits_counted(self.bvh, rays).1)
    }
}

impl ScheduledTracer<'_> {
    /// Fills `stats` from a successful run, updates speeds, calibrations and retired devices,
    /// and returns the hits of each task, in task order. `active[i]` is the tracer's index of the run's
    /// device `i`.
    fn learn(
        &mut self,
        stats: &mut GenerationStats,
        active: &[usize],
        costs: &Costs,
        work: Option<&[Work]>,
        report: RunReport<HitBatch>,
    ) -> Vec<HitBatch> {
        let names: Vec<String> = active.iter().map(|&d| self.devices[d].name()).collect();
        let planned = self.speeds.for_kind(stats.kind);
        let old: Vec<f64> = active.iter().map(|&d| planned[d]).collect();
        let class = class_indices(active.iter().map(|&d| self.devices[d].class()));
        // Equal costs (regular mode) predict no task's time, so there is nothing to be far off.
        let keep = match work {
            Some(_) => learnable(costs, &report.timeline),
            None => vec![true; report.timeline.spans.len()],
        };
        stats.outliers = keep.iter().filter(|k| !**k).count();
        let (new, measured) = measured_speeds(&old, &class, costs, &report.timeline, &keep);

        let mut task_stats = vec![
            TaskStats {
                cost: 0.0,
                start: 0.0,
                seconds: 0.0,
                device: usize::MAX,
                device_seconds: None,
            };
            costs.len()
        ];
        let mut delivered = vec![0usize; active.len()];
        for s in &report.timeline.spans {
            let d = s.device as usize;
            delivered[d] += 1;
            task_stats[s.task as usize] = TaskStats {
                cost: costs[s.task as usize],
                start: s.start,
                seconds: s.end - s.start,
                device: active[d],
                device_seconds: s.device_seconds,
            };
        }
        let device_seconds: Vec<Option<f64>> = active
            .iter()
            .map(|&d| self.devices[d].take_device_seconds())
            .collect();
        stats.devices = (0..active.len())
            .map(|i| DeviceStats {
                index: active[i],
                name: names[i].clone(),
                speed: old[i],
                measured_speed: measured[i],
                launches: report.launches[i],
                tasks: delivered[i],
                busy: report.metrics.busy[i],
                device_seconds: device_seconds[i],
                launch_overhead: self.devices[active[i]].launch_overhead(),
            })
            .collect();
        stats.plan_seconds = report.plan_seconds;
        stats.makespan = report.metrics.makespan;
        stats.balance_efficiency = report.metrics.balance_efficiency;
        stats.reruns = report.reruns;
        stats.task_stats = task_stats;

        if let Some(work) = work {
            stats.calibrations = fit_devices(stats.kind, &names, work, &report.timeline, &keep);
            for f in &stats.calibrations {
                self.calibrations.insert(&f.device, f.kind, f.fit.model);
            }
        }
        // Blended by the busy time learnt from: a spike left out adds no evidence.
        let weight: f64 = report
            .timeline
            .spans
            .iter()
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(s, _)| (s.end - s.start).max(0.0))
            .sum();
        self.speeds.learn(stats.kind, active, &new, weight);
        // Devices that failed are not planned for again; their speed is left as it was.
        for f in &report.failures {
            self.retired[active[f.device]] = true;
        }
        stats.failures = report
            .failures
            .into_iter()
            .map(|f| DeviceFailure {
                device: active[f.device],
                ..f
            })
            .collect();

        report.outputs
    }
}

/// What [`ScheduledTracer::costs`] found: the costs the plan uses, the work behind them
/// (cost mode), why the estimate failed (uniform costs then) and where it ran.
struct Costed {
    costs: Costs,
    work: Option<Vec<Work>>,
    /// The sample's hits, where the walk traced it for real.
    traced: Option<Traced>,
    error: Option<String>,
    on: Option<String>,
}

/// A generation's tasks, costed: the costs the plan uses, the work behind them (cost mode),
/// and what estimating took or why it failed.
struct Planned<'w> {
    costs: Costs,
    work: Option<&'w [Work]>,
    /// Rays whose hits are known already (sorted): the devices leave them out.
    known: &'w [usize],
    estimate_seconds: f64,
    estimate_error: Option<String>,
    /// Where the estimate ran (a device's name or `host`), if it ran here.
    estimated_on: Option<String>,
}

/// Dense indices of `classes`, equal where the class names are equal.
fn class_indices(classes: impl Iterator<Item = String>) -> Vec<usize> {
    let mut seen: Vec<String> = Vec::new();
    classes
        .map(|c| match seen.iter().position(|s| *s == c) {
            Some(i) => i,
            None => {
                seen.push(c);
                seen.len() - 1
            }
        })
        .collect()
}
