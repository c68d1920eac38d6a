use std::ops::Range;
use std::sync::atomic::{AtomicU32, Ordering};

use proptest::prelude::*;
use sched::{
    Costs, DeviceError, Executor, Policy, Runtime, SchedError, Simulation, Speeds, split_ranges,
};

/// How a test device misbehaves after running some tasks.
#[derive(Debug, Clone, Copy)]
enum Fail {
    Never,
    ErrorAfter(u32),
    PanicAfter(u32),
}

/// Sums its range; counts every run of every task, delivered or not.
struct Device<'a> {
    speed: f64,
    fail: Fail,
    ran: u32,
    runs: &'a [AtomicU32],
}

impl Executor<Range<usize>> for Device<'_> {
    type Output = (usize, u64);

    fn run(&mut self, task: &Range<usize>) -> Result<(usize, u64), DeviceError> {
        match self.fail {
            Fail::ErrorAfter(k) if self.ran >= k => return Err(DeviceError::msg("injected error")),
            Fail::PanicAfter(k) if self.ran >= k => panic!("injected panic"),
            _ => {}
        }
        self.ran += 1;
        self.runs[task.start / TASK].fetch_add(1, Ordering::Relaxed);
        Ok((task.start, task.clone().map(|i| i as u64).sum()))
    }

    fn speed(&self) -> f64 {
        self.speed
    }
}

const TASK: usize = 8;

fn fail_mode() -> impl Strategy<Value = Fail> {
    prop_oneof![
        2 => Just(Fail::Never),
        1 => (0u32..6).prop_map(Fail::ErrorAfter),
        1 => (0u32..6).prop_map(Fail::PanicAfter),
    ]
}

fn quiet_panics() {
    // Injected panics are expected; keep their messages out of the test log.
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !info.to_string().contains("injected panic") {
                default(info);
            }
        }));
    });
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn each_output_delivered_exactly_once_despite_failures(
        n in 0usize..40,
        fails in prop::collection::vec(fail_mode(), 1..=4),
        policy in prop::sample::select(Policy::ALL.to_vec()),
        cost_seed in any::<u64>(),
    ) {
        quiet_panics();
        let tasks = split_ranges(n * TASK, TASK);
        let costs = Costs::new((0..n).map(|i| ((cost_seed >> (i % 60)) & 7) as f64 + 0.5).collect()).unwrap();
        let runs: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
        let mut devices: Vec<Device> = fails.iter().enumerate()
            .map(|(d, &fail)| Device { speed: 1.0 + d as f64, fail, ran: 0, runs: &runs })
            .collect();
        let all_can_fail = fails.iter().all(|f| !matches!(f, Fail::Never));

        match Runtime::new(policy).run(&tasks, &costs, &mut devices) {
            Ok(report) => {
                prop_assert_eq!(report.outputs.len(), n);
                for (i, &(start, sum)) in report.outputs.iter().enumerate() {
                    prop_assert_eq!(start, i * TASK, "output {} is another task's", i);
                    prop_assert_eq!(sum, (i * TASK..(i + 1) * TASK).map(|x| x as u64).sum::<u64>());
                }
                let mut seen = vec![0; n];
                for s in &report.timeline.spans {
                    seen[s.task as usize] += 1;
                }
                prop_assert!(seen.iter().all(|&k| k == 1), "{}: spans per task {:?}", policy, seen);
                // Every task ran at least once; only failures cause extra runs, and a failed
                // run never counts as a delivery.
                prop_assert!(runs.iter().all(|r| r.load(Ordering::Relaxed) >= 1));
                prop_assert!(report.failures.len() < devices.len());
            }
            Err(SchedError::AllDevicesFailed { unfinished, failures, devices: m, .. }) => {
                prop_assert!(all_can_fail, "{}: gave up although a device never fails", policy);
                prop_assert!(unfinished > 0);
                prop_assert_eq!(failures.len(), m);
            }
            Err(e) => prop_assert!(false, "unexpected error: {}", e),
        }
    }

    #[test]
    fn simulator_and_runtime_agree_on_static_plans(
        c in prop::collection::vec(0.0f64..10.0, 0..60),
        s in prop::collection::vec(prop_oneof![Just(1.0), Just(2.5), 0.5f64..3.0], 1..=4),
        policy in prop::sample::select(vec![Policy::StaticEqual, Policy::StaticLpt]),
    ) {
        let n = c.len();
        let costs = Costs::new(c).unwrap();
        let tasks = split_ranges(n * TASK, TASK);
        let runs: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(0)).collect();
        let mut devices: Vec<Device> = s.iter()
            .map(|&speed| Device { speed, fail: Fail::Never, ran: 0, runs: &runs })
            .collect();
        // The devices here take no time their costs say, so backups would copy at other
        // moments: the plan itself is compared.
        let real = Runtime::new(policy).backups(false).run(&tasks, &costs, &mut devices).unwrap();
        let sim = Simulation::new(policy, Speeds::new(s).unwrap()).backups(false).run(&costs).unwrap();
        prop_assert_eq!(real.timeline.assignment(n), sim.assignment);
        prop_assert!(real.launches.iter().all(|&l| l <= 1), "a static plan launches once per device");
    }
}

#[test]
fn every_device_failing_is_a_clear_error() {
    quiet_panics();
    let tasks = split_ranges(100 * TASK, TASK);
    let costs = Costs::uniform(tasks.len());
    let runs: Vec<AtomicU32> = (0..100).map(|_| AtomicU32::new(0)).collect();
    let mut devices = vec![
        Device {
            speed: 1.0,
            fail: Fail::ErrorAfter(3),
            ran: 0,
            runs: &runs,
        },
        Device {
            speed: 1.0,
            fail: Fail::PanicAfter(5),
            ran: 0,
            runs: &runs,
        },
    ];
    for policy in Policy::ALL {
        for d in &mut devices {
            d.ran = 0;
        }
        let err = Runtime::new(policy)
            .run(&tasks, &costs, &mut devices)
            .unwrap_err();
        let text = err.to_string();
        assert!(text.contains("all 2 devices failed"), "{text}");
        assert!(
            text.contains("injected error") && text.contains("injected panic"),
            "{text}"
        );
    }
}

#[test]
fn bad_speed_is_rejected_before_anything_runs() {
    let tasks = split_ranges(10, 5);
    let runs: Vec<AtomicU32> = (0..2).map(|_| AtomicU32::new(0)).collect();
    let mut devices = vec![Device {
        speed: f64::NAN,
        fail: Fail::Never,
        ran: 0,
        runs: &runs,
    }];
    let err = Runtime::new(Policy::QueueFifo)
        .run(&tasks, &Costs::uniform(2), &mut devices)
        .unwrap_err();
    assert!(matches!(err, SchedError::BadSpeed { device: 0, .. }));
    assert_eq!(runs[0].load(Ordering::Relaxed), 0);
    let no_devices: &mut [Device] = &mut [];
    assert_eq!(
        Runtime::new(Policy::QueueFifo)
            .run(&tasks, &Costs::uniform(2), no_devices)
            .unwrap_err(),
        SchedError::NoDevices
    );
}
