use std::error::Error;
use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::time::Instant;

use crate::Task;

/// One device: runs tasks and says how fast it is.
///
/// Only [`run`](Executor::run) is required. A device with a high launch cost (a GPU kernel,
/// a network round trip) overrides [`run_batch`](Executor::run_batch) to run a whole static
/// plan in one launch; the runtime always calls `run_batch`, and a queue policy's batches
/// hold one task.
pub trait Executor<T: Task>: Send {
    /// What running a task produces (hits, contact pairs, neighbours…).
    type Output: Send;

    /// Runs one task.
    fn run(&mut self, task: &T) -> Result<Self::Output, DeviceError>;

    /// Runs `tasks` in one launch, pushing each output to `sink` in the order of `tasks` as
    /// soon as it is ready. If it fails midway, outputs already pushed are kept and the rest
    /// of the batch is re-run on another device.
    ///
    /// Another device may run a backup copy of a task and deliver it first: then
    /// [`Sink::wanted`] turns false and the task may be passed over ([`Sink::skip`]), or the
    /// launch cut short ([`Sink::any_wanted`]). Pushing it anyway is harmless: the output is
    /// dropped. The default runs only the tasks still wanted.
    fn run_batch(
        &mut self,
        tasks: &[&T],
        sink: &mut Sink<Self::Output>,
    ) -> Result<(), DeviceError> {
        for task in tasks {
            if sink.wanted() {
                sink.push(self.run(task)?);
            } else {
                sink.skip();
            }
        }
        Ok(())
    }

    /// Relative speed: a task of cost `c` takes `c / speed`. Policies plan with it; measure it
    /// (cobalt's devices update it from the previous generation's timings).
    fn speed(&self) -> f64 {
        1.0
    }

    /// Seconds a launch costs on top of its tasks (a kernel dispatch, a network round trip,
    /// a thread pool to enter), where known (`None`, the default, where not). `Hybrid`
    /// launches one task at a time where it is `Some(0.0)`, so every task not yet started can
    /// still be stolen, halves of what is left where it is unknown, and few launches of at
    /// least eight overheads of work where it is positive (see `HybridDispatch`).
    fn launch_overhead(&self) -> Option<f64> {
        None
    }

    /// A name for reports and errors.
    fn name(&self) -> String {
        String::from("device")
    }
}

impl<T: Task, E: Executor<T> + ?Sized> Executor<T> for Box<E> {
    type Output = E::Output;
    fn run(&mut self, task: &T) -> Result<Self::Output, DeviceError> {
        (**self).run(task)
    }
    fn run_batch(
        &mut self,
        tasks: &[&T],
        sink: &mut Sink<Self::Output>,
    ) -> Result<(), DeviceError> {
        (**self).run_batch(tasks, sink)
    }
    fn speed(&self) -> f64 {
        (**self).speed()
    }
    fn launch_overhead(&self) -> Option<f64> {
        (**self).launch_overhead()
    }
    fn name(&self) -> String {
        (**self).name()
    }
}

/// Receives the outputs of a batch, in order, and stamps each with the time it arrived.
///
/// In a run with backup copies, the sink also tells the executor which of its tasks another
/// device has already delivered, and keeps only the first output of each task.
#[derive(Debug)]
pub struct Sink<O> {
    outputs: Vec<(Option<O>, Instant, Option<f64>)>,
    capacity: usize,
    watch: Option<Arc<Watch>>,
}

/// A launch as the rest of a run sees it while it runs: its tasks, which of the run's tasks
/// have an output (shared by every launch of the run), and how far it has got.
#[derive(Debug)]
pub(crate) struct Watch {
    pub(crate) tasks: Vec<u32>,
    pub(crate) done: Arc<[AtomicBool]>,
    /// The index in `tasks` of the task running now.
    pub(crate) next: AtomicUsize,
    /// When it started, in nanoseconds after `start`.
    since: AtomicU64,
    start: Instant,
}

impl Watch {
    /// `tasks`, launched now, in a run that started at `start`.
    pub(crate) fn new(tasks: Vec<u32>, done: Arc<[AtomicBool]>, start: Instant) -> Self {
        let watch = Watch {
            tasks,
            done,
            next: AtomicUsize::new(0),
            since: AtomicU64::new(0),
            start,
        };
        watch.started_next(Instant::now());
        watch
    }

    fn started_next(&self, at: Instant) {
        let nanos = at.saturating_duration_since(self.start).as_nanos();
        self.since
            .store(u64::try_from(nanos).unwrap_or(u64::MAX), Ordering::Release);
    }

    /// When the task running now started, in seconds after the run's start.
    pub(crate) fn head_started(&self) -> f64 {
        self.since.load(Ordering::Acquire) as f64 * 1e-9
    }

