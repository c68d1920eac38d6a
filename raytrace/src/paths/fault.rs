//! Faults and slowness injected into any [`PathDevice`], CPU and GPU alike, so that every
//! device of a `--devices` list fails and slows alike ([`InjectedPaths`]).
//!
//! `--fail D@K`: the device completes `K` tasks in its lifetime and then fails, so its paths
//! must be rendered elsewhere. A launch that would cross the limit fails whole, as a device
//! lost mid-launch would: none of its values reach the host.
//!
//! `--slow D=K`: the device waits `K − 1` times each launch's busy time after rendering it,
//! so that devices of different speeds can be shown on a machine of equal cores. Its values
//! are the inner device's: images do not change.

use std::ops::Range;
use std::time::{Duration, Instant};

use sched::DeviceError;

use super::{Frame, Launch, PathDevice};

/// Fault injection: device `device` (index in the list) fails after `tasks` tasks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FailAfter {
    /// Index of the device, counting every device of the list in order.
    pub device: usize,
    /// Tasks it completes before failing.
    pub tasks: u64,
}

/// A device made slower on purpose: device `device` (index in the list) takes `factor` times
/// as long.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlowBy {
    /// Index of the device, counting every device of the list in order.
    pub device: usize,
    /// How many times as long it takes, at least 1.
    pub factor: f64,
}

/// Why a device stopped on purpose: the fault an [`InjectedPaths`] injected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{device}: injected fault after {after} tasks")]
pub struct InjectedFault {
    /// The device's name.
    pub device: String,
    /// Tasks it completed before failing.
    pub after: u64,
}

/// `inner`, failing once it has completed `fail_after` tasks (if set), and `factor` times
/// slower: after each launch it waits `factor − 1` times the launch's busy time, less if the
/// launch's values stop being wanted meanwhile (another device delivered them first).
pub struct InjectedPaths<'a> {
    inner: Box<dyn PathDevice + 'a>,
    fail_after: Option<u64>,
    done: u64,
    factor: f64,
}

impl<'a> InjectedPaths<'a> {
    /// Each device of `devices` with what `faults` and `slow` name for it: the earliest of its
    /// faults, the largest of its factors. The caller checks the indices.
    pub fn wrap(
        devices: Vec<Box<dyn PathDevice + 'a>>,
        faults: &[FailAfter],
        slow: &[SlowBy],
    ) -> Vec<Box<dyn PathDevice + 'a>> {
        let on = |i: usize| faults.iter().filter(move |f| f.device == i);
        let slowed = |i: usize| slow.iter().filter(move |s| s.device == i);
        devices
            .into_iter()
            .enumerate()
            .map(|(i, inner)| {
                let fail_after = on(i).map(|f| f.tasks).min();
                let factor = slowed(i).map(|s| s.factor).fold(1.0, f64::max);
                if fail_after.is_none() && factor <= 1.0 {
                    return inner;
                }
                Box::new(Self {
                    inner,
                    fail_after,
                    done: 0,
                    factor,
                }) as Box<dyn PathDevice + 'a>
            })
            .collect()
    }
}

impl PathDevice for InjectedPaths<'_> {
    fn render(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
    ) -> Result<Launch, DeviceError> {
        self.render_while(frame, tasks, &|| true)
    }

    fn render_while(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        wanted: &dyn Fn() -> bool,
    ) -> Result<Launch, DeviceError> {
        if let Some(after) = self.fail_after
            && self.done + tasks.len() as u64 > after
        {
            self.done = after;
            return Err(InjectedFault {
                device: self.inner.name(),
                after,
            }
            .into());
        }
        let started = Instant::now();
        let launch = self.inner.render_while(frame, tasks, wanted)?;
        self.done += tasks.len() as u64;
        let until = started + started.elapsed().mul_f64(self.factor);
        // Short sleeps, so that a launch no longer wanted ends soon after.
        while wanted() {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(Duration::from_micros(500)));
        }
        Ok(launch)
    }

    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        rate: sched::SampleRate,
        walk: crate::traverse::walk::Walk,
    ) -> Result<super::Estimate, DeviceError> {
        self.inner.estimate(frame, tasks, rate, walk)
    }

    fn estimate_kind(&self) -> &'static str {
        self.inner.estimate_kind()
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        if self.factor > 1.0 {
            // Not measured with the inner device's class: it is slower.
            format!("{} (slowed)", self.inner.name())
        } else {
            self.inner.class()
        }
    }

    fn launch_overhead(&self) -> Option<f64> {
        self.inner.launch_overhead()
    }

    fn cheap_launches(&self) -> bool {
        self.inner.cheap_launches()
    }

    fn end_frame(&mut self) {
        self.inner.end_frame();
    }
}
