//! The report of `cobalt render --pipeline generations`: every generation's plan, fits, task
//! times and traffic, built from the tracer's statistics, and its one-screen summary.

use raytrace::cost_image::max_counts;
use raytrace::scheduled::{GenerationStats, ScheduledTracer, Settings};
use raytrace::shade::Rendering;
use sched::Policy;
use serde::Serialize;

use super::header::Header;
use crate::args::Devices;

#[derive(Debug, Serialize)]
struct GenerationReport {
    kind: &'static str,
    bounce: u32,
    rays: usize,
    /// Trace time: estimate, plan and run on the devices.
    seconds: f64,
    mrays_per_s: f64,
    #[serde(flatten)]
    schedule: Option<ScheduleReport>,
}

/// How one generation was scheduled.
#[derive(Debug, Serialize)]
struct ScheduleReport {
    tasks: usize,
    /// Rays in the longest task: `--task-size`, or less for a generation too small to give
    /// every device several tasks.
    task_size: usize,
    estimate_seconds: f64,
    plan_seconds: f64,
    /// Wall time of the run on the devices.
    run_seconds: f64,
    makespan: f64,
    balance_efficiency: f64,
    /// Per device that took part, in `devices` order.
    device_names: Vec<String>,
    /// The relative speeds the plan used.
    speeds: Vec<f64>,
    /// The speeds measured on this generation (null where a device ran nothing).
    measured_speeds: Vec<Option<f64>>,
    launches: Vec<u64>,
    busy: Vec<f64>,
    /// Per device: kernel seconds it measured itself (a GPU's timestamp queries), null
    /// where it cannot.
    device_seconds: Vec<Option<f64>>,
    reruns: u64,
    failures: Vec<String>,
    host_fallback: bool,
    /// What crossed between the host and the devices: the generation's rays and hits, and
    /// an estimate's samples and sums where a GPU estimated (0 for CPUs).
    host_to_device_bytes: u64,
    device_to_host_bytes: u64,
    /// Times the host blocked on a device.
    host_waits: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    estimate_error: Option<String>,
    /// Where the estimate ran (cost mode): a device's name or `host`.
    #[serde(skip_serializing_if = "Option::is_none")]
    estimated_on: Option<String>,
    calibration: Vec<FitReport>,
    /// Per task, in task order: planned cost, measured seconds, device index.
    task_costs: Vec<f64>,
    task_seconds: Vec<f64>,
    task_devices: Vec<usize>,
    /// Per task: the kernel time its device measured (a GPU's timestamp queries) where the
    /// task had a launch of its own (queue policies), else null.
    task_device_seconds: Vec<Option<f64>>,
}

/// `kB`, `kT` of one device for one ray kind, fitted by least squares to measured task times.
#[derive(Debug, Clone, Serialize)]
struct FitReport {
    device: String,
    kind: &'static str,
    kr: f64,
    kb: f64,
    kt: f64,
    form: &'static str,
    r2: f64,
    rms_residual: f64,
    tasks: usize,
}

#[derive(Debug, Serialize)]
struct CostReport {
    max_nodes: u32,
    max_tris: u32,
    mean_nodes: f64,
    mean_tris: f64,
    seconds: f64,
}

/// The report of `--pipeline generations`.
#[derive(Debug, Serialize)]
pub struct Report {
    #[serde(flatten)]
    header: Header,
    devices: String,
    /// Every device, in order.
    device_names: Vec<String>,
    /// Threads over all devices.
    threads: usize,
    policy: Policy,
    mode: &'static str,
    task_size: usize,
    sample_rate: f64,
    /// How far the host's estimate refined its sample (`--sample-error`); null: every task
    /// at `sample_rate`.
    sample_error: Option<f64>,
    /// Cost mode's walk of closest-hit generations.
    walk: &'static str,
    generations: Vec<GenerationReport>,
    total_rays: usize,
    /// Sum of the generations' trace times.
    trace_seconds: f64,
    /// Wall time of the render: ray generation, tracing and shading.
    render_seconds: f64,
    /// Rendering efficiency: total rays over `render_seconds`.
    mrays_per_s: f64,
    /// Σ busy / Σ (makespan × devices) over the generations: balance of the whole render.
    balance_efficiency: f64,
    /// Estimation and planning time over all generations.
    estimate_seconds: f64,
    plan_seconds: f64,
    launches: u64,
    reruns: u64,
    /// Generations traced on the host because every device had failed (`--host-fallback`).
    host_fallback_generations: usize,
    /// The last fit of every device and ray kind: the calibration the next render would use.
    calibration: Vec<FitReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cost: Option<CostReport>,
}

