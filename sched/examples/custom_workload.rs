//! A workload of your own on `sched`: a task type, a device that runs it, and a run.
//!
//! The workload is a Mandelbrot image cut into bands of rows. It is irregular in the way
//! that matters to a scheduler: a band through the set iterates every pixel to the cap, a
//! band outside it stops after a few iterations, so equal-sized tasks cost very different
//! amounts.
//!
//! Run it with `cargo run -p sched --example custom_workload`.

use sched::{ByItems, CostEstimator, DeviceError, Executor, Policy, Runtime, Task};

const WIDTH: u32 = 256;
const HEIGHT: u32 = 192;
const MAX_ITER: u32 = 500;

/// One task: a band of image rows. A task can be any type the devices know how to run;
/// `sched` only asks how many items it holds (for throughput reports) and that it can be
/// shared between the device threads (`Sync`).
#[derive(Debug, Clone, Copy)]
struct Band {
    first_row: u32,
    rows: u32,
}

impl Task for Band {
    fn items(&self) -> usize {
        (self.rows * WIDTH) as usize
    }
}

/// Escape-time iterations of the pixel `(x, y)`.
fn iterations(x: u32, y: u32) -> u32 {
    let c = (
        -2.2 + 3.2 * f64::from(x) / f64::from(WIDTH),
        -1.2 + 2.4 * f64::from(y) / f64::from(HEIGHT),
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

/// A device. Here each is a host thread; a GPU or a remote node would implement the same
/// trait, and would override `run_batch` to run a whole plan in one launch.
struct Renderer {
    name: &'static str,
    /// Relative speed the policies plan with. Both devices here are threads of the same
    /// machine, so 1.0; a device twice as fast would say 2.0 and get about twice the work.
    speed: f64,
    /// Fails on its first task, to show that a failing device loses no work.
    fails: bool,
}

impl Executor<Band> for Renderer {
    /// The output of one task: its pixels' iteration counts, row by row.
    type Output = Vec<u32>;

    fn run(&mut self, band: &Band) -> Result<Vec<u32>, DeviceError> {
        if self.fails {
            // Any error type converts into a `DeviceError`; the runtime retires this device
            // and re-runs its unfinished tasks on the others.
            return Err(DeviceError::msg(format!("{} lost its context", self.name)));
        }
        let rows = band.first_row..band.first_row + band.rows;
        Ok(rows
            .flat_map(|y| (0..WIDTH).map(move |x| iterations(x, y)))
            .collect())
    }

    fn speed(&self) -> f64 {
        self.speed
    }

    fn name(&self) -> String {
        self.name.to_string()
    }
}

fn main() -> Result<(), sched::SchedError> {
    let bands: Vec<Band> = (0..HEIGHT)
        .step_by(8)
        .map(|first_row| Band { first_row, rows: 8 })
        .collect();

    // Costs are needed before anything runs. Counting items is the cheapest estimate, and a
    // poor one here: every band has as many pixels. `custom_estimator.rs` does better.
    let costs = ByItems.estimate_timed(&bands)?.costs;

    let mut devices = [
        Renderer {
            name: "cpu-0",
            speed: 1.0,
            fails: false,
        },
        Renderer {
            name: "cpu-1",
            speed: 1.0,
            fails: true,
        },
    ];
    // A static plan: each device gets its list up front and runs it in one launch, so
    // cpu-1 surely gets tasks, fails on the first, and cpu-0 runs the rest of its list.
    let run = Runtime::new(Policy::StaticLpt).run(&bands, &costs, &mut devices)?;

    // One output per task, in task order, whoever ran it and however often it was retried:
    // the image is complete although cpu-1 failed partway.
    let image: Vec<u32> = run.outputs.concat();
    assert_eq!(image.len(), (WIDTH * HEIGHT) as usize);
    let reference: Vec<u32> = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| iterations(x, y)))
        .collect();
    assert_eq!(image, reference);
    assert_eq!(run.failures.len(), 1);

    let failure = &run.failures[0];
    println!(
        "{} tasks on {} devices in {:.1} ms; {} failed ({}), {} task run(s) lost and re-run",
        bands.len(),
        devices.len(),
        run.metrics.makespan * 1e3,
        failure.name,
        failure.reason,
        run.reruns,
    );
    let iterations: u64 = image.iter().map(|&i| u64::from(i)).sum();
    println!("{iterations} iterations in all, checked against a sequential render");
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
