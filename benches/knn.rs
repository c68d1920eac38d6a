//! kNN batches on a clustered cloud: the density estimator at two sampling rates, and a whole
//! batch run on two devices in regular and cost mode. Run: `cargo bench --bench knn`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use knn::{
    Clustered, DensityEstimator, DensityGrid, Device, KnnIndex, KnnQueries, PointCloud, SampleRate,
};
use sched::{CostEstimator, Costs, Policy, Runtime};
use std::hint::black_box;

fn knn(c: &mut Criterion) {
    let cloud = PointCloud::clustered(50_000, Clustered::default(), 1);
    let queries = cloud.queries(20_000, 2);
    let index = KnnIndex::build(cloud.points).expect("finite points");
    let batch = KnnQueries::new(queries, 16, &index).expect("k fits");
    let grid = DensityGrid::new(index.points(), 64);
    let tasks = sched::split_ranges(batch.len(), 512);
    let mut group = c.benchmark_group("knn");
    group.sample_size(10);
    group.throughput(Throughput::Elements(batch.len() as u64));
    for rate in [0.125, 1.0] {
        let est = DensityEstimator::new(&grid, &batch, SampleRate::new(rate).expect("rate"));
        group.bench_function(format!("estimate-{rate}"), |b| {
            b.iter(|| black_box(est.estimate(&tasks)))
        });
    }
    let est = DensityEstimator::new(&grid, &batch, SampleRate::new(0.125).expect("rate"));
    let costs = est.estimate_timed(&tasks).expect("valid costs").costs;
    for (mode, plan) in [("regular", Costs::uniform(tasks.len())), ("cost", costs)] {
        group.bench_function(format!("run-static-lpt-{mode}"), |b| {
            b.iter(|| {
                let mut devices = Device::many(&index, &batch, 2);
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

criterion_group!(benches, knn);
criterion_main!(benches);
