//! Planning time of each policy, and whole simulations, from 10^3 to 10^6 tasks on 2 to 1024
//! devices. Run: `cargo bench --bench sched`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use sched::{Costs, Policy, Simulation, Speeds};
use std::hint::black_box;

/// Irregular costs: a heavy tail like ray-tracing tasks (most cheap, a few very costly).
fn costs(n: usize) -> Costs {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    Costs::new(
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                ((state >> 11) as f64 / (1u64 << 53) as f64).powi(4)
            })
            .collect(),
    )
    .expect("generated costs are finite and non-negative")
}

/// A quarter of the devices eight times faster: GPUs beside CPU cores.
fn speeds(m: usize) -> Speeds {
    Speeds::new((0..m).map(|d| if d % 4 == 3 { 8.0 } else { 1.0 }).collect())
        .expect("positive speeds")
}

fn planning(c: &mut Criterion) {
    let mut group = c.benchmark_group("plan");
    group.sample_size(10);
    for n in [1_000, 10_000, 100_000, 1_000_000] {
        let costs = costs(n);
        group.throughput(Throughput::Elements(n as u64));
        for m in [2, 16, 1024] {
            let speeds = speeds(m);
            for policy in Policy::ALL {
                group.bench_with_input(
                    BenchmarkId::new(policy.name(), format!("{n}x{m}")),
                    &(&costs, &speeds),
                    |b, (costs, speeds)| b.iter(|| black_box(policy.dispatcher(costs, speeds))),
                );
            }
        }
    }
    group.finish();
}

fn simulation(c: &mut Criterion) {
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    let costs = costs(1_000_000);
    let speeds = speeds(1024);
    group.throughput(Throughput::Elements(1_000_000));
    for policy in Policy::ALL {
        let sim = Simulation::new(policy, speeds.clone()).latency(1e-5);
        group.bench_function(BenchmarkId::new(policy.name(), "1000000x1024"), |b| {
            b.iter(|| black_box(sim.run(&costs).expect("no faults")))
        });
    }
    group.finish();
}

criterion_group!(benches, planning, simulation);
criterion_main!(benches);
