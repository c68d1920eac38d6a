//! `cobalt`: cost-balanced scheduling of irregular workloads, from the command line.

mod args;
mod bench;
mod calibration;
mod collide;
mod error;
mod estimate;
mod input;
mod knn;
mod limits;
mod output;
mod print;
mod render;
mod schedule;
mod spatial;
mod trace;
mod tradeoff;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "cobalt", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run the benchmark matrix of policies, task sizes and devices; print a table.
    Bench(bench::Args),
    /// Render a scene (Whitted or AO) to a PNG, with an optional cost image and JSON report.
    Render(render::Args),
    /// k-nearest-neighbour batches (kiddo) balanced in regular and cost mode; table or JSON.
    Knn(knn::Args),
    /// Contacts of many bodies (parry3d) balanced in regular and cost mode; table or JSON.
    Collide(collide::Args),
    /// Estimate task costs from sampled rays; judge each estimator by measured time.
    Estimate(estimate::Args),
    /// Plan task costs on devices with a policy; print makespan, lower bound and assignment.
    Schedule(schedule::Args),
    /// Trace binary rays through a scene's BVH; write binary hits and print timings.
    Trace(trace::Args),
    /// Measure what speed costs in accuracy: BVH presets, AO sample counts.
    Tradeoff(tradeoff::Args),
}

fn main() -> ExitCode {
    quiet_device_select();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Bench(args) => bench::run(args),
        Command::Render(args) => render::run(args),
        Command::Estimate(args) => estimate::run(args),
        Command::Knn(args) => knn::run(args),
        Command::Collide(args) => collide::run(args),
        Command::Schedule(args) => schedule::run(args),
        Command::Trace(args) => trace::run(args),
        Command::Tradeoff(args) => tradeoff::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One write for the whole line: under `mpirun` every rank may print at once, and
            // the pieces `eprintln!` writes one by one would interleave.
            let line = format!("cobalt: error: {e}\n");
            let _ = std::io::Write::write_all(&mut std::io::stderr().lock(), line.as_bytes());
            ExitCode::from(e.exit_code())
        }
    }
}

/// Turns off Mesa's Vulkan device-select layer unless the user set it: to order the GPUs by
/// the desktop's, it connects to Wayland and X11 at every instance creation, and without a
/// desktop it prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` on a
/// run that succeeds. cobalt chooses its adapters itself (`--devices`), so the order is not
/// needed.
fn quiet_device_select() {
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: called first in `main`, before any thread is started, so no other thread
        // can read the environment while it changes.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}
