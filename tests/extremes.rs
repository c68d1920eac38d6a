use std::time::Instant;

use sched::bounds::lower_bound;
use sched::{Costs, Policy, Simulation, Speeds};

use crate::testkit::Rng;

#[test]
fn costs_spanning_twenty_four_decades_are_planned_exactly() {
    let mut rng = Rng::from_env(11);
    let c: Vec<f64> = (0..10_000)
        .map(|_| 10f64.powf(rng.range(-12.0, 12.0)))
        .collect();
    let costs = Costs::new(c).unwrap();
    for m in [1, 2, 3, 64] {
        let speeds = Speeds::identical(m).unwrap();
        let lb = lower_bound(&costs, &speeds);
        for policy in Policy::ALL {
            let r = Simulation::new(policy, speeds.clone()).run(&costs).unwrap();
            // The few huge costs dominate: every policy that sorts ends at the bound.
            assert!(
                r.metrics.makespan >= lb * (1.0 - 1e-12),
                "{policy} below the lower bound"
            );
            if policy != Policy::StaticEqual && policy != Policy::QueueFifo {
                assert!(
                    r.metrics.makespan <= lb * (1.0 + 1e-9) || m == 64,
                    "{policy} on {m}: {} vs {lb}",
                    r.metrics.makespan
                );
            }
        }
    }
}

#[test]
fn a_million_equal_costs_on_1024_devices_split_exactly() {
    let costs = Costs::new(vec![0.1; 1_000_000]).unwrap();
    let speeds = Speeds::identical(1024).unwrap();
    for policy in Policy::ALL {
        let r = Simulation::new(policy, speeds.clone()).run(&costs).unwrap();
        // 1_000_000 = 976 · 1024 + 576: the busiest devices run 977 tasks.
        let expected = sched::Load::sum(std::iter::repeat_n(0.1, 977)).value();
        assert_eq!(r.metrics.makespan, expected, "{policy}");
        let mut per_device = vec![0u32; 1024];
        for &d in &r.assignment {
            per_device[d as usize] += 1;
        }
        assert!(per_device.iter().all(|&k| k == 976 || k == 977), "{policy}");
    }
}

#[test]
fn simulates_a_million_tasks_on_1024_devices_quickly() {
    let mut rng = Rng::from_env(3);
    let costs = Costs::new(
        (0..1_000_000)
            .map(|_| rng.range(0.0, 1.0).powi(4))
            .collect(),
    )
    .unwrap();
    let mut s = vec![1.0; 768];
    s.extend(std::iter::repeat_n(8.0, 256));
    let speeds = Speeds::new(s).unwrap();
    for policy in Policy::ALL {
        let start = Instant::now();
        // Backup copies weigh every held task at each idle device's turn: too slow at this
        // scale, where the plan alone is timed.
        let r = Simulation::new(policy, speeds.clone())
            .latency(1e-5)
            .backups(false)
            .run(&costs)
            .unwrap();
        let seconds = start.elapsed().as_secs_f64();
        eprintln!(
            "{policy}: {seconds:.3} s, makespan / lower bound {:.4}",
            r.metrics.makespan / lower_bound(&costs, &speeds)
        );
        // The bench measures this properly; here only a gross regression fails (CI is noisy).
        assert!(seconds < 3.0, "{policy} took {seconds} s");
        assert!(r.assignment.iter().all(|&d| d < 1024));
    }
}

#[test]
fn one_task_and_zero_tasks() {
    let speeds = Speeds::new(vec![1.0, 4.0]).unwrap();
    for policy in Policy::ALL {
        let one = Simulation::new(policy, speeds.clone())
            .run(&Costs::new(vec![2.0]).unwrap())
            .unwrap();
        assert_eq!(one.assignment.len(), 1);
        let none = Simulation::new(policy, speeds.clone())
            .run(&Costs::default())
            .unwrap();
        assert_eq!(none.metrics.makespan, 0.0);
        assert_eq!(none.metrics.balance_efficiency, 1.0);
    }
}
