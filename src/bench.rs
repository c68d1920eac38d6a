//! `cobalt bench`: the thesis's policy matrix.
//!
//! Until the ray tracer lands (issues 3 and 4), this runs on a *synthetic* ray workload in
//! `sched`'s simulator, and says so in every record: a million rays whose cost varies
//! smoothly along the Morton order with hot spots (like the cost image of a sparse scene),
//! cut into tasks of 16384, 4096 and 512 rays, estimated by sampling 1/8 of each task's
//! rays as the thesis does, and replayed on identical and mixed-speed devices with a
//! PCIe-like launch latency.

use std::time::Instant;

use sched::bounds::lower_bound;
use sched::{Costs, Policy, Simulation, Speeds};
use serde::Serialize;

use crate::error::CliError;

/// Arguments of `cobalt bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Write every record as a JSON array to this file.
    #[arg(long)]
    json: Option<std::path::PathBuf>,
    /// Rays in the synthetic workload.
    #[arg(long, default_value_t = 1 << 20)]
    rays: usize,
    /// Share of each task's rays traced to estimate its cost.
    #[arg(long, default_value_t = 0.125)]
    sample_rate: f64,
}

#[derive(Debug, Serialize)]
struct Record {
    workload: &'static str,
    policy: Policy,
    mode: &'static str,
    task_size: usize,
    devices: usize,
    speeds: Vec<f64>,
    latency: f64,
    rays: usize,
    seconds: f64,
    mrays_per_s: f64,
    makespan_over_bound: f64,
    balance_efficiency: f64,
    launches: u64,
    prediction_error: f64,
}

const LATENCY: f64 = 10e-6;

/// Runs the matrix, prints a Markdown table and writes the JSON records if asked.
pub fn run(args: Args) -> Result<(), CliError> {
    if !(args.sample_rate > 0.0 && args.sample_rate <= 1.0) {
        return Err(CliError::Arg {
            flag: "sample-rate",
            value: args.sample_rate.to_string(),
            message: "must be in (0, 1]".into(),
        });
    }
    let started = Instant::now();
    let ray_costs = synthetic_rays(args.rays);
    let machines = [vec![1.0, 1.0], vec![1.0, 1.0, 4.0, 4.0]];
    let mut records = Vec::new();
    for task_size in [16384, 4096, 512] {
        let actual = task_costs(&ray_costs, task_size, 1.0);
        let estimated = task_costs(&ray_costs, task_size, args.sample_rate);
        let error = prediction_error(&estimated, &actual);
        let (actual, estimated) = (Costs::new(actual)?, Costs::new(estimated)?);
        let uniform = Costs::uniform(actual.len());
        for speeds in &machines {
            let speeds = Speeds::new(speeds.clone())?;
            let bound = lower_bound(&actual, &speeds);
            for policy in Policy::ALL {
                for (mode, plan_with) in [("regular", &uniform), ("cost", &estimated)] {
                    let sim = Simulation::new(policy, speeds.clone())
                        .latency(LATENCY)
                        .run_actual(plan_with, &actual)?;
                    let seconds = sim.metrics.makespan;
                    records.push(Record {
                        workload: "synthetic (simulated; real scenes arrive with issue 4)",
                        policy,
                        mode,
                        task_size,
                        devices: speeds.len(),
                        speeds: speeds.as_slice().to_vec(),
                        latency: LATENCY,
                        rays: args.rays,
                        seconds,
                        mrays_per_s: args.rays as f64 / seconds / 1e6,
                        makespan_over_bound: seconds / bound,
                        balance_efficiency: sim.metrics.balance_efficiency,
                        launches: sim.launches.iter().sum(),
                        prediction_error: if mode == "cost" { error } else { f64::NAN },
                    });
                }
            }
        }
    }
    crate::print_text(&table(&records))?;
    crate::print_text(&format!(
        "\n{} runs in {:.2} s. Workload: synthetic rays in sched's simulator, {} µs per launch.\n",
        records.len(),
        started.elapsed().as_secs_f64(),
        LATENCY * 1e6
    ))?;
    if let Some(path) = &args.json {
        let text =
            serde_json::to_string_pretty(&records).map_err(|e| CliError::Write(e.to_string()))?;
        crate::write_file(path, text.as_bytes())?;
    }
    Ok(())
}

/// Per-ray cost in seconds: about 1 µs, ×20 in a few hot spots along the curve, with noise.
fn synthetic_rays(n: usize) -> Vec<f64> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let hot = [0.13, 0.41, 0.47, 0.78];
    (0..n)
        .map(|i| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let x = i as f64 / n as f64;
            let heat: f64 = hot
                .iter()
                .map(|h| 20.0 * (-((x - h) / 0.02).powi(2)).exp())
                .sum();
            let noise = 0.5 + (state >> 11) as f64 / (1u64 << 53) as f64;
            1e-6 * (1.0 + heat) * noise
        })
        .collect()
}

/// Each task's cost from a uniform sample of its rays (at least one), scaled to the task.
fn task_costs(rays: &[f64], task_size: usize, rate: f64) -> Vec<f64> {
    rays.chunks(task_size)
        .map(|task| {
            let stride = ((1.0 / rate).round() as usize).max(1);
            let sampled: Vec<f64> = task.iter().step_by(stride).copied().collect();
            sampled.iter().sum::<f64>() * task.len() as f64 / sampled.len() as f64
        })
        .collect()
}

/// The thesis's prediction error: Σ|estimated − full| / Σ full.
fn prediction_error(estimated: &[f64], full: &[f64]) -> f64 {
    let diff: f64 = estimated.iter().zip(full).map(|(e, f)| (e - f).abs()).sum();
    diff / full.iter().sum::<f64>()
}

fn table(records: &[Record]) -> String {
    let mut out = String::from(
        "| task size | devices (speeds) | policy | mode | MRays/s | makespan / bound | balance | launches | pred. error |\n|---:|---|---|---|---:|---:|---:|---:|---:|\n",
    );
    for r in records {
        let speeds: Vec<String> = r.speeds.iter().map(f64::to_string).collect();
        let error = if r.prediction_error.is_nan() {
            String::from("–")
        } else {
            format!("{:.2} %", 100.0 * r.prediction_error)
        };
        out.push_str(&format!(
            "| {} | {} ({}) | {} | {} | {:.1} | {:.4} | {:.2} % | {} | {} |\n",
            r.task_size,
            r.devices,
            speeds.join(","),
            r.policy,
            r.mode,
            r.mrays_per_s,
            r.makespan_over_bound,
            100.0 * r.balance_efficiency,
            r.launches,
            error
        ));
    }
    out
}
