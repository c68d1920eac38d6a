//! Scheduled kNN results equal the brute-force reference on random clouds, for every policy.

use knn::{
    Clustered, DensityEstimator, DensityGrid, Device, KnnIndex, KnnQueries, PointCloud, SampleRate,
    SampledQueries,
};
use proptest::prelude::*;
use sched::{CostEstimator, Costs, Policy, Runtime};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn scheduled_knn_equals_brute_force(
        n in 40usize..600,
        m in 1usize..300,
        k in 1usize..12,
        task_size in 1usize..64,
        devices in 1usize..4,
        clusters in 0usize..5,
        seed in any::<u64>(),
        density in any::<bool>(),
    ) {
        let spec = Clustered { clusters, noise: 0.2, sigma: 0.02 };
        let cloud = PointCloud::clustered(n, spec, seed);
        let queries = cloud.queries(m, seed.wrapping_add(1));
        let index = KnnIndex::build(cloud.points.clone()).unwrap();
        let batch = KnnQueries::new(queries.clone(), k, &index).unwrap();
        let tasks = sched::split_ranges(batch.len(), task_size);
        let rate = SampleRate::new(0.25).unwrap();
        let grid = DensityGrid::new(index.points(), 8);
        let costs = if density {
            DensityEstimator::new(&grid, &batch, rate).estimate_timed(&tasks).unwrap().costs
        } else {
            SampledQueries::new(&index, &batch, rate).estimate_timed(&tasks).unwrap().costs
        };
        for policy in Policy::ALL {
            for plan in [&costs, &Costs::uniform(tasks.len())] {
                let mut devs = Device::many(&index, &batch, devices);
                let run = Runtime::new(policy).run(&tasks, plan, &mut devs).unwrap();
                let got = batch.gather(&run.outputs);
                for (i, q) in queries.iter().enumerate() {
                    prop_assert!(knn::reference::is_knn(index.points(), q, k, &got[i * k..(i + 1) * k]),
                        "{policy}: query {i} {q:?}");
                }
            }
        }
    }
}

#[test]
fn bad_inputs_are_named() {
    let index = KnnIndex::build(PointCloud::uniform(10, 1).points).unwrap();
    let err = KnnQueries::new(vec![[0.0; 3]], 11, &index).unwrap_err();
    assert!(err.to_string().contains("k = 11"), "{err}");
    let err = KnnQueries::new(vec![[0.0, f32::NAN, 0.0]], 1, &index).unwrap_err();
    assert!(err.to_string().contains("point 0"), "{err}");
    assert!(SampleRate::new(0.0).is_err() && SampleRate::new(1.5).is_err());
    let _ = Clustered::default();
}

#[test]
fn full_sampling_has_no_prediction_error() {
    let cloud = PointCloud::clustered(5000, Clustered::default(), 9);
    let index = KnnIndex::build(cloud.points.clone()).unwrap();
    let batch = KnnQueries::new(cloud.queries(2000, 3), 8, &index).unwrap();
    let tasks = sched::split_ranges(batch.len(), 100);
    let grid = DensityGrid::new(index.points(), 16);
    let full = DensityEstimator::new(&grid, &batch, SampleRate::new(1.0).unwrap()).estimate(&tasks);
    let half = DensityEstimator::new(&grid, &batch, SampleRate::new(0.5).unwrap()).estimate(&tasks);
    assert_eq!(knn::prediction_error(&full, &full), Some(0.0));
    let e = knn::prediction_error(&half, &full).unwrap();
    assert!(e > 0.0 && e < 0.5, "{e}");
}