    /// The tasks from the one running now on.
    pub(crate) fn rest(&self) -> &[u32] {
        let next = self.next.load(Ordering::Acquire).min(self.tasks.len());
        &self.tasks[next..]
    }

    fn is_done(&self, k: usize) -> bool {
        self.tasks
            .get(k)
            .is_some_and(|&t| self.done[t as usize].load(Ordering::Acquire))
    }
}

impl<O> Sink<O> {
    /// A sink for a batch of `capacity` tasks: what an executor that runs its batches on
    /// another executor (a device behind a link, say) hands that one.
    pub fn new(capacity: usize) -> Self {
        Sink {
            outputs: Vec::with_capacity(capacity),
            capacity,
            watch: None,
        }
    }

    /// A sink for a launch the rest of the run watches.
    pub(crate) fn watched(watch: Arc<Watch>) -> Self {
        Sink {
            outputs: Vec::with_capacity(watch.tasks.len()),
            capacity: watch.tasks.len(),
            watch: Some(watch),
        }
    }

    /// False once another device has delivered the next task of the batch: its output is no
    /// longer wanted, and the executor may [`skip`](Sink::skip) it or stop running it.
    pub fn wanted(&self) -> bool {
        self.watch
            .as_ref()
            .is_none_or(|w| !w.is_done(self.outputs.len()))
    }

    /// True while any of the next `count` tasks of the batch is still wanted: false when
    /// running them is of no use.
    pub fn any_wanted(&self, count: usize) -> bool {
        let next = self.outputs.len();
        self.watch
            .as_ref()
            .is_none_or(|w| (next..(next + count).min(w.tasks.len())).any(|k| !w.is_done(k)))
    }

    /// Passes over the next task of the batch, whose output is no longer wanted. Skipping a
    /// task still wanted loses its output: the runtime re-runs it as a failure's.
    ///
    /// # Panics
    /// As [`Sink::push`].
    pub fn skip(&mut self) {
        self.record(None, None);
    }

    /// Delivers the output of the next task of the batch.
    ///
    /// # Panics
    /// Panics if the batch already has all its outputs: an executor bug, which the runtime
    /// treats like any other panic (the device is retired, its unfinished tasks re-run).
    pub fn push(&mut self, output: O) {
        self.deliver(output, None);
    }

    /// Delivers the output of the next task of the batch with the time the device itself
    /// measured for it (a GPU's timestamp queries): the task's [`crate::Span::device_seconds`]
    /// in the timeline. The span itself stays the host's wall time.
    ///
    /// # Panics
    /// As [`Sink::push`].
    pub fn push_timed(&mut self, output: O, device_seconds: f64) {
        self.deliver(output, Some(device_seconds));
    }

    fn deliver(&mut self, output: O, device_seconds: Option<f64>) {
        // The first output of a task is kept: a later one, from a copy that lost, is dropped.
        let first = self.watch.as_ref().is_none_or(|w| {
            w.tasks
                .get(self.outputs.len())
                .is_some_and(|&t| !w.done[t as usize].swap(true, Ordering::AcqRel))
        });
        self.record(first.then_some(output), device_seconds);
    }

    fn record(&mut self, output: Option<O>, device_seconds: Option<f64>) {
        assert!(
            self.outputs.len() < self.capacity,
            "executor delivered more outputs than the {} tasks of its batch",
            self.capacity
        );
        let now = Instant::now();
        self.outputs.push((output, now, device_seconds));
        if let Some(w) = &self.watch {
            w.started_next(now);
            w.next.store(self.outputs.len(), Ordering::Release);
        }
    }

    /// How many tasks of the batch have been passed so far: delivered or skipped.
    pub fn len(&self) -> usize {
        self.outputs.len()
    }

    /// True before the first output.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    /// Each task's output (`None` where skipped or another device's came first), when it
    /// arrived and the device's own time for it.
    pub(crate) fn into_outputs(self) -> Vec<(Option<O>, Instant, Option<f64>)> {
        self.outputs
    }

    /// The outputs delivered, in order (those skipped or dropped left out).
    pub fn into_values(self) -> Vec<O> {
        self.outputs.into_iter().filter_map(|(o, ..)| o).collect()
    }
}

/// Why a device stopped: any error, boxed, so devices of different kinds can share a run.
pub struct DeviceError(Box<dyn Error + Send + Sync + 'static>);

impl DeviceError {
    /// An error from a message.
    pub fn msg(message: impl fmt::Display) -> Self {
        DeviceError(message.to_string().into())
    }

    /// The underlying error.
    pub fn inner(&self) -> &(dyn Error + Send + Sync + 'static) {
        &*self.0
    }
}

impl<E: Error + Send + Sync + 'static> From<E> for DeviceError {
    fn from(e: E) -> Self {
        DeviceError(Box::new(e))
    }
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.0, f)
    }
}

impl fmt::Debug for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.0, f)
    }
}
