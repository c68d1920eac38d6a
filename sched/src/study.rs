//! A workload's policies compared, as `cobalt knn` and `cobalt collide` report them: its
//! tasks run under each policy in regular mode (equal costs) and cost mode (estimated) on real
//! devices, the measured task times replayed on a simulated machine of mixed speeds, and the
//! estimator's error and overhead measured against its sampling rate.

use std::ops::Range;

use crate::{
    Costs, Executor, Metrics, Policy, Runtime, SampleRate, SchedError, Simulation, Speeds,
    prediction_error, rank_correlation,
};

/// Mixed speeds of the simulated machine: four slow, two double and two quadruple devices.
pub const SIM_SPEEDS: [f64; 8] = [1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 4.0, 4.0];
/// Dispatch latency of a simulated launch (PCIe-like), in seconds.
pub const SIM_LATENCY: f64 = 10e-6;
/// Sampling rates of the trade table.
pub const RATES: [f64; 5] = [0.0625, 0.125, 0.25, 0.5, 1.0];

/// One run, in the record shape of `cobalt bench`.
#[derive(Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Record {
    /// The workload's name.
    pub workload: String,
    /// The policy that planned the run.
    pub policy: Policy,
    /// `regular` (equal costs) or `cost` (estimated).
    pub mode: &'static str,
    /// Whether the run is the simulated machine's replay of measured times.
    pub simulated: bool,
    /// Items per task.
    pub task_size: usize,
    /// Tasks in the run.
    pub tasks: usize,
    /// Devices of the run.
    pub devices: usize,
    /// Their relative speeds.
    pub speeds: Vec<f64>,
    /// Items (queries, bodies) in the workload.
    pub queries: usize,
    /// Wall time: estimation (cost mode) + planning + the run's makespan.
    pub seconds: f64,
    /// Items per second of `seconds`.
    pub queries_per_s: f64,
    /// Mean device busy time over the makespan.
    pub balance_efficiency: f64,
    /// Seconds spent estimating (0 in regular mode).
    pub estimate_seconds: f64,
    /// Seconds spent planning.
    pub plan_seconds: f64,
    /// Σ|estimated − full| / Σ full; null in regular mode.
    pub prediction_error: Option<f64>,
    /// Estimation time over the work's total device time; null in regular mode.
    pub overhead: Option<f64>,
    /// Launches over every device.
    pub launches: u64,
}

/// One row of the sampling-rate trade table.
#[derive(Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Trade {
    /// The estimator's sampling rate.
    pub sample_rate: f64,
    /// Seconds the estimate took.
    pub estimate_seconds: f64,
    /// Estimation time over the work's total device time.
    pub overhead: f64,
    /// Σ|estimated − full| / Σ full.
    pub prediction_error: Option<f64>,
    /// Rank correlation of the estimates with the measured task times.
    pub spearman_vs_time: Option<f64>,
    /// Balance efficiency of static LPT planned with these estimates on the 8 simulated
    /// devices, replaying measured task times.
    pub simulated_lpt_balance: f64,
}

/// The whole report.
#[derive(Debug)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Report {
    /// Every run, real then simulated.
    pub records: Vec<Record>,
    /// The estimator's trade, one row per sampling rate.
    pub trade: Vec<Trade>,
    /// Σ measured task time on one device thread (the fastest of the runs for each task).
    pub work_seconds: f64,
}

/// Task costs at a sampling rate, with the seconds they took.
pub type EstimateFn<'a, Err> =
    dyn Fn(SampleRate, &[Range<usize>]) -> Result<(Vec<f64>, f64), Err> + 'a;
/// Checks a run's outputs.
pub type CheckFn<'a, O, Err> = dyn Fn(&[O]) -> Result<(), Err> + 'a;

/// A workload as the measurement sees it.
pub struct Workload<'a, E: Executor<Range<usize>>, Err> {
    /// The name printed above its tables.
    pub name: String,
    /// Items in the workload.
    pub items: usize,
    /// Items per task.
    pub task_size: usize,
    /// Its tasks.
    pub tasks: Vec<Range<usize>>,
    /// Estimates of `tasks` at a sampling rate, with their wall time.
    pub estimate: Box<EstimateFn<'a, Err>>,
    /// Fresh devices.
    pub devices: Box<dyn Fn(usize) -> Vec<E> + 'a>,
    /// Checks a run's outputs against the workload (cheap; the property tests do the rest).
    pub check: Box<CheckFn<'a, E::Output, Err>>,
}

/// Measures `work` under `policies` on `devices` real devices with estimates at `rate`, then
/// replays the measured task times on the simulated machine and measures the trade.
pub fn measure<E, Err>(
    work: &Workload<'_, E, Err>,
    policies: &[Policy],
    devices: usize,
    rate: SampleRate,
) -> Result<Report, Err>
where
    E: Executor<Range<usize>>,
    Err: From<SchedError>,
{
    let n = work.tasks.len();
    let (estimated, estimate_seconds) = (work.estimate)(rate, &work.tasks)?;
    let (full, _) = (work.estimate)(SampleRate::FULL, &work.tasks)?;
    let error = prediction_error(&estimated, &full);
    let estimated = Costs::new(estimated)?;
    let uniform = Costs::uniform(n);
    let modes = [("regular", &uniform), ("cost", &estimated)];
    // A run's record, charged `estimate_seconds` in cost mode; its overhead is known once
    // every task has been measured.
    let record = |(policy, mode): (Policy, &'static str),
                  (simulated, speeds): (bool, &[f64]),
                  estimate_seconds: f64,
                  plan_seconds: f64,
                  metrics: &Metrics,
                  launches: &[u64]| {
        let estimate_seconds = if mode == "cost" {
            estimate_seconds
        } else {
            0.0
        };
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
            let (plan_s, m, l) = (run.plan_seconds, &run.metrics, &run.launches);
            let est = estimate_seconds;
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
            let (plan_s, m, l) = (sim.plan_seconds, &sim.metrics, &sim.launches);
            let speeds = (true, &SIM_SPEEDS[..]);
            records.push(record((policy, mode), speeds, spread, plan_s, m, l));
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
            prediction_error: prediction_error(&est, &full),
            spearman_vs_time: rank_correlation(&est, &measured),
            simulated_lpt_balance: sim.metrics.balance_efficiency,
        });
    }
    Ok(Report {
        records,
        trade,
        work_seconds,
    })
}

impl Report {
    /// The report as Markdown tables.
    pub fn tables(&self) -> String {
        let pct = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{:.2} %", 100.0 * v));
        let mut out = String::from(
            "| devices | policy | mode | queries/s | balance | pred. error | overhead | launches |\n|---|---|---|---:|---:|---:|---:|---:|\n",
        );
        for r in &self.records {
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
        for t in &self.trade {
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
            self.work_seconds
        ));
        out
    }
}