impl Report {
    /// The report of `rendering`, traced by `tracer` over `devices` with `settings`.
    pub fn new(
        header: Header,
        devices: &Devices,
        settings: Settings,
        tracer: &ScheduledTracer<'_>,
        rendering: &Rendering,
    ) -> Self {
        let stats = tracer.stats();
        Self {
            header,
            devices: devices.as_str().to_string(),
            device_names: tracer.device_names(),
            threads: devices.threads(),
            policy: settings.policy,
            mode: settings.mode.name(),
            task_size: settings.task_size.get(),
            sample_rate: settings.sample_rate.get(),
            sample_error: settings.sample_error,
            walk: settings.walk.name(),
            generations: generation_reports(rendering, stats),
            total_rays: rendering.total_rays(),
            trace_seconds: rendering.trace_seconds(),
            render_seconds: rendering.seconds,
            mrays_per_s: rendering.mrays_per_s(),
            balance_efficiency: overall_balance(stats),
            estimate_seconds: stats.iter().map(|g| g.estimate_seconds).sum(),
            plan_seconds: stats.iter().map(|g| g.plan_seconds).sum(),
            launches: stats.iter().map(GenerationStats::launches).sum(),
            reruns: stats.iter().map(|g| g.reruns).sum(),
            host_fallback_generations: stats.iter().filter(|g| g.host_fallback).count(),
            calibration: final_calibration(stats),
            cost: rendering.primary_counts.as_ref().map(|counts| {
                let max = max_counts(counts);
                let n = counts.len().max(1) as f64;
                CostReport {
                    max_nodes: max.nodes,
                    max_tris: max.tris,
                    mean_nodes: counts.iter().map(|c| c.nodes as f64).sum::<f64>() / n,
                    mean_tris: counts.iter().map(|c| c.tris as f64).sum::<f64>() / n,
                    seconds: rendering.count_seconds,
                }
            }),
        }
    }
}

/// One report per generation; the tracer's stats are in the same order (one per traced
/// generation).
fn generation_reports(r: &Rendering, stats: &[GenerationStats]) -> Vec<GenerationReport> {
    r.generations
        .iter()
        .enumerate()
        .map(|(i, g)| GenerationReport {
            kind: g.kind.name(),
            bounce: g.bounce,
            rays: g.rays,
            seconds: g.seconds,
            mrays_per_s: g.mrays_per_s(),
            schedule: stats.get(i).map(schedule_report),
        })
        .collect()
}

fn schedule_report(g: &GenerationStats) -> ScheduleReport {
    ScheduleReport {
        tasks: g.tasks,
        task_size: g.task_size,
        estimate_seconds: g.estimate_seconds,
        plan_seconds: g.plan_seconds,
        run_seconds: g.run_seconds,
        makespan: g.makespan,
        balance_efficiency: g.balance_efficiency,
        device_names: g.devices.iter().map(|d| d.name.clone()).collect(),
        speeds: g.devices.iter().map(|d| d.speed).collect(),
        measured_speeds: g.devices.iter().map(|d| d.measured_speed).collect(),
        launches: g.devices.iter().map(|d| d.launches).collect(),
        busy: g.devices.iter().map(|d| d.busy).collect(),
        device_seconds: g.devices.iter().map(|d| d.device_seconds).collect(),
        reruns: g.reruns,
        failures: g.failures.iter().map(ToString::to_string).collect(),
        host_fallback: g.host_fallback,
        host_to_device_bytes: g.traffic.host_to_device_bytes,
        device_to_host_bytes: g.traffic.device_to_host_bytes,
        host_waits: g.traffic.host_waits,
        estimate_error: g.estimate_error.clone(),
        estimated_on: g.estimated_on.clone(),
        calibration: g.calibrations.iter().map(fit_report).collect(),
        task_costs: g.task_stats.iter().map(|t| t.cost).collect(),
        task_seconds: g.task_stats.iter().map(|t| t.seconds).collect(),
        task_devices: g.task_stats.iter().map(|t| t.device).collect(),
        task_device_seconds: g.task_stats.iter().map(|t| t.device_seconds).collect(),
    }
}

