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

/// What a heterogeneous instance is: actual costs and speeds, and what the policy is told.
#[derive(Debug, Clone)]
struct Mixed {
    actual: Vec<f64>,
    estimated: Vec<f64>,
    speeds: Vec<f64>,
    declared: Vec<f64>,
}

impl Mixed {
    /// The fastest device alone: every task, one after another, at that device's actual speed.
    fn alone(&self) -> f64 {
        let fastest = self.speeds.iter().copied().fold(0.0, f64::max);
        self.actual.iter().map(|c| c / fastest).sum()
    }

    /// The simulated makespan: planned on the estimates and declared speeds, timed on the
    /// actual costs and speeds.
    fn makespan(&self, policy: Policy, backups: bool, latency: f64) -> f64 {
        let estimated = Costs::new(self.estimated.clone()).expect("finite costs");
        Simulation::new(
            policy,
            Speeds::new(self.declared.clone()).expect("positive speeds"),
        )
        .backups(backups)
        .latency(latency)
        .run_timed(&estimated, &|t, d| self.actual[t] / self.speeds[d])
        .expect("no faults")
        .metrics
        .makespan
    }
}

/// 1 to 8 devices whose speeds differ up to 10^4 times, estimates and declared speeds each
/// wrong by up to `wrong` times either way.
fn mixed(wrong: f64) -> impl Strategy<Value = Mixed> {
    (1usize..=8, 0usize..=40).prop_flat_map(move |(m, n)| {
        let spread = wrong.log10();
        (
            prop::collection::vec(-3.0f64..3.0, n),
            prop::collection::vec(-spread..=spread, n),
            prop::collection::vec(-4.0f64..=0.0, m),
            prop::collection::vec(-spread..=spread, m),
        )
            .prop_map(|(c, ce, s, se)| {
                let actual: Vec<f64> = c.iter().map(|e| 10f64.powf(*e)).collect();
                let speeds: Vec<f64> = s.iter().map(|e| 10f64.powf(*e)).collect();
                Mixed {
                    estimated: actual
                        .iter()
                        .zip(&ce)
                        .map(|(a, e)| a * 10f64.powf(*e))
                        .collect(),
                    declared: speeds
                        .iter()
                        .zip(&se)
                        .map(|(v, e)| v * 10f64.powf(*e))
                        .collect(),
                    actual,
                    speeds,
                }
            })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// With backups, no policy ends after the fastest device would alone: every task one
    /// after another at that device's actual speed (the sum of the actual costs over its
    /// speed), in one launch; with estimates wrong by up to 10× either way and no latency.
    #[test]
    fn with_backups_no_run_waits_for_a_slower_device(
        inst in mixed(10.0),
        policy in prop::sample::select(Policy::ALL.to_vec()),
    ) {
        let inst = Mixed { declared: inst.speeds.clone(), ..inst };
        let alone = inst.alone();
        let got = inst.makespan(policy, true, 0.0);
        prop_assert!(within(got, 1.0, alone), "{policy}: {got} vs alone {alone}");
    }

    /// With a launch latency, a static plan with exact estimates ends at most one latency
    /// after the fastest device alone (its one launch paying the latency too): its idle
    /// fastest device starts its copies unless the holder is expected to finish first.
    #[test]
    fn with_backups_and_latency_at_most_one_launch_more(
        inst in mixed(1.0),
        latency in 1e-3f64..1.0,
        policy in prop::sample::select(vec![Policy::StaticEqual, Policy::StaticLpt]),
    ) {
        let alone = inst.alone() + latency;
        let got = inst.makespan(policy, true, latency);
        prop_assert!(within(got, 1.0, alone + latency), "{policy}: {got} vs alone {alone}");
    }

    /// The same with the declared speeds wrong by up to 10× as well, without latency.
    #[test]
    fn with_backups_wrong_speeds_do_not_hold_the_end(
        inst in mixed(10.0),
        policy in prop::sample::select(Policy::ALL.to_vec()),
    ) {
        let alone = inst.alone();
        let got = inst.makespan(policy, true, 0.0);
        prop_assert!(within(got, 1.0, alone), "{policy}: {got} vs alone {alone}");
    }

    /// Backups change nothing of the proven bounds on identical devices with exact costs.
    #[test]
    fn backups_keep_the_proven_bounds(c in costs(10), m in 1usize..=4) {
        let (costs, speeds) = (Costs::new(c).unwrap(), Speeds::identical(m).unwrap());
        let opt = optimal_makespan(&costs, &speeds);
        // Static-equal ignores costs and carries no bound.
        for (policy, factor) in [
            (Policy::StaticLpt, lpt_identical_factor(m)),
            (Policy::QueueSorted, lpt_identical_factor(m)),
            (Policy::Hybrid, lpt_identical_factor(m)),
            (Policy::QueueFifo, list_factor(m)),
        ] {
            let got = Simulation::new(policy, speeds.clone()).backups(true).run(&costs).unwrap().metrics.makespan;
            prop_assert!(within(got, factor, opt), "{policy} {got} vs OPT {opt} on {m}");
        }
    }

    /// With backups and faults, every output is delivered exactly once, and a failed device's
    /// unfinished tasks are run again once each.
    #[test]
    fn backups_deliver_once_and_rerun_a_failed_devices_tasks_once(
        inst in mixed(10.0),
        faults in prop::collection::vec((0usize..8, 0.0f64..20.0), 0..4),
        policy in prop::sample::select(Policy::ALL.to_vec()),
    ) {
        let m = inst.speeds.len();
        let estimated = Costs::new(inst.estimated.clone()).unwrap();
        let mut sim = Simulation::new(policy, Speeds::new(inst.declared.clone()).unwrap())
            .record_timeline(true);
        let mut failed = vec![false; m];
        for &(d, at) in &faults {
            if d < m {
                sim = sim.fault(Fault { device: d, at });
                failed[d] = true;
            }
        }
        match sim.run_timed(&estimated, &|t, d| inst.actual[t] / inst.speeds[d]) {
            Ok(report) => {
                let mut seen = vec![0u32; inst.actual.len()];
                for s in &report.timeline.unwrap().spans {
                    seen[s.task as usize] += 1;
                    let fault = faults.iter().filter(|f| f.0 == s.device as usize);
                    prop_assert!(s.end <= fault.map(|f| f.1).fold(f64::INFINITY, f64::min));
                }
                prop_assert!(seen.iter().all(|&k| k == 1), "{policy}: deliveries {seen:?}");
                prop_assert!(report.reruns as usize <= inst.actual.len());
            }
            Err(SchedError::AllDevicesFailed { unfinished, .. }) => {
                prop_assert!(failed.iter().all(|&f| f), "{policy}: gave up with a live device");
                prop_assert!(unfinished > 0);
            }
            Err(e) => prop_assert!(false, "unexpected error {e}"),
        }
    }
}

/// One fast device and one to three slower ones (5 to 10^4 times slower), actual costs 0.5 to
/// 2 times the estimates, and, in half the instances, the slow devices 10 times slower than
/// declared: with backups, every policy ends within 0.1 % of the fast device alone (every
/// task at its true speed). Without them, most runs wait for a slow device.
#[test]
fn backups_keep_one_fast_device_from_waiting_for_slow_ones() {
    let mut rng = Rng::from_env(23);
    let mut worst = [[1.0f64; 2]; Policy::ALL.len()];
    let mut slower_without = 0;
    const RUNS: usize = 120;
    for run in 0..RUNS {
        let slow = 1 + rng.below(3);
        let mut speeds = vec![1.0];
        speeds.extend((0..slow).map(|_| 10f64.powf(-rng.range(5f64.log10(), 4.0))));
        let declared: Vec<f64> = if run % 2 == 0 {
            speeds.clone()
        } else {
            speeds
                .iter()
                .enumerate()
                .map(|(d, &v)| if d == 0 { v } else { v * 10.0 })
                .collect()
        };
        let n = 10 + rng.below(200);
        let estimated: Vec<f64> = (0..n).map(|_| rng.range(0.1, 1.0)).collect();
        let actual: Vec<f64> = estimated.iter().map(|c| c * rng.range(0.5, 2.0)).collect();
        let inst = Mixed {
            actual,
            estimated,
            speeds,
            declared,
        };
        let alone = inst.alone();
        for (p, &policy) in Policy::ALL.iter().enumerate() {
            for (b, backups) in [false, true].into_iter().enumerate() {
                let ratio = inst.makespan(policy, backups, 0.0) / alone;
                worst[p][b] = worst[p][b].max(ratio);
                if !backups && ratio > 1.0 {
                    slower_without += 1;
                }
            }
        }
    }
    for (p, policy) in Policy::ALL.iter().enumerate() {
        eprintln!(
            "{policy}: worst makespan / fast device alone {:.4} without backups, {:.6} with",
            worst[p][0], worst[p][1]
        );
    }
    eprintln!(
        "without backups, {slower_without} of {} runs ended after the fast device alone",
        RUNS * Policy::ALL.len()
    );
    for (p, policy) in Policy::ALL.iter().enumerate() {
        assert!(worst[p][1] <= 1.001, "{policy}: {}", worst[p][1]);
    }
}
