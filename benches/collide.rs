//! Collision batches: the broad-phase-count estimator at two sampling rates, and a whole batch
//! on two devices in regular and cost mode. Run: `cargo bench --bench collide`.

use collision::{BroadPhaseCount, Device, SampleRate, Swarms, World, random_bodies, terrain};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sched::{CostEstimator, Costs, Policy, Runtime};
use std::hint::black_box;

fn collide(c: &mut Criterion) {
    let world = World::new(
        random_bodies(5_000, Swarms::default(), 1),
        terrain(64).expect("terrain builds"),
    );
    let tasks = sched::split_ranges(world.len(), 64);
    let mut group = c.benchmark_group("collide");
    group.sample_size(10);
    group.throughput(Throughput::Elements(world.len() as u64));
    for rate in [0.125, 1.0] {
        let est = BroadPhaseCount::new(&world, SampleRate::new(rate).expect("rate"));
        group.bench_function(format!("estimate-{rate}"), |b| {
            b.iter(|| black_box(est.estimate(&tasks)))
        });
    }
    let est = BroadPhaseCount::new(&world, SampleRate::new(0.125).expect("rate"));
    let costs = est.estimate_timed(&tasks).expect("valid costs").costs;
    for (mode, plan) in [("regular", Costs::uniform(tasks.len())), ("cost", costs)] {
        group.bench_function(format!("run-static-lpt-{mode}"), |b| {
            b.iter(|| {
                let mut devices = Device::many(&world, 2);
                black_box(
                    Runtime::new(Policy::StaticLpt)
                        .run(&tasks, &plan, &mut devices)
                        .expect("runs"),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, collide);
criterion_main!(benches);
