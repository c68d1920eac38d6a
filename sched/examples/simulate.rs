//! The simulator: replay a policy on virtual devices to see how it would balance a workload,
//! before building devices or in place of a long measurement.
//!
//! `Simulation` reads a task's cost as its time on a device of speed 1, charges a latency
//! per launch, and can fail a device partway. It plans with the *estimated* costs and
//! advances time with the *actual* ones, so the effect of estimation error shows. Here:
//! heavy-tailed task costs, estimates off by up to ±30 %, eight devices of mixed speeds.
//!
//! Run it with `cargo run -p sched --example simulate`.

use sched::{Costs, Fault, Policy, Rng, Simulation, Speeds, bounds};

fn main() -> Result<(), sched::SchedError> {
    // A seeded generator, so every run prints the same table.
    let mut rng = Rng::new(2012);
    // Log-normal costs: most tasks cheap, a few 10–50 times the median, as rays through a
    // dense part of a scene or queries beside a dense cluster.
    let actual: Vec<f64> = (0..2000)
        .map(|_| f64::from(1e-4 * (1.5 * rng.normal()).exp()))
        .collect();
    let estimated: Vec<f64> = actual
        .iter()
        .map(|c| c * f64::from(rng.range(0.7, 1.3)))
        .collect();
    let (actual, estimated) = (Costs::new(actual)?, Costs::new(estimated)?);

    // Four slow devices, two twice as fast, two four times (CPU threads beside GPUs, say).
    let speeds = Speeds::new(vec![1.0, 1.0, 1.0, 1.0, 2.0, 2.0, 4.0, 4.0])?;
    // No schedule can beat this bound, so makespan / bound is how far from optimal a policy
    // is at most.
    let optimum = bounds::lower_bound(&actual, &speeds);

    println!("policy        makespan/bound  balance  launches  proven factor");
    for policy in Policy::ALL {
        // 10 µs a launch, about a GPU kernel launch: queue policies pay it per task.
        let sim = Simulation::new(policy, speeds.clone()).latency(10e-6);
        let report = sim.run_actual(&estimated, &actual)?;
        let guarantee = bounds::guarantee(policy, &speeds)
            .map_or("-".to_string(), |g| format!("{g:.3} (exact costs)"));
        println!(
            "{:<13} {:>14.3}  {:>7.3}  {:>8}  {guarantee}",
            policy.name(),
            report.metrics.makespan / optimum,
            report.metrics.balance_efficiency,
            report.launches.iter().sum::<u64>(),
        );
        assert_eq!(report.assignment.len(), actual.len());
    }

    // A fast device fails halfway through: what it was running, and what it had not started,
    // is re-run by the others, and every task is still delivered once.
    let sim = Simulation::new(Policy::Hybrid, speeds.clone()).fault(Fault {
        device: 7,
        at: 0.5 * optimum,
    });
    let report = sim.run_actual(&estimated, &actual)?;
    assert!(
        report
            .assignment
            .iter()
            .all(|&d| (d as usize) < speeds.len())
    );
    println!(
        "hybrid with device 7 failing at half the bound: makespan/bound {:.3}, {} task run(s) lost",
        report.metrics.makespan / optimum,
        report.reruns,
    );
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
