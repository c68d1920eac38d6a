//! `cobalt schedule`: plan a list of task costs with a policy and report the result.

use std::path::{Path, PathBuf};
use std::time::Instant;

use sched::bounds::{guarantee, lower_bound};
use sched::{Costs, Fault, Policy, Simulation, Speeds};
use serde::Serialize;

use crate::args::{fault_time, speed};
use crate::error::CliError;
use crate::input::read_costs;

/// Arguments of `cobalt schedule`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// File with one non-negative task cost per line (`-` for standard input).
    #[arg(long)]
    costs: PathBuf,
    /// Relative device speeds, comma-separated: `1,1,2.5` is two devices and one 2.5× faster.
    #[arg(long, default_value = "1", value_delimiter = ',', value_parser = speed)]
    speeds: Vec<f64>,
    /// static-equal, static-lpt (lpt), queue-fifo (fifo), queue-sorted (sorted) or hybrid.
    #[arg(long, default_value = "static-lpt")]
    policy: Policy,
    /// Time every launch waits before its first task, in cost units.
    #[arg(long, default_value_t = 0.0)]
    latency: f64,
    /// Actual costs, one per line, if they differ from the estimates in `--costs`.
    #[arg(long)]
    actual: Option<PathBuf>,
    /// The devices' true speeds, if they differ from the speeds in `--speeds` (which the
    /// policy plans with): `--speeds 1,1 --actual-speeds 1,0.05` is a device declared as fast
    /// as the first but 20 times slower.
    #[arg(long, value_delimiter = ',', value_parser = speed)]
    actual_speeds: Option<Vec<f64>>,
    /// Run the plan as planned: no device left idle runs backup copies of the tasks another
    /// device holds (the thesis's pure static behaviour). Without it, the makespan without
    /// backups is reported beside.
    #[arg(long)]
    no_backups: bool,
    /// Device failures, `DEVICE@TIME`, comma-separated: `1@0.5` stops device 1 at time 0.5.
    #[arg(long, value_delimiter = ',', value_parser = fault_time)]
    fail: Vec<Fault>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Debug, Serialize)]
struct Report {
    policy: Policy,
    tasks: usize,
    devices: usize,
    speeds: Vec<f64>,
    /// The true speeds (`--actual-speeds`, else `speeds`).
    actual_speeds: Vec<f64>,
    latency: f64,
    /// Whether idle devices ran backup copies (false with `--no-backups`).
    backups: bool,
    makespan: f64,
    /// The makespan of the same run without backup copies (absent with `--no-backups`).
    makespan_without_backups: Option<f64>,
    /// The fastest device alone: every actual cost over its true speed, plus one latency.
    alone: f64,
    /// Backup copies launched.
    copies: u64,
    /// Time spent on copies whose output was dropped.
    wasted: f64,
    lower_bound: f64,
    /// makespan / lower_bound (1 when both are 0).
    ratio: f64,
    /// The factor of the optimum this policy is proven to stay within here, if any (none
    /// with latency, faults or actual costs that differ from the estimates).
    guarantee: Option<f64>,
    balance_efficiency: f64,
    busy: Vec<f64>,
    launches: Vec<u64>,
    reruns: u64,
    plan_seconds: f64,
    simulate_seconds: f64,
    /// The device that ran each task, in input order.
    assignment: Vec<u32>,
}