fn fit_report(f: &raytrace::scheduled::DeviceFit) -> FitReport {
    FitReport {
        device: f.device.clone(),
        kind: f.kind.name(),
        kr: f.fit.model.kr,
        kb: f.fit.model.kb,
        kt: f.fit.model.kt,
        form: f.fit.form.name(),
        r2: f.fit.r2,
        rms_residual: f.fit.rms_residual,
        tasks: f.fit.n,
    }
}

/// The balance efficiency of the whole render: every generation's busy time over
/// its makespan times its devices, summed before dividing so long generations weigh more.
fn overall_balance(stats: &[GenerationStats]) -> f64 {
    let busy: f64 = stats
        .iter()
        .flat_map(|g| g.devices.iter().map(|d| d.busy))
        .sum();
    let capacity: f64 = stats
        .iter()
        .map(|g| g.makespan * g.devices.len() as f64)
        .sum();
    if capacity > 0.0 { busy / capacity } else { 1.0 }
}

/// The latest fit of each (device, kind), in order of first appearance.
fn final_calibration(stats: &[GenerationStats]) -> Vec<FitReport> {
    let mut out: Vec<FitReport> = Vec::new();
    for f in stats.iter().flat_map(|g| &g.calibrations) {
        let r = fit_report(f);
        match out
            .iter_mut()
            .find(|o| o.device == r.device && o.kind == r.kind)
        {
            Some(o) => *o = r,
            None => out.push(r),
        }
    }
    out
}

impl Report {
    /// The summary printed without `--json`: the render, then one line per generation and
    /// per fitted device.
    pub fn summary(&self) -> String {
        let r = self;
        let mut s = format!(
            "{} on {} ({} thread(s)), {} {}, tasks of {}: {} rays in {:.3} s, {:.2} MRays/s, balance {:.1} %\n",
            r.header.what(),
            r.devices,
            r.threads,
            r.policy,
            r.mode,
            r.task_size,
            r.total_rays,
            r.render_seconds,
            r.mrays_per_s,
            100.0 * r.balance_efficiency,
        );
        if r.host_fallback_generations > 0 {
            s += &format!(
                "every device failed: {} generation(s) traced on the host instead (--host-fallback)\n",
                r.host_fallback_generations
            );
        }
        for g in &r.generations {
            s += &format!(
                "  {:<10} bounce {}  {:>10} rays  {:.4} s  {:.2} MRays/s",
                g.kind, g.bounce, g.rays, g.seconds, g.mrays_per_s
            );
            if let Some(x) = &g.schedule {
                let speeds: Vec<String> = x.speeds.iter().map(|v| format!("{v:.3}")).collect();
                s += &format!(
                    "  {:>6} tasks  balance {:5.1} %  estimate {:.4} s  plan {:.5} s  launches {:?}  speeds [{}]",
                    x.tasks,
                    100.0 * x.balance_efficiency,
                    x.estimate_seconds,
                    x.plan_seconds,
                    x.launches,
                    speeds.join(", "),
                );
                if x.reruns > 0 {
                    s += &format!("  reruns {}", x.reruns);
                }
                if x.host_fallback {
                    s += "  traced on the host";
                }
                for f in &x.failures {
                    s += &format!("\n    {f}");
                }
            }
            s += "\n";
        }
        for c in &r.calibration {
            s += &format!(
                "  calibration {:<6} {:<10} kR {:.3e} s  kB {:.3e} s  kT {:.3e} s  ({}, R² {:.3}, {} tasks)\n",
                c.device, c.kind, c.kr, c.kb, c.kt, c.form, c.r2, c.tasks
            );
        }
        s
    }
}
