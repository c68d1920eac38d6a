//! Scheduled contact pairs equal the all-pairs reference on random worlds, for every policy.

use collision::{BroadPhaseCount, Device, SampleRate, Swarms, World, random_bodies, terrain};
use proptest::prelude::*;
use sched::{CostEstimator, Costs, Policy, Runtime};

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn scheduled_contacts_equal_brute_force(
        n in 1usize..80,
        side in 1usize..8,
        swarms in 0usize..4,
        size in 0.01f32..0.08,
        task_size in 1usize..20,
        devices in 1usize..4,
        seed in any::<u64>(),
    ) {
        let spec = Swarms { swarms, crowded: 0.6, sigma: 0.05, size };
        let world = World::new(random_bodies(n, spec, seed), terrain(side).unwrap());
        let reference = collision::brute_force(&world);
        let tasks = sched::split_ranges(world.len(), task_size);
        let costs = BroadPhaseCount::new(&world, SampleRate::new(0.5).unwrap())
            .estimate_timed(&tasks).unwrap().costs;
        for policy in Policy::ALL {
            for plan in [&costs, &Costs::uniform(tasks.len())] {
                let run = Runtime::new(policy).run(&tasks, plan, &mut Device::many(&world, devices)).unwrap();
                let mut pairs: Vec<_> = run.outputs.into_iter().flatten().collect();
                pairs.sort_unstable();
                prop_assert_eq!(&pairs, &reference, "{}", policy);
            }
        }
    }
}

#[test]
fn full_sampling_has_no_prediction_error() {
    let world = World::new(
        random_bodies(400, Swarms::default(), 5),
        terrain(8).unwrap(),
    );
    let tasks = sched::split_ranges(world.len(), 16);
    let full = BroadPhaseCount::new(&world, SampleRate::new(1.0).unwrap()).estimate(&tasks);
    let some = BroadPhaseCount::new(&world, SampleRate::new(0.25).unwrap()).estimate(&tasks);
    assert_eq!(collision::prediction_error(&full, &full), Some(0.0));
    assert!(collision::prediction_error(&some, &full).unwrap() > 0.0);
    assert!(SampleRate::new(0.0).is_err() && SampleRate::new(2.0).is_err());
}
