//! Fault injection for any [`RayDevice`] (`--fail D@K` on a GPU, say): the wrapped device
//! completes `K` tasks in its lifetime and then fails, so its unfinished work must be re-run
//! elsewhere. A launch of several ranges that crosses the limit delivers the ranges before it
//! (from one launch of the inner device) and then fails, as a device lost mid-launch would.
//!
//! Every device of a `--devices` list takes its faults this way, CPU and GPU alike, so they
//! fail alike.

use std::ops::Range;

use sched::{DeviceError, Sink};

use super::RayDevice;
use crate::cost::{SampleRate, Work};
use crate::{HitBatch, RayBatch, RayKind};

/// Why a device stopped on purpose: the fault a [`FailingAfter`] injected.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{device}: injected fault after {after} tasks")]
pub struct InjectedFault {
    /// The device's name.
    pub device: String,
    /// Tasks it completed before failing.
    pub after: u64,
}

/// `inner`, failing once it has completed `after` tasks.
pub struct FailingAfter<'a> {
    inner: Box<dyn RayDevice + 'a>,
    after: u64,
    done: u64,
}

impl<'a> FailingAfter<'a> {
    /// `inner`, failing after `after` tasks.
    pub fn new(inner: Box<dyn RayDevice + 'a>, after: u64) -> Self {
        Self {
            inner,
            after,
            done: 0,
        }
    }

    /// Ranges it may still run before failing.
    fn left(&self) -> u64 {
        self.after.saturating_sub(self.done)
    }

    fn fault(&self) -> DeviceError {
        InjectedFault {
            device: self.inner.name(),
            after: self.after,
        }
        .into()
    }
}

impl RayDevice for FailingAfter<'_> {
    fn trace_range(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<HitBatch, DeviceError> {
        if self.left() == 0 {
            return Err(self.fault());
        }
        let hits = self.inner.trace_range(kind, rays, range)?;
        self.done += 1;
        Ok(hits)
    }

    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        known: &[usize],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        let allowed = usize::try_from(self.left()).unwrap_or(usize::MAX);
        let run = &ranges[..allowed.min(ranges.len())];
        if !run.is_empty() {
            self.inner.trace_ranges(kind, rays, run, known, sink)?;
            self.done += run.len() as u64;
        }
        if run.len() < ranges.len() {
            return Err(self.fault());
        }
        Ok(())
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        self.inner.class()
    }

    fn skips_known(&self) -> bool {
        self.inner.skips_known()
    }

    fn launch_overhead(&self) -> Option<f64> {
        self.inner.launch_overhead()
    }

    fn take_device_seconds(&mut self) -> Option<f64> {
        self.inner.take_device_seconds()
    }

    fn take_traffic(&mut self) -> crate::Traffic {
        self.inner.take_traffic()
    }

    /// Estimating is not a task: it neither counts towards the fault nor is refused by it.
    fn estimate_work(
        &mut self,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: SampleRate,
        walk: crate::Walk,
    ) -> Option<Result<Vec<Work>, DeviceError>> {
        self.inner.estimate_work(rays, tasks, rate, walk)
    }
}
