//! What a device that traces rays is, and how one becomes a [`sched::Executor`] for one
//! generation.
//!
//! A device lives for the whole render (its threads, later its GPU buffers), while a
//! generation's rays are only borrowed for one call of [`crate::shade::Tracer::trace`]. So the
//! executor the runtime drives is a short-lived [`Bound`]: the device, the rays and their kind,
//! and the speed measured so far.

use std::ops::Range;

use sched::{DeviceError, Executor, Sink};

use crate::cost::{SampleRate, Work};
use crate::{HitBatch, RayBatch, RayKind};

/// Why a device refused a task: a range outside the generation.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{device}: task {start}..{end} is outside the generation of {rays} rays")]
pub struct BadRange {
    /// The device's name.
    pub device: String,
    /// The range's start.
    pub start: usize,
    /// The range's end.
    pub end: usize,
    /// Rays in the generation.
    pub rays: usize,
}

impl BadRange {
    /// `Ok` when `range` lies inside `rays` (and the batch's columns agree), else the error
    /// naming `device`, the range and the generation's length.
    pub fn check(
        device: impl FnOnce() -> String,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<(), Self> {
        if range.start > range.end || range.end > rays.len() || !rays.is_consistent() {
            return Err(Self {
                device: device(),
                start: range.start,
                end: range.end,
                rays: rays.len(),
            });
        }
        Ok(())
    }
}

/// A device that traces ranges of a generation's rays. There is one required method besides
/// the name.
///
/// ## Contract
/// A range's hits are those of [`crate::shade::Tracer::trace`] for the same rays: any hit for
/// [`RayKind::is_occlusion`] kinds, else the closest; each ray traced the same way whatever
/// range or launch it lands in, so images do not depend on the schedule.
pub trait RayDevice: Send {
    /// Traces the rays of `range`.
    fn trace_range(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<HitBatch, DeviceError>;

    /// Traces `ranges` in one launch, pushing each range's hits to `sink` in order as soon as
    /// they are ready. A device with a costly launch (a thread pool to enter, a kernel to
    /// dispatch) overrides this to pay it once per launch rather than once per range.
    ///
    /// The rays at `known` (sorted indices into `rays`, usually none) were traced already, by
    /// the estimator's sample ([`crate::Walk::Trace`]): a device that
    /// [skips them](RayDevice::skips_known) leaves them as misses, for the caller writes
    /// their hits in afterwards. By default they are traced like the others.
    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        known: &[usize],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        let _ = known;
        for range in ranges {
            sink.push(self.trace_range(kind, rays, range)?);
        }
        Ok(())
    }

    /// True when [`RayDevice::trace_ranges`] skips the known rays (false by default).
    /// A tracer hands them down only where every device skips them, so that the speeds it
    /// measures compare devices doing the same work.
    fn skips_known(&self) -> bool {
        false
    }

    /// A name unique among the devices of a tracer: calibrations are keyed by it.
    fn name(&self) -> String;

    /// Seconds a launch costs beyond its ranges, where known: see
    /// [`sched::Executor::launch_overhead`]. Unknown by default.
    fn launch_overhead(&self) -> Option<f64> {
        None
    }

    /// The estimate of `tasks` computed on this device (the thesis estimates on the GPU):
    /// each task's sampled work at `rate` by `walk`'s reduced traversal, equal to
    /// [`crate::cost::ReducedTraversal::try_work`]'s. `None` for a device that does not
    /// estimate (the default: the CPU estimates in parallel on the host instead).
    fn estimate_work(
        &mut self,
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: SampleRate,
        walk: crate::Walk,
    ) -> Option<Result<Vec<Work>, DeviceError>> {
        let _ = (rays, tasks, rate, walk);
        None
    }

    /// Seconds the device itself measured running its kernels since the last call (a GPU's
    /// timestamp queries), and resets the count; `None` for a device that cannot measure
    /// them (the default: its busy time is the host's wall time of its launches).
    fn take_device_seconds(&mut self) -> Option<f64> {
        None
    }

    /// What crossed between the host and the device since the last call (rays up, hits
    /// back, the waits in between), and resets the count. Nothing for a device that works
    /// in host memory (the default).
    fn take_traffic(&mut self) -> crate::Traffic {
        crate::Traffic::default()
    }

    /// Devices of one class are the same hardware doing the same work (the `N` devices of a
    /// `cpu:N/T` entry): their speed is measured together, because any difference between
    /// them is noise (the OS scheduling threads, errors of the cost model) that would
    /// otherwise skew the next plan. By default every device is a class of its own.
    fn class(&self) -> String {
        self.name()
    }
}

/// A device bound to one generation: the [`Executor`] that `sched`'s runtime drives.
pub struct Bound<'r, 'a> {
    device: &'r mut (dyn RayDevice + 'a),
    kind: RayKind,
    rays: &'r RayBatch,
    known: &'r [usize],
    speed: f64,
}

impl<'r, 'a> Bound<'r, 'a> {
    /// `device` tracing `rays` of `kind`, planned at relative `speed`.
    pub fn new(
        device: &'r mut (dyn RayDevice + 'a),
        kind: RayKind,
        rays: &'r RayBatch,
        speed: f64,
    ) -> Self {
        Self {
            device,
            kind,
            rays,
            known: &[],
            speed,
        }
    }

    /// The same, told that the rays at `known` (sorted) need no tracing: see
    /// [`RayDevice::trace_ranges`].
    pub fn knowing(self, known: &'r [usize]) -> Self {
        Self { known, ..self }
    }
}

impl Executor<Range<usize>> for Bound<'_, '_> {
    type Output = HitBatch;

    fn run(&mut self, task: &Range<usize>) -> Result<HitBatch, DeviceError> {
        self.device.trace_range(self.kind, self.rays, task)
    }

    fn run_batch(
        &mut self,
        tasks: &[&Range<usize>],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        self.device
            .trace_ranges(self.kind, self.rays, tasks, self.known, sink)
    }

    /// The speed measured on earlier generations (1 before the first).
    fn speed(&self) -> f64 {
        self.speed
    }

    fn launch_overhead(&self) -> Option<f64> {
        self.device.launch_overhead()
    }

    fn name(&self) -> String {
        self.device.name()
    }
}
