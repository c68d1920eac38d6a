//! What a measurement is timed on: wall time, or the CPU time of the whole process.
//!
//! On a machine shared with other work, a parallel step's wall time swings with the other
//! processes, while the CPU time its own threads spent moves far less: a figure that compares
//! steps of one process (an estimate's overhead against the trace it saves) stays readable on
//! such a machine. CPU time counts every thread of the process, the pool's idle spinning
//! included, so it measures work, not latency: a step that waits on one slow thread is not
//! seen to wait.

use std::time::Instant;

/// The clock a measurement is timed on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Clock {
    /// Elapsed real time.
    #[default]
    Wall,
    /// CPU time of every thread of this process (Linux only; see [`Clock::is_available`]).
    ProcessCpu,
}

impl Clock {
    /// Lower-case name for reports and command lines: `wall` or `cpu`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Wall => "wall",
            Self::ProcessCpu => "cpu",
        }
    }

    /// Whether this clock can be read here: the process CPU clock needs Linux.
    pub fn is_available(self) -> bool {
        self == Self::Wall || self.read().is_some()
    }

    /// Runs `f` and returns the seconds it took on this clock, with its result. A clock that
    /// cannot be read here falls back to wall time.
    pub fn time<T>(self, f: impl FnOnce() -> T) -> (f64, T) {
        let wall = Instant::now();
        let start = self.read();
        let out = f();
        let seconds = match (start, self.read()) {
            (Some(a), Some(b)) => (b - a).max(0.0),
            _ => wall.elapsed().as_secs_f64(),
        };
        (seconds, out)
    }

    /// The clock's reading in seconds since an arbitrary origin; `None` for wall time (timed
    /// with [`Instant`]) and where the clock does not exist.
    fn read(self) -> Option<f64> {
        match self {
            Self::Wall => None,
            Self::ProcessCpu => process_cpu_seconds(),
        }
    }
}

impl std::str::FromStr for Clock {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "wall" => Ok(Self::Wall),
            "cpu" => Ok(Self::ProcessCpu),
            other => Err(format!("unknown clock `{other}` (expected wall or cpu)")),
        }
    }
}

impl std::fmt::Display for Clock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(target_os = "linux")]
fn process_cpu_seconds() -> Option<f64> {
    cpu_clock(libc::CLOCK_PROCESS_CPUTIME_ID)
}

#[cfg(not(target_os = "linux"))]
fn process_cpu_seconds() -> Option<f64> {
    None
}

/// The CPU time the calling thread has used, in seconds (Linux only; `None` elsewhere): what
/// a device's own thread spends of a core, where its wall time also counts its waits (a GPU's
/// host thread waits on the GPU for most of a launch).
#[cfg(target_os = "linux")]
pub fn thread_cpu_seconds() -> Option<f64> {
    cpu_clock(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// The CPU time the calling thread has used (Linux only; `None` here).
#[cfg(not(target_os = "linux"))]
pub fn thread_cpu_seconds() -> Option<f64> {
    None
}

#[cfg(target_os = "linux")]
fn cpu_clock(clock: libc::clockid_t) -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the call's duration, and the process and
    // thread CPU clocks are clocks every Linux kernel since 2.6.12 provides.
    let rc = unsafe { libc::clock_gettime(clock, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(test)]
mod tests {
    use super::*;

    // What each clock sees of a busy and a sleeping thread is tested in `tests/clock.rs`,
    // a binary of its own: process CPU time counts every thread, and the other tests of this
    // binary run beside it.

    #[test]
    fn names_round_trip_and_bad_names_are_named() {
        for c in [Clock::Wall, Clock::ProcessCpu] {
            assert_eq!(c.name().parse::<Clock>(), Ok(c));
            assert_eq!(c.to_string(), c.name());
        }
        assert_eq!(
            "sun".parse::<Clock>().unwrap_err(),
            "unknown clock `sun` (expected wall or cpu)"
        );
    }
}
