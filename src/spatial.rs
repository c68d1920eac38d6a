//! What `cobalt knn` and `cobalt collide` share: run a workload's tasks in regular and cost
//! mode under each policy on real devices, replay the measured task times on 8 simulated
//! devices, and measure the estimator's error and overhead against its sampling rate.

use std::ops::Range;

use sched::{Costs, Executor, Metrics, Policy, Runtime, SampleRate, Simulation, Speeds};
use serde::Serialize;

use crate::args::count;
use crate::error::CliError;
use crate::limits::MAX_THREADS;

/// Mixed speeds of the simulated machine: four slow, two double and two quadruple devices.
pub const SIM_SPEEDS: [f64; 8] = [1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 4.0, 4.0];
/// Dispatch latency of a simulated launch (PCIe-like), in seconds.
pub const SIM_LATENCY: f64 = 10e-6;
/// Sampling rates of the trade table.
pub const RATES: [f64; 5] = [0.0625, 0.125, 0.25, 0.5, 1.0];

/// One run, in the record shape of `cobalt bench`.
#[derive(Debug, Serialize)]
pub struct Record {
    pub workload: String,
    pub policy: Policy,
    pub mode: &'static str,
    pub simulated: bool,
    pub task_size: usize,
    pub tasks: usize,
    pub devices: usize,
    pub speeds: Vec<f64>,
    pub queries: usize,
    /// Wall time: estimation (cost mode) + planning + the run's makespan.
    pub seconds: f64,
    pub queries_per_s: f64,
    pub balance_efficiency: f64,
    pub estimate_seconds: f64,
    pub plan_seconds: f64,
    /// Σ|estimated − full| / Σ full; null in regular mode.
    pub prediction_error: Option<f64>,
    /// Estimation time over the work's total device time; null in regular mode.
    pub overhead: Option<f64>,
    pub launches: u64,
}

/// One row of the sampling-rate trade table.
#[derive(Debug, Serialize)]
pub struct Trade {
    pub sample_rate: f64,
    pub estimate_seconds: f64,
    pub overhead: f64,
    pub prediction_error: Option<f64>,
    /// Rank correlation of the estimates with the measured task times.
    pub spearman_vs_time: Option<f64>,
    /// Balance efficiency of static LPT planned with these estimates on the 8 simulated
    /// devices, replaying measured task times.
    pub simulated_lpt_balance: f64,
}

/// The whole report.
#[derive(Debug, Serialize)]
pub struct Report {
    pub records: Vec<Record>,
    pub trade: Vec<Trade>,
    /// Σ measured task time on one device thread (the fastest of the runs for each task).
    pub work_seconds: f64,
}

/// Task costs at a sampling rate, with the seconds they took.
pub type EstimateFn<'a> =
    dyn Fn(SampleRate, &[Range<usize>]) -> Result<(Vec<f64>, f64), CliError> + 'a;
/// Checks a run's outputs.
pub type CheckFn<'a, O> = dyn Fn(&[O]) -> Result<(), CliError> + 'a;

/// A workload as the measurement sees it.
pub struct Workload<'a, E: Executor<Range<usize>>> {
    pub name: String,
    pub items: usize,
    pub task_size: usize,
    pub tasks: Vec<Range<usize>>,
    /// Estimates of `tasks` at a sampling rate, with their wall time.
    pub estimate: Box<EstimateFn<'a>>,
    /// Fresh devices.
    pub devices: Box<dyn Fn(usize) -> Vec<E> + 'a>,
    /// Checks a run's outputs against the workload (cheap; the property tests do the rest).
    pub check: Box<CheckFn<'a, E::Output>>,
}

/// How `cobalt knn` and `cobalt collide` run their workload.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// One policy instead of all five.
    #[arg(long)]
    policy: Option<Policy>,
    /// Real CPU devices (threads), 1..=4096.
    #[arg(long, default_value_t = 2, value_parser = count::<MAX_THREADS>)]
    devices: usize,
    /// Print the report as one JSON object instead of tables.
    #[arg(long)]
    json: bool,
}

/// Measures `work` as `args` say, with estimates at `rate`, and prints the report.
pub fn run<E: Executor<Range<usize>>>(
    work: &Workload<'_, E>,
    args: &RunArgs,
    rate: SampleRate,
) -> Result<(), CliError> {
    let policies = args.policy.map_or(Policy::ALL.to_vec(), |p| vec![p]);
    let report = measure(work, &policies, args.devices, rate)?;
    if args.json {
        crate::print::print_json(&report)
    } else {
        crate::print::print_text(&format!("{}\n\n{}", work.name, tables(&report)))
    }
}

