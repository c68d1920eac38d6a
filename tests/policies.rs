use proptest::prelude::*;
use sched::bounds::{
    LPT_UNIFORM_FACTOR, fractional_bound, list_factor, lower_bound, lpt_identical_factor,
};
use sched::exact::optimal_makespan;
use sched::{Costs, Fault, Policy, SchedError, Simulation, Speeds};

use crate::testkit::Rng;

/// Relative slack for rounding: the bounds are exact in real arithmetic.
const EPS: f64 = 1e-9;

/// Costs that exercise ties (small integers) and wide ranges (log-uniform floats).
fn costs(max_n: usize) -> impl Strategy<Value = Vec<f64>> {
    prop_oneof![
        prop::collection::vec((1u32..20).prop_map(f64::from), 0..=max_n),
        prop::collection::vec((-3.0f64..3.0).prop_map(|e| 10f64.powf(e)), 0..=max_n),
        prop::collection::vec(0.0f64..1.0, 0..=max_n),
    ]
}

fn speeds(max_m: usize) -> impl Strategy<Value = Vec<f64>> {
    prop::collection::vec(
        prop_oneof![Just(1.0), Just(2.0), Just(2.5), 0.25f64..4.0],
        1..=max_m,
    )
}

fn makespan(policy: Policy, costs: &Costs, speeds: &Speeds) -> f64 {
    Simulation::new(policy, speeds.clone())
        .run(costs)
        .expect("no faults, so the run completes")
        .metrics
        .makespan
}

