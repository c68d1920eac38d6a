//! What `cobalt knn` and `cobalt collide` share: their run flags, and the policy comparison of
//! their workload ([`sched::study`]) printed as tables or JSON.

use std::ops::Range;

use sched::study::{Workload, measure};
use sched::{Executor, Policy, SampleRate};

use crate::args::count;
use crate::error::CliError;
use crate::limits::MAX_THREADS;

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
    work: &Workload<'_, E, CliError>,
    args: &RunArgs,
    rate: SampleRate,
) -> Result<(), CliError> {
    let policies = args.policy.map_or(Policy::ALL.to_vec(), |p| vec![p]);
    let report = measure(work, &policies, args.devices, rate)?;
    if args.json {
        crate::print::print_json(&report)
    } else {
        crate::print::print_text(&format!("{}\n\n{}", work.name, report.tables()))
    }
}
