use std::error::Error;
use std::fmt;
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
    fn run_batch(
        &mut self,
        tasks: &[&T],
        sink: &mut Sink<Self::Output>,
    ) -> Result<(), DeviceError> {
        for task in tasks {
            sink.push(self.run(task)?);
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
#[derive(Debug)]
pub struct Sink<O> {
    outputs: Vec<(O, Instant, Option<f64>)>,
    capacity: usize,
}

impl<O> Sink<O> {
    /// A sink for a batch of `capacity` tasks: what an executor that runs its batches on
    /// another executor (a device behind a link, say) hands that one.
    pub fn new(capacity: usize) -> Self {
        Sink {
            outputs: Vec::with_capacity(capacity),
            capacity,
        }
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
        assert!(
            self.outputs.len() < self.capacity,
            "executor delivered more outputs than the {} tasks of its batch",
            self.capacity
        );
        self.outputs.push((output, Instant::now(), device_seconds));
    }

    /// How many outputs have been delivered so far.
    pub fn len(&self) -> usize {
        self.outputs.len()
    }

    /// True before the first output.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    pub(crate) fn into_outputs(self) -> Vec<(O, Instant, Option<f64>)> {
        self.outputs
    }

    /// The outputs delivered, in order.
    pub fn into_values(self) -> Vec<O> {
        self.outputs.into_iter().map(|(o, ..)| o).collect()
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
