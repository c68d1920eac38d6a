//! Fault injection for any [`PathDevice`] (`--fail D@K`): the wrapped device completes `K`
//! tasks in its lifetime and then fails, so its paths must be rendered elsewhere. A launch
//! that would cross the limit fails whole, as a device lost mid-launch would: none of its
//! values reach the host.
//!
//! Every device of a `--devices` list takes its faults this way, CPU and GPU alike, so they
//! fail alike.

use std::ops::Range;

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

/// Why a device stopped on purpose: the fault a [`FailingPaths`] injected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{device}: injected fault after {after} tasks")]
pub struct InjectedFault {
    /// The device's name.
    pub device: String,
    /// Tasks it completed before failing.
    pub after: u64,
}

/// `inner`, failing once it has completed `after` tasks.
pub struct FailingPaths<'a> {
    inner: Box<dyn PathDevice + 'a>,
    after: u64,
    done: u64,
}

impl<'a> FailingPaths<'a> {
    /// `inner`, failing after `after` tasks.
    pub fn new(inner: Box<dyn PathDevice + 'a>, after: u64) -> Self {
        Self {
            inner,
            after,
            done: 0,
        }
    }
}

impl PathDevice for FailingPaths<'_> {
    fn render(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
    ) -> Result<Launch, DeviceError> {
        if self.done + tasks.len() as u64 > self.after {
            self.done = self.after;
            return Err(InjectedFault {
                device: self.inner.name(),
                after: self.after,
            }
            .into());
        }
        let launch = self.inner.render(frame, tasks)?;
        self.done += tasks.len() as u64;
        Ok(launch)
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        self.inner.class()
    }

    fn launch_overhead(&self) -> Option<f64> {
        self.inner.launch_overhead()
    }

    fn end_frame(&mut self) {
        self.inner.end_frame();
    }
}
