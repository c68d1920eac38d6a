//! What each clock sees, in a test binary of its own: [`Clock::ProcessCpu`] counts the CPU
//! time of every thread of the process, so no other test may run beside it.

use std::time::Instant;

use sched::Clock;

fn spin(seconds: f64) -> u64 {
    let start = Instant::now();
    let mut n = 0u64;
    while start.elapsed().as_secs_f64() < seconds {
        n = std::hint::black_box(n + 1);
    }
    n
}

#[test]
fn both_clocks_see_a_busy_thread_and_only_wall_time_sees_a_sleeping_one() {
    assert!(Clock::Wall.is_available());
    let (wall, _) = Clock::Wall.time(|| spin(0.02));
    assert!(wall >= 0.02, "{wall}");
    if !Clock::ProcessCpu.is_available() {
        return;
    }
    let (cpu, _) = Clock::ProcessCpu.time(|| spin(0.02));
    // A busy loop is CPU time (less only if the machine took the thread away).
    assert!(cpu > 0.002 && cpu < 1.0, "{cpu}");
    let (asleep, ()) =
        Clock::ProcessCpu.time(|| std::thread::sleep(std::time::Duration::from_millis(30)));
    assert!(asleep < 0.015, "sleeping cost {asleep} s of CPU");
}