/// Runs the command and prints its report.
pub fn run(args: Args) -> Result<(), CliError> {
    if args.costs == Path::new("-") && args.actual.as_deref() == Some(Path::new("-")) {
        return Err(CliError::Arg {
            flag: "actual",
            value: "-".into(),
            message: "--costs already reads standard input".into(),
        });
    }
    fn named(path: &Path) -> impl FnOnce(sched::SchedError) -> CliError + '_ {
        move |e| CliError::Read {
            path: path.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
        }
    }
    let estimated = Costs::new(read_costs(&args.costs)?).map_err(named(&args.costs))?;
    let actual = match &args.actual {
        Some(path) => Costs::new(read_costs(path)?).map_err(named(path))?,
        None => estimated.clone(),
    };
    let speeds = speeds_of("speeds", &args.speeds)?;
    let true_speeds = match &args.actual_speeds {
        Some(s) => {
            let checked = speeds_of("actual-speeds", s)?;
            if checked.len() != speeds.len() {
                return Err(CliError::Arg {
                    flag: "actual-speeds",
                    value: typed(s),
                    message: format!("one speed per device of --speeds ({})", speeds.len()),
                });
            }
            checked
        }
        None => speeds.clone(),
    };
    let faults = &args.fail;
    let device = |f: &Fault| format!("device {}", f.device);
    crate::args::distinct("fail", faults, device, |f| format!("{}@{}", f.device, f.at))?;
    // The proven factors hold for exact estimates and speeds, no latency and no failures.
    let ideal = faults.is_empty()
        && args.latency == 0.0
        && estimated == actual
        && true_speeds.as_slice() == speeds.as_slice();
    let mut sim = Simulation::new(args.policy, speeds.clone()).latency(args.latency);
    for &fault in faults {
        sim = sim.fault(fault);
    }
    let seconds = |t: usize, d: usize| actual[t] / true_speeds[d];

    let simulating = Instant::now();
    let result = sim
        .clone()
        .backups(!args.no_backups)
        .run_timed(&estimated, &seconds)?;
    let simulate_seconds = simulating.elapsed().as_secs_f64();
    let without = if args.no_backups {
        None
    } else {
        Some(sim.backups(false).run_timed(&estimated, &seconds)?)
    };
    let fastest = true_speeds.as_slice().iter().copied().fold(0.0, f64::max);
    let alone = actual.as_slice().iter().map(|c| c / fastest).sum::<f64>() + args.latency;

    let bound = lower_bound(&actual, &true_speeds);
    let makespan = result.metrics.makespan;
    // The costs' sum is finite, but divided by slow speeds or plus a latency it may not be.
    let makespan_without_backups = without.map(|w| w.metrics.makespan);
    let finite = [makespan, bound, alone, result.metrics.balance_efficiency]
        .into_iter()
        .chain(result.metrics.busy.iter().copied())
        .chain(makespan_without_backups)
        .all(f64::is_finite);
    if !finite {
        return Err(CliError::Arg {
            flag: "speeds",
            value: typed(&args.speeds),
            message: format!(
                "the costs divided by these speeds (plus --latency {}) overflow: a makespan \
                 of {makespan:e} cannot be reported; scale the costs down",
                args.latency
            ),
        });
    }
    let report = Report {
        policy: args.policy,
        tasks: estimated.len(),
        devices: speeds.len(),
        speeds: speeds.as_slice().to_vec(),
        actual_speeds: true_speeds.as_slice().to_vec(),
        latency: args.latency,
        backups: !args.no_backups,
        makespan,
        makespan_without_backups,
        alone,
        copies: result.copies,
        wasted: result.wasted,
        lower_bound: bound,
        ratio: if bound > 0.0 { makespan / bound } else { 1.0 },
        guarantee: guarantee(args.policy, &speeds).filter(|_| ideal),
        balance_efficiency: result.metrics.balance_efficiency,
        busy: result.metrics.busy,
        launches: result.launches,
        reruns: result.reruns,
        plan_seconds: result.plan_seconds,
        simulate_seconds,
        assignment: result.assignment,
    };
    if args.json {
        crate::print::print_json(&report)
    } else {
        crate::print::print_text(&table(&report))
    }
}

/// `values` as device speeds; an error names `flag` and the values as typed.
fn speeds_of(flag: &'static str, values: &[f64]) -> Result<Speeds, CliError> {
    Speeds::new(values.to_vec()).map_err(|e| CliError::Arg {
        flag,
        value: typed(values),
        message: e.to_string(),
    })
}

/// Speeds as they were typed: comma-separated.
fn typed(values: &[f64]) -> String {
    let text: Vec<String> = values.iter().map(f64::to_string).collect();
    text.join(",")
}

fn table(r: &Report) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let guarantee = r
        .guarantee
        .map_or(String::from("no proven factor here"), |g| {
            format!("proven ≤ {g:.4} × optimum")
        });
    // Writing to a String cannot fail.
    let _ = writeln!(out, "policy        {}", r.policy);
    let _ = writeln!(out, "tasks         {} on {} devices", r.tasks, r.devices);
    match r.makespan_without_backups {
        Some(without) => {
            let _ = writeln!(
                out,
                "makespan      {}  (without backup copies {without}; {} copies, {} wasted)",
                r.makespan, r.copies, r.wasted
            );
        }
        None => {
            let _ = writeln!(out, "makespan      {}  (no backup copies)", r.makespan);
        }
    }
    let _ = writeln!(
        out,
        "alone         {}  (the fastest device, every task at its true speed)",
        r.alone
    );
    let _ = writeln!(
        out,
        "lower bound   {}  (makespan / bound = {:.4}; {guarantee})",
        r.lower_bound, r.ratio
    );
    let _ = writeln!(out, "balance       {:.2} %", 100.0 * r.balance_efficiency);
    let _ = writeln!(out, "reruns        {}\n", r.reruns);
    let _ = writeln!(out, "| device | speed | tasks | busy | launches |");
    let _ = writeln!(out, "|---:|---:|---:|---:|---:|");
    for d in 0..r.devices {
        let tasks = r.assignment.iter().filter(|&&a| a as usize == d).count();
        let _ = writeln!(
            out,
            "| {d} | {} | {tasks} | {:.6} | {} |",
            r.speeds[d], r.busy[d], r.launches[d]
        );
    }
    out
}