/// Measures `work` under `policies` on `devices` real devices, then simulates and trades.
fn measure<E: Executor<Range<usize>>>(
    work: &Workload<'_, E>,
    policies: &[Policy],
    devices: usize,
    rate: SampleRate,
) -> Result<Report, CliError> {
    let n = work.tasks.len();
    let (estimated, estimate_seconds) = (work.estimate)(rate, &work.tasks)?;
    let (full, _) = (work.estimate)(SampleRate::FULL, &work.tasks)?;
    let error = knn::prediction_error(&estimated, &full);
    let estimated = Costs::new(estimated)?;
    let uniform = Costs::uniform(n);
    let modes = [("regular", &uniform), ("cost", &estimated)];
    // A run's record; its overhead is known once every task has been measured.
    let record = |(policy, mode): (Policy, &'static str),
                  (simulated, speeds): (bool, &[f64]),
                  estimate_seconds: f64,
                  plan_seconds: f64,
                  metrics: &Metrics,
                  launches: &[u64]| {
        let seconds = estimate_seconds + plan_seconds + metrics.makespan;
        Record {
            workload: work.name.clone(),
            policy,
            mode,
            simulated,
            task_size: work.task_size,
            tasks: n,
            devices: speeds.len(),
            speeds: speeds.to_vec(),
            queries: work.items,
            seconds,
            queries_per_s: work.items as f64 / seconds,
            balance_efficiency: metrics.balance_efficiency,
            estimate_seconds,
            plan_seconds,
            prediction_error: (mode == "cost").then_some(error).flatten(),
            overhead: None,
            launches: launches.iter().sum(),
        }
    };
    let mut measured = vec![f64::INFINITY; n];
    let mut records = Vec::new();
    let real = vec![1.0; devices];
    for &policy in policies {
        for (mode, plan) in modes {
            let mut devs = (work.devices)(devices);
            let run = Runtime::new(policy).run(&work.tasks, plan, &mut devs)?;
            (work.check)(&run.outputs)?;
            for s in &run.timeline.spans {
                let t = &mut measured[s.task as usize];
                *t = t.min(s.end - s.start);
            }
            let est = if mode == "cost" {
                estimate_seconds
            } else {
                0.0
            };
            let (plan_s, m, l) = (run.plan_seconds, &run.metrics, &run.launches);
            records.push(record((policy, mode), (false, &real), est, plan_s, m, l));
        }
    }
    let work_seconds: f64 = measured.iter().sum();
    let actual = Costs::new(measured.clone())?;
    let speeds = Speeds::new(SIM_SPEEDS.to_vec())?;
    let simulate = |policy: Policy, plan: &Costs| {
        Simulation::new(policy, speeds.clone())
            .latency(SIM_LATENCY)
            .run_actual(plan, &actual)
    };
    // Estimation is data-parallel over tasks, so on the simulated machine it is spread over
    // the devices like any other work.
    let spread = estimate_seconds / SIM_SPEEDS.iter().sum::<f64>();
    for &policy in policies {
        for (mode, plan) in modes {
            let sim = simulate(policy, plan)?;
            let est = if mode == "cost" { spread } else { 0.0 };
            let (plan_s, m, l) = (sim.plan_seconds, &sim.metrics, &sim.launches);
            records.push(record(
                (policy, mode),
                (true, &SIM_SPEEDS),
                est,
                plan_s,
                m,
                l,
            ));
        }
    }
    for r in &mut records {
        if r.mode == "cost" {
            r.overhead = Some(r.estimate_seconds / work_seconds);
        }
    }
    let mut trade = Vec::new();
    for rate in RATES.into_iter().filter_map(|r| SampleRate::new(r).ok()) {
        let (est, seconds) = (work.estimate)(rate, &work.tasks)?;
        let sim = simulate(Policy::StaticLpt, &Costs::new(est.clone())?)?;
        trade.push(Trade {
            sample_rate: rate.get(),
            estimate_seconds: seconds,
            overhead: seconds / work_seconds,
            prediction_error: knn::prediction_error(&est, &full),
            spearman_vs_time: raytrace::cost::spearman(&est, &measured).ok(),
            simulated_lpt_balance: sim.metrics.balance_efficiency,
        });
    }
    Ok(Report {
        records,
        trade,
        work_seconds,
    })
}

/// The Markdown tables of a report.
pub fn tables(report: &Report) -> String {
    let pct = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{:.2} %", 100.0 * v));
    let mut out = String::from(
        "| devices | policy | mode | queries/s | balance | pred. error | overhead | launches |\n|---|---|---|---:|---:|---:|---:|---:|\n",
    );
    for r in &report.records {
        let devices = if r.simulated {
            format!("{} simulated", r.devices)
        } else {
            format!("{} cpu", r.devices)
        };
        out.push_str(&format!(
            "| {devices} | {} | {} | {:.0} | {:.2} % | {} | {} | {} |\n",
            r.policy,
            r.mode,
            r.queries_per_s,
            100.0 * r.balance_efficiency,
            pct(r.prediction_error),
            pct(r.overhead),
            r.launches
        ));
    }
    out.push_str(
        "\n| sample rate | estimate s | overhead | pred. error | spearman vs time | LPT balance (8 sim.) |\n|---:|---:|---:|---:|---:|---:|\n",
    );
    for t in &report.trade {
        out.push_str(&format!(
            "| {:.4} | {:.5} | {} | {} | {} | {:.2} % |\n",
            t.sample_rate,
            t.estimate_seconds,
            pct(Some(t.overhead)),
            pct(t.prediction_error),
            t.spearman_vs_time.map_or("–".into(), |s| format!("{s:.3}")),
            100.0 * t.simulated_lpt_balance
        ));
    }
    out.push_str(&format!(
        "\nmeasured work: {:.3} s on one device thread\n",
        report.work_seconds
    ));
    out
}
