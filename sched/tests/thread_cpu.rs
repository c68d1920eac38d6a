//! What a run reports of each device thread's CPU time, in a test binary of its own: its
//! spinning device would show in the process CPU time that `clock.rs` measures.

use std::time::Instant;

fn spin(seconds: f64) -> u64 {
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        n = std::hint::black_box(n + 1);
    }
    n
}

/// A device that sleeps through its tasks (as a GPU's host thread waits on the GPU) or spins
/// through them.
struct Device {
    spins: bool,
}

impl sched::Executor<std::ops::Range<usize>> for Device {
    type Output = usize;
    fn run(&mut self, task: &std::ops::Range<usize>) -> Result<usize, sched::DeviceError> {
        if self.spins {
            spin(0.004);
        } else {
            std::thread::sleep(std::time::Duration::from_millis(4));
        }
        Ok(task.len())
    }
}

/// The run reports each device thread's CPU time in its launches: a sleeping device's is a
/// small part of its busy time, a spinning one's up to all of it.
#[test]
fn a_run_reports_what_each_device_thread_spent_of_a_core() {
    let tasks = sched::split_ranges(40, 1);
    let costs = sched::Costs::new(vec![1.0; tasks.len()]).unwrap();
    let mut devices = [Device { spins: true }, Device { spins: false }];
    let run = sched::Runtime::new(sched::Policy::QueueFifo)
        .run(&tasks, &costs, &mut devices)
        .unwrap();
    let Some(cpu) = run
        .cpu_seconds
        .iter()
        .copied()
        .collect::<Option<Vec<f64>>>()
    else {
        assert!(sched::thread_cpu_seconds().is_none());
        return;
    };
    let busy = &run.metrics.busy;
    assert!(busy[0] > 0.0 && busy[1] > 0.0, "{busy:?}");
    assert!(
        cpu[0] > 0.0 && cpu[0] <= busy[0] * 1.05 + 0.001,
        "{cpu:?} of {busy:?}"
    );
    assert!(
        cpu[1] < 0.25 * busy[1],
        "sleeping cost {} s of {} s",
        cpu[1],
        busy[1]
    );
}