fn within(value: f64, factor: f64, opt: f64) -> bool {
    value <= factor * opt * (1.0 + EPS) + f64::MIN_POSITIVE
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn lpt_within_four_thirds_on_identical_devices(c in costs(10), m in 1usize..=4) {
        let (costs, speeds) = (Costs::new(c).unwrap(), Speeds::identical(m).unwrap());
        let opt = optimal_makespan(&costs, &speeds);
        // A cost-sorted queue on identical devices with exact costs makes LPT's choices.
        for policy in [Policy::StaticLpt, Policy::QueueSorted, Policy::Hybrid] {
            let got = makespan(policy, &costs, &speeds);
            prop_assert!(within(got, lpt_identical_factor(m), opt), "{policy} {got} vs OPT {opt} on {m}");
        }
        prop_assert!(opt >= lower_bound(&costs, &speeds) * (1.0 - EPS));
    }

    #[test]
    fn every_list_schedule_within_two(c in costs(10), m in 1usize..=4, seed in any::<u64>()) {
        let speeds = Speeds::identical(m).unwrap();
        let costs = Costs::new(c.clone()).unwrap();
        let opt = optimal_makespan(&costs, &speeds);
        // A queue in any order is a list schedule: shuffle the tasks, run them FIFO.
        let mut shuffled = c;
        let mut state = seed | 1;
        for i in (1..shuffled.len()).rev() {
            state ^= state << 13; state ^= state >> 7; state ^= state << 17;
            shuffled.swap(i, (state % (i as u64 + 1)) as usize);
        }
        let shuffled = Costs::new(shuffled).unwrap();
        for (policy, costs) in [(Policy::QueueFifo, &costs), (Policy::QueueSorted, &costs), (Policy::QueueFifo, &shuffled)] {
            let got = makespan(policy, costs, &speeds);
            prop_assert!(within(got, list_factor(m), opt), "{policy}: {got} vs OPT {opt} on {m}");
        }
    }

    #[test]
    fn lpt_within_kovacs_bound_on_mixed_speeds(c in costs(10), s in speeds(4)) {
        let (costs, speeds) = (Costs::new(c).unwrap(), Speeds::new(s).unwrap());
        let opt = optimal_makespan(&costs, &speeds);
        let lpt = makespan(Policy::StaticLpt, &costs, &speeds);
        prop_assert!(within(lpt, LPT_UNIFORM_FACTOR, opt), "LPT {lpt} vs OPT {opt} on {speeds:?}");
        prop_assert!(opt >= lower_bound(&costs, &speeds) * (1.0 - EPS));
    }

    /// The integral bound is at least the fractional one and the largest task on the fastest
    /// device, and no plan (the exact optimum included) beats it.
    #[test]
    fn the_integral_bound_is_fair_and_sound(c in costs(9), s in speeds(4)) {
        let (costs, speeds) = (Costs::new(c.clone()).unwrap(), Speeds::new(s.clone()).unwrap());
        let bound = lower_bound(&costs, &speeds);
        prop_assert!(bound >= fractional_bound(&costs, &speeds) * (1.0 - EPS));
        let largest = c.iter().copied().fold(0.0, f64::max);
        let fastest = s.iter().copied().fold(0.0, f64::max);
        prop_assert!(bound >= largest / fastest * (1.0 - EPS));
        let opt = optimal_makespan(&costs, &speeds);
        prop_assert!(opt >= bound * (1.0 - EPS), "OPT {opt} below the bound {bound}");
        for policy in Policy::ALL {
            let got = makespan(policy, &costs, &speeds);
            prop_assert!(got >= bound * (1.0 - EPS), "{policy} {got} below the bound {bound}");
        }
    }

    #[test]
    fn hybrid_never_worse_than_its_lpt_start(c in costs(60), s in speeds(6)) {
        let (costs, speeds) = (Costs::new(c).unwrap(), Speeds::new(s).unwrap());
        let lpt = makespan(Policy::StaticLpt, &costs, &speeds);
        let hybrid = makespan(Policy::Hybrid, &costs, &speeds);
        prop_assert!(hybrid <= lpt * (1.0 + EPS), "hybrid {hybrid} > LPT {lpt}");
    }

    #[test]
    fn every_task_delivered_exactly_once_under_faults(
        c in costs(40),
        s in speeds(4),
        faults in prop::collection::vec((0usize..4, 0.0f64..20.0), 0..4),
        policy in prop::sample::select(Policy::ALL.to_vec()),
    ) {
        let (costs, speeds) = (Costs::new(c).unwrap(), Speeds::new(s).unwrap());
        let m = speeds.len();
        let mut sim = Simulation::new(policy, speeds).record_timeline(true);
        let mut failed = vec![false; m];
        for &(d, at) in &faults {
            if d < m {
                sim = sim.fault(Fault { device: d, at });
                failed[d] = true;
            }
        }
        match sim.run(&costs) {
            Ok(report) => {
                let spans = report.timeline.unwrap().spans;
                let mut seen = vec![0u32; costs.len()];
                for s in &spans {
                    seen[s.task as usize] += 1;
                    prop_assert_eq!(report.assignment[s.task as usize], s.device);
                }
                prop_assert!(seen.iter().all(|&k| k == 1), "{policy}: deliveries {seen:?}");
            }
            Err(SchedError::AllDevicesFailed { unfinished, .. }) => {
                prop_assert!(failed.iter().all(|&f| f), "{policy}: gave up with a live device");
                prop_assert!(unfinished > 0);
            }
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }
}

/// With estimates off by up to 5× either way, stealing the tail must pay off on average:
/// Hybrid ends closer to the lower bound than the static LPT plan it starts from, both run as
/// planned. Backup copies pay off for both.
#[test]
fn hybrid_absorbs_wrong_estimates() {
    let mut rng = Rng::from_env(7);
    // [policy][backups]
    let mut sums = [[0.0; 2]; 2];
    for _ in 0..300 {
        let m = 2 + rng.below(7);
        let n = 4 * m + rng.below(36 * m);
        let estimated: Vec<f64> = (0..n).map(|_| rng.range(0.1, 1.0)).collect();
        let actual: Vec<f64> = estimated
            .iter()
            .map(|c| c * 5f64.powf(rng.range(-1.0, 1.0)))
            .collect();
        let (estimated, actual) = (Costs::new(estimated).unwrap(), Costs::new(actual).unwrap());
        let speeds = Speeds::identical(m).unwrap();
        let lb = lower_bound(&actual, &speeds);
        for (p, policy) in [Policy::StaticLpt, Policy::Hybrid].into_iter().enumerate() {
            for (b, backups) in [false, true].into_iter().enumerate() {
                sums[p][b] += Simulation::new(policy, speeds.clone())
                    .backups(backups)
                    .run_actual(&estimated, &actual)
                    .unwrap()
                    .metrics
                    .makespan
                    / lb;
            }
        }
    }
    eprintln!(
        "mean makespan / lower bound, without and with backups: static-lpt {:.4} {:.4}, \
         hybrid {:.4} {:.4}",
        sums[0][0] / 300.0,
        sums[0][1] / 300.0,
        sums[1][0] / 300.0,
        sums[1][1] / 300.0
    );
    assert!(sums[1][0] < sums[0][0]);
    assert!(sums[0][1] < sums[0][0] && sums[1][1] < sums[1][0]);
}

/// Behind a network-like launch (200 µs on a run of about 45 ms), Hybrid launches a few times
/// per device, not once per halving of its list, and ends within 3 % of the lower bound:
/// halving down to single tasks paid the latency about a dozen times per device (1.044–1.066
/// on `cobalt bench --simulate 8`'s AO tasks).
#[test]
fn hybrid_pays_a_costly_launch_a_few_times_per_device() {
    let mut rng = Rng::from_env(11);
    let speeds = Speeds::new((0..8).map(|d| [1.0, 4.0, 2.0, 8.0][d % 4]).collect()).unwrap();
    let (mut ratio, mut launches) = (0.0, 0u64);
    const RUNS: usize = 20;
    for _ in 0..RUNS {
        let n = 500 + rng.below(3500);
        let raw: Vec<f64> = (0..n).map(|_| rng.range(0.1, 1.0)).collect();
        // Scaled so the lower bound is 45 ms on these speeds (their sum is 30).
        let scale = 0.045 * 30.0 / raw.iter().sum::<f64>();
        let actual: Vec<f64> = raw.iter().map(|c| c * scale).collect();
        let estimated: Vec<f64> = actual.iter().map(|c| c * rng.range(0.9, 1.1)).collect();
        let (estimated, actual) = (Costs::new(estimated).unwrap(), Costs::new(actual).unwrap());
        let sim = Simulation::new(Policy::Hybrid, speeds.clone())
            .latency(200e-6)
            .run_actual(&estimated, &actual)
            .unwrap();
        ratio += sim.metrics.makespan / lower_bound(&actual, &speeds);
        launches += sim.launches.iter().sum::<u64>();
    }
    let (ratio, per_device) = (ratio / RUNS as f64, launches as f64 / (RUNS * 8) as f64);
    eprintln!("mean makespan / lower bound {ratio:.4}, launches per device {per_device:.2}");
    assert!(ratio < 1.03 && per_device < 4.0, "{ratio} {per_device}");
}
