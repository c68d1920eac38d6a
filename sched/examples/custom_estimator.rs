//! A cost estimator of your own: predict each task's cost cheaply, before it runs, so a
//! static plan can balance tasks whose costs differ.
//!
//! The workload is a Mandelbrot image cut into ranges of pixels; a pixel costs its
//! escape-time iterations. The estimator iterates a sample of each task's pixels (every
//! eighth) and scales up: a reduced version of the real work, the same idea as estimating a
//! ray tracing task by traversing a sample of its rays. It is checked against the full
//! count, then used to plan on simulated devices of mixed speeds.
//!
//! Run it with `cargo run -p sched --example custom_estimator`.

use std::ops::Range;

use sched::{
    ByItems, CostEstimator, Costs, Policy, SampleRate, SchedError, Simulation, Speeds, bounds,
    prediction_error,
};

const WIDTH: usize = 320;
const HEIGHT: usize = 240;
const MAX_ITER: u32 = 400;

/// Escape-time iterations of pixel `p` (row-major).
fn iterations(p: usize) -> u32 {
    let (x, y) = ((p % WIDTH) as f64, (p / WIDTH) as f64);
    let c = (
        -2.2 + 3.2 * x / WIDTH as f64,
        -1.2 + 2.4 * y / HEIGHT as f64,
    );
    let mut z = (0.0f64, 0.0f64);
    for i in 0..MAX_ITER {
        if z.0 * z.0 + z.1 * z.1 > 4.0 {
            return i;
        }
        z = (z.0 * z.0 - z.1 * z.1 + c.0, 2.0 * z.0 * z.1 + c.1);
    }
    MAX_ITER
}

/// Iterates every `stride`-th pixel of a task and scales the sum to the whole task.
///
/// Only `estimate` is required; `estimate_timed` (provided) checks that there is one
/// finite, non-negative cost per task and times the call, since an estimate that costs as
/// much as the work it plans is no gain.
struct SampledIterations {
    rate: SampleRate,
}

impl CostEstimator<Range<usize>> for SampledIterations {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        let stride = self.rate.stride();
        tasks
            .iter()
            .map(|task| {
                let sampled: u64 = task
                    .clone()
                    .step_by(stride)
                    .map(|p| u64::from(iterations(p)))
                    .sum();
                // Scaled by the share of the task sampled, so that tasks of different sizes
                // (the last one is shorter) stay comparable.
                let taken = task.len().div_ceil(stride);
                sampled as f64 * task.len() as f64 / taken.max(1) as f64
            })
            .collect()
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let tasks = sched::split_ranges(WIDTH * HEIGHT, 1024);

    // The truth, for this demonstration only: every pixel iterated. A real workload would
    // measure task times instead (`RunReport::timeline`).
    let actual = SampledIterations {
        rate: SampleRate::FULL,
    }
    .estimate_timed(&tasks)?;
    let sampled = SampledIterations {
        rate: SampleRate::new(0.125)?,
    }
    .estimate_timed(&tasks)?;
    let by_items = ByItems.estimate_timed(&tasks)?;

    // The error `sched` reports for every estimator: Σ|estimated − actual| / Σ actual.
    let error = prediction_error(sampled.costs.as_slice(), actual.costs.as_slice())
        .ok_or("the image has no work")?;
    println!(
        "sampled estimate: {:.1} % error, {:.2} ms against {:.2} ms for the full count",
        100.0 * error,
        1e3 * sampled.seconds,
        1e3 * actual.seconds
    );
    assert!(error < 0.1, "a 1/8 sample is within 10 % here: {error}");

    // Plan with each estimate, run on the actual costs: four devices of mixed speeds.
    let speeds = Speeds::new(vec![1.0, 1.0, 2.0, 4.0])?;
    let optimum = bounds::lower_bound(&actual.costs, &speeds);
    let makespan = |estimated: &Costs| -> Result<f64, SchedError> {
        let sim = Simulation::new(Policy::StaticLpt, speeds.clone());
        Ok(sim.run_actual(estimated, &actual.costs)?.metrics.makespan)
    };
    let blind = makespan(&by_items.costs)? / optimum;
    let informed = makespan(&sampled.costs)? / optimum;
    println!(
        "static LPT, makespan over the lower bound: by items {blind:.3}, sampled {informed:.3}"
    );
    assert!(informed < blind, "the estimate beats counting pixels");
    Ok(())
}

// `cargo test` runs the example too (`test = true` in `sched/Cargo.toml`), so it cannot rot.
#[cfg(test)]
mod tests {
    #[test]
    fn runs() {
        super::main().expect("the example runs");
    }
}
