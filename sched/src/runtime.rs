use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::backup::{Backup, Backups, Held};
use crate::executor::Watch;
use crate::{
    Costs, DeviceError, DeviceFailure, Dispatch, Executor, Homes, Metrics, Policy, SchedError,
    Sink, Span, Speeds, Task, Timeline,
};

/// Runs a workload on real executors, one host thread per device.
///
/// ```
/// use sched::{Costs, DeviceError, Executor, Policy, Runtime};
/// use std::ops::Range;
///
/// struct Summer;
/// impl Executor<Range<usize>> for Summer {
///     type Output = usize;
///     fn run(&mut self, task: &Range<usize>) -> Result<usize, DeviceError> {
///         Ok(task.clone().sum())
///     }
/// }
///
/// let tasks = sched::split_ranges(1000, 64);
/// let costs = Costs::new(tasks.iter().map(|t| t.len() as f64).collect())?;
/// let run = Runtime::new(Policy::Hybrid).run(&tasks, &costs, &mut [Summer, Summer])?;
/// assert_eq!(run.outputs.iter().sum::<usize>(), (0..1000).sum());
/// # Ok::<(), sched::SchedError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Runtime {
    policy: Policy,
    homes: Option<Homes>,
    backups: bool,
}

/// What a real run produced and how it went.
#[derive(Debug)]
pub struct RunReport<O> {
    /// One output per task, in task order.
    pub outputs: Vec<O>,
    /// Every delivered task: device, start and end, in seconds from the start of dispatch.
    pub timeline: Timeline,
    /// Makespan, busy and idle time, balance efficiency.
    pub metrics: Metrics,
    /// Time spent planning (building the policy's dispatcher), before any device started.
    pub plan_seconds: f64,
    /// Per device: time spent asking the policy for work, lock waits included.
    pub dispatch_seconds: Vec<f64>,
    /// Launches per device.
    pub launches: Vec<u64>,
    /// Per device: CPU time its thread spent in its launches ([`crate::thread_cpu_seconds`];
    /// `None` where the platform has no such clock). Beside the busy (wall) time it shows
    /// what driving the device takes of that thread's core: a task's whole work where the
    /// executor computes on the thread, only the hand-off, submission and read-back where it
    /// passes the work to a GPU or to threads of its own, and waits.
    pub cpu_seconds: Vec<Option<f64>>,
    /// Devices that failed; their unfinished tasks were re-run by the others.
    pub failures: Vec<DeviceFailure>,
    /// Task runs lost to failures and run again.
    pub reruns: u64,
    /// Backup copies launched: tasks an idle device ran because another device held them
    /// and the model said the copy would finish sooner (see [`Runtime::backups`]).
    pub copies: u64,
    /// Seconds devices spent on task runs whose output was dropped because another copy's
    /// came first.
    pub wasted: f64,
}

struct State<'a, O> {
    dispatch: Box<dyn Dispatch + 'a>,
    outputs: Vec<Option<O>>,
    delivered: usize,
    spans: Vec<Span>,
    failures: Vec<DeviceFailure>,
    reruns: u64,
    /// Each device's launch while it runs, and whether it is a launch of copies.
    held: Vec<Option<(Arc<Watch>, bool)>>,
    copies: u64,
    wasted: f64,
}

struct Shared<'a, O> {
    state: Mutex<State<'a, O>>,
    // Signalled when a failure releases work, a launch starts or ends (with backups), or the
    // last output arrives.
    changed: Condvar,
    start: Instant,
    /// Which tasks have an output, set by the sink that delivers it first.
    done: Arc<[AtomicBool]>,
    backups: Option<Backups<'a>>,
}

impl<'a, O> Shared<'a, O> {
    fn lock(&self) -> MutexGuard<'_, State<'a, O>> {
        // A panic never happens while the lock is held (executors run unlocked), so a
        // poisoned lock still holds consistent state.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn seconds(&self, t: Instant) -> f64 {
        t.saturating_duration_since(self.start).as_secs_f64()
    }
}

impl Runtime {
    /// A runtime that schedules with `policy`.
    pub fn new(policy: Policy) -> Self {
        Runtime {
            policy,
            homes: None,
            backups: true,
        }
    }

    /// Whether an idle device may run backup copies of tasks other devices hold (on by
    /// default): when a device has nothing left, it copies the tasks the model says it would
    /// finish sooner (estimated cost over speed, and how long a running one has run already;
    /// see `backup.rs`), the first output of each task is kept and the other copy is told it
    /// is no longer wanted ([`Sink::wanted`]). Off, the policy's plan runs as planned, the
    /// thesis's pure static behaviour.
    ///
    /// The rule reads a cost over a speed as seconds, as the [`crate::Simulation`] does: with
    /// costs in another unit it still never delays a run, but copies more than it needs to
    /// (costs far too large make every held task look late; far too small, every running one
    /// overrun).
    pub fn backups(self, on: bool) -> Self {
        Runtime {
            backups: on,
            ..self
        }
    }

    /// The same runtime for tasks whose data lives on one device each: the policy weighs
    /// what moving a task costs (see [`Policy::dispatcher_homed`]). Only the plan changes:
    /// an executor given a task away from home moves its data itself.
    pub fn with_homes(self, homes: Homes) -> Self {
        Runtime {
            homes: Some(homes),
            ..self
        }
    }

    /// Starts (if not yet parked) the threads a run on `devices` devices uses, so that the
    /// first run does not wait for new threads: call it while setting up. Runs drive device
    /// 0 on the calling thread and the others on parked threads kept between runs.
    pub fn start_threads(devices: usize) {
        // A refusal here shows again, as an error, in the run that needs the threads.
        if let Ok(pool) = workers::take(devices.saturating_sub(1)) {
            workers::give_back(pool);
        }
    }

    /// Runs `jobs[d]` on the thread a run drives device `d` on: the first on the calling
    /// thread, the others on the parked device threads, woken off the caller's CPU
    /// (`placement.rs`), so that each starts at once; returns once every job has ended. For
    /// what a caller does with each device outside a run, such as each device estimating its
    /// share of a frame. A job's panic is the job's to catch: on a parked thread it is
    /// swallowed, on the calling thread it unwinds.
    ///
    /// # Errors
    /// [`SchedError::Threads`] when the operating system refuses a thread (no job has run).
    pub fn on_device_threads<'s>(
        jobs: Vec<Box<dyn FnOnce() + Send + 's>>,
    ) -> Result<(), SchedError> {
        let mut jobs = jobs.into_iter();
        let Some(first) = jobs.next() else {
            return Ok(());
        };
        let others: Vec<_> = jobs.collect();
        let pool = workers::take(others.len())?;
        pool.run(others, first);
        workers::give_back(pool);
        Ok(())
    }

    /// Runs every task exactly once across `executors` and returns their outputs in task
    /// order. Speeds come from [`Executor::speed`]. A device that errors or panics is retired
    /// and its unfinished tasks go to the others; only if every device fails is the run an
    /// error, naming each failure.
    pub fn run<T, E>(
        &self,
        tasks: &[T],
        costs: &Costs,
        executors: &mut [E],
    ) -> Result<RunReport<E::Output>, SchedError>
    where
        T: Task,
        E: Executor<T>,
    {
        if costs.len() != tasks.len() {
            return Err(SchedError::LengthMismatch {
                what: "one cost per task",
                expected: tasks.len(),
                got: costs.len(),
            });
        }
        let speeds = Speeds::new(executors.iter().map(|e| e.speed()).collect())?;
        let names: Vec<String> = executors.iter().map(|e| e.name()).collect();
        let m = executors.len();

        let planning = Instant::now();
        let overheads: Vec<Option<f64>> = executors.iter().map(|e| e.launch_overhead()).collect();
        let dispatch = match &self.homes {
            Some(homes) => self
                .policy
                .dispatcher_homed(costs, &speeds, &overheads, homes)?,
            None => self
                .policy
                .dispatcher_with_overheads(costs, &speeds, &overheads),
        };
        let backups = self
            .backups
            .then(|| Backups::new(costs, speeds.as_slice(), &overheads, self.homes.as_ref()));
        let plan_seconds = planning.elapsed().as_secs_f64();

        let shared = Shared {
            state: Mutex::new(State {
                dispatch,
                outputs: (0..tasks.len()).map(|_| None).collect(),
                delivered: 0,
                spans: Vec::with_capacity(tasks.len()),
                failures: Vec::new(),
                reruns: 0,
                held: (0..m).map(|_| None).collect(),
                copies: 0,
                wasted: 0.0,
            }),
            changed: Condvar::new(),
            start: Instant::now(),
            done: (0..tasks.len()).map(|_| AtomicBool::new(false)).collect(),
            backups,
        };
        let mut per_device = vec![Totals::default(); m];
        let pool = workers::take(m.saturating_sub(1))?;
        {
            let shared = &shared;
            let names = &names;
            // Executors' panics are caught inside the loop; this catches a bug of the loop
            // itself, so that it neither kills a parked thread nor escapes the run.
            let run = move |d: usize, exec: &mut E, out: &mut Totals| {
                *out = catch_unwind(AssertUnwindSafe(|| {
                    device_loop(d, &names[d], exec, tasks, shared)
                }))
                .unwrap_or_default();
            };
            let mut devices = executors.iter_mut().zip(per_device.iter_mut()).enumerate();
            let first = devices.next();
            let others: Vec<Box<dyn FnOnce() + Send + '_>> = devices
                .map(|(d, (exec, out))| {
                    Box::new(move || run(d, exec, out)) as Box<dyn FnOnce() + Send + '_>
                })
                .collect();
            // The calling thread is device 0: it starts at once.
            pool.run(others, || {
                if let Some((d, (exec, out))) = first {
                    run(d, exec, out);
                }
            });
        }
        workers::give_back(pool);

        let state = shared.state.into_inner().unwrap_or_else(|p| p.into_inner());
        let n = tasks.len();
        if state.delivered < n {
            return Err(SchedError::AllDevicesFailed {
                devices: m,
                tasks: n,
                unfinished: n - state.delivered,
                failures: state.failures,
            });
        }
        let timeline = Timeline {
            devices: m,
            spans: state.spans,
        };
        Ok(RunReport {
            outputs: state.outputs.into_iter().flatten().collect(),
            metrics: timeline.metrics(),
            timeline,
            plan_seconds,
            dispatch_seconds: per_device.iter().map(|p| p.dispatch_seconds).collect(),
            launches: per_device.iter().map(|p| p.launches).collect(),
            cpu_seconds: per_device.iter().map(|p| p.cpu_seconds).collect(),
            failures: state.failures,
            reruns: state.reruns,
            copies: state.copies,
            wasted: state.wasted,
        })
    }
}

/// Parked threads for the devices after the first, kept between runs: a thread woken from a
/// park starts at once, where spawning a new one can take milliseconds on a busy machine,
/// longer than a short run's tasks.
mod workers {
    use std::panic::{AssertUnwindSafe, catch_unwind};
    use std::sync::Mutex;

    use crossbeam::channel::{Sender, unbounded};
    use crossbeam::sync::WaitGroup;

    use crate::SchedError;
    use crate::placement::{ThreadId, allow_this_thread, keep_off_caller, this_thread};

    type Job = Box<dyn FnOnce() + Send + 'static>;

    /// Threads that each wait on their own channel, so that a run gives every device a thread
    /// of its own: two device loops queued on one thread would wait on each other forever.
    pub(super) struct Pool {
        threads: Vec<Sender<Job>>,
        ids: Vec<ThreadId>,
    }

    static IDLE: Mutex<Vec<Pool>> = Mutex::new(Vec::new());

    /// A pool of at least `threads` threads that no other run is using.
    ///
    /// # Errors
    /// [`SchedError::Threads`] when the operating system refuses a thread.
    pub(super) fn take(threads: usize) -> Result<Pool, SchedError> {
        let mut idle = IDLE.lock().unwrap_or_else(|p| p.into_inner());
        match idle.iter().position(|p| p.threads.len() >= threads) {
            Some(i) => Ok(idle.swap_remove(i)),
            None => Pool::new(threads).map_err(|e| SchedError::Threads {
                threads,
                why: e.to_string(),
            }),
        }
    }

    pub(super) fn give_back(pool: Pool) {
        IDLE.lock().unwrap_or_else(|p| p.into_inner()).push(pool);
    }

    /// Waits, when dropped, until every job holding a clone of its group has ended: on
    /// return and on unwinding alike.
    struct Join(Option<WaitGroup>);

    impl Drop for Join {
        fn drop(&mut self) {
            if let Some(group) = self.0.take() {
                group.wait();
            }
        }
    }

    impl Pool {
        /// Starts the threads; if the system refuses one, those already started end as
        /// their channels close.
        fn new(threads: usize) -> std::io::Result<Pool> {
            let (ids, started) = unbounded::<(usize, ThreadId)>();
            let threads: Vec<Sender<Job>> = (0..threads)
                .map(|k| {
                    let (jobs, inbox) = unbounded::<Job>();
                    let ids = ids.clone();
                    std::thread::Builder::new()
                        .name(format!("sched-device-{}", k + 1))
                        .spawn(move || {
                            let _ = ids.send((k, this_thread()));
                            drop(ids);
                            // A job's panic must not end the thread: its channel would
                            // refuse the next run's job.
                            for job in inbox {
                                let _ = catch_unwind(AssertUnwindSafe(job));
                            }
                        })
                        .map(|_| jobs)
                })
                .collect::<std::io::Result<_>>()?;
            drop(ids);
            let mut id = vec![None; threads.len()];
            for (k, t) in started {
                id[k] = t;
            }
            Ok(Pool { threads, ids: id })
        }

        /// Runs `jobs[k]` on thread `k` and `here` on the calling thread, and returns once all
        /// of them have ended.
        pub(super) fn run<'s>(
            &self,
            jobs: Vec<Box<dyn FnOnce() + Send + 's>>,
            here: impl FnOnce(),
        ) {
            assert!(jobs.len() <= self.threads.len(), "more jobs than threads");
            // Before they are woken: see `placement.rs`.
            let restore = keep_off_caller(&self.ids[..jobs.len()], jobs.len() + 1);
            let group = WaitGroup::new();
            let join = Join(Some(group.clone()));
            for (job, thread) in jobs.into_iter().zip(&self.threads) {
                let token = group.clone();
                let job: Box<dyn FnOnce() + Send + 's> = Box::new(move || {
                    let _token = token;
                    if let Some(all) = restore {
                        allow_this_thread(&all);
                    }
                    job();
                });
                // SAFETY: only the lifetime changes (same type, same layout). What the job
                // borrows lives for `'s`, which outlasts this call, and the call does not end,
                // by return or by unwinding, before the job has: `join` waits in its drop for
                // the job's `_token`, dropped when the job ends (or unwinds, or is dropped
                // unrun along with a refused send).
                let job: Job =
                    unsafe { std::mem::transmute::<Box<dyn FnOnce() + Send + 's>, Job>(job) };
                // A pool's threads outlive it (they end when their channel closes) and
                // survive their jobs' panics, so the receiving end is always there.
                thread
                    .send(job)
                    .unwrap_or_else(|_| unreachable!("a device thread ended"));
            }
            drop(group);
            here();
            drop(join);
        }
    }
}

/// What one device's thread did: its time asking for work, its launches and the CPU time
/// they took of its thread.
#[derive(Clone, Copy, Default)]
struct Totals {
    dispatch_seconds: f64,
    launches: u64,
    cpu_seconds: Option<f64>,
}

/// One device's thread. The order it looks for work in is the policy's (see `Dispatch`),
/// then, with backups, copies of what others hold (`backup.rs`); here it only waits when
/// there is neither, runs launches unlocked and delivers their outputs.
fn device_loop<T: Task, E: Executor<T>>(
    device: usize,
    name: &str,
    exec: &mut E,
    tasks: &[T],
    shared: &Shared<'_, E::Output>,
) -> Totals {
    let mut launch = Vec::new();
    let mut dispatch_seconds = 0.0;
    let mut launches = 0;
    let mut cpu_seconds = crate::thread_cpu_seconds().map(|_| 0.0);
    let totals = |dispatch_seconds, launches, cpu_seconds| Totals {
        dispatch_seconds,
        launches,
        cpu_seconds,
    };
    loop {
        let asked = Instant::now();
        let mut state = shared.lock();
        let copy = loop {
            if state.delivered == tasks.len() {
                return totals(
                    dispatch_seconds + asked.elapsed().as_secs_f64(),
                    launches,
                    cpu_seconds,
                );
            }
            launch.clear();
            let now = shared.seconds(Instant::now());
            state.dispatch.next(device, now, &mut launch);
            if !launch.is_empty() {
                break false;
            }
            let Some(backups) = &shared.backups else {
                state = shared
                    .changed
                    .wait(state)
                    .unwrap_or_else(|p| p.into_inner());
                continue;
            };
            let held: Vec<Held<'_>> = state
                .held
                .iter()
                .enumerate()
                .filter_map(|(d, h)| h.as_ref().map(|h| (d, &h.0)))
                .map(|(d, w)| Held {
                    device: d,
                    tasks: w.rest(),
                    head_started: w.head_started(),
                })
                .collect();
            let done = |t: u32| shared.done[t as usize].load(Ordering::Acquire);
            match backups.choose(device, now, &held, &done) {
                Backup::Copy(copies) => {
                    launch.extend(copies);
                    break true;
                }
                Backup::Wait(at) => {
                    drop(held);
                    state = match at {
                        Some(at) => {
                            let wait = Duration::from_secs_f64((at - now).clamp(0.0, 3600.0));
                            shared
                                .changed
                                .wait_timeout(state, wait)
                                .map_or_else(|p| p.into_inner().0, |r| r.0)
                        }
                        None => shared
                            .changed
                            .wait(state)
                            .unwrap_or_else(|p| p.into_inner()),
                    };
                }
            }
        };
        let watch = Arc::new(Watch::new(
            launch.clone(),
            Arc::clone(&shared.done),
            shared.start,
        ));
        if shared.backups.is_some() {
            if copy {
                state.copies += launch.len() as u64;
            }
            state.held[device] = Some((Arc::clone(&watch), copy));
            // Devices waiting for work weigh copies of what this launch holds.
            shared.changed.notify_all();
        }
        drop(state);
        dispatch_seconds += asked.elapsed().as_secs_f64();
        launches += 1;

        let batch: Vec<&T> = launch.iter().map(|&t| &tasks[t as usize]).collect();
        let mut sink = Sink::watched(watch);
        let started = Instant::now();
        let cpu_before = crate::thread_cpu_seconds();
        let result = catch_unwind(AssertUnwindSafe(|| exec.run_batch(&batch, &mut sink)));
        if let (Some(total), Some(a), Some(b)) = (
            cpu_seconds.as_mut(),
            cpu_before,
            crate::thread_cpu_seconds(),
        ) {
            *total += (b - a).max(0.0);
        }
        let failure = match result {
            Ok(Ok(())) if sink.len() == batch.len() => None,
            Ok(Ok(())) => Some(DeviceError::msg(format!(
                "returned {} outputs for a batch of {}",
                sink.len(),
                batch.len()
            ))),
            Ok(Err(e)) => Some(e),
            Err(panic) => Some(DeviceError::msg(format!(
                "panicked: {}",
                panic_message(&*panic)
            ))),
        };

        let mut state = shared.lock();
        state.held[device] = None;
        let mut from = shared.seconds(started);
        for (&task, (output, at, device_seconds)) in launch.iter().zip(sink.into_outputs()) {
            let end = shared.seconds(at);
            match output {
                Some(output) => {
                    state.spans.push(Span {
                        device: device as u32,
                        task,
                        start: from,
                        end,
                        device_seconds,
                    });
                    state.outputs[task as usize] = Some(output);
                    state.delivered += 1;
                }
                None => state.wasted += end - from,
            }
            from = end;
        }
        // A copy's tasks are still held by the devices they were copied from; a device's
        // own tasks without an output, whether it failed on them or skipped them while they
        // were still wanted, are handed out again.
        let undone: Vec<u32> = if copy {
            Vec::new()
        } else {
            let done = |t: u32| shared.done[t as usize].load(Ordering::Acquire);
            launch.iter().copied().filter(|&t| !done(t)).collect()
        };
        let failure = failure.or_else(|| {
            (!undone.is_empty())
                .then(|| DeviceError::msg(format!("skipped {} tasks still wanted", undone.len())))
        });
        if let Some(error) = failure {
            state.reruns += undone.len() as u64;
            state.dispatch.fail(device, &undone);
            state.failures.push(DeviceFailure {
                device,
                name: name.to_owned(),
                reason: error.to_string(),
                orphaned: undone.len(),
            });
            shared.changed.notify_all();
            return totals(dispatch_seconds, launches, cpu_seconds);
        }
        if state.delivered == tasks.len() || shared.backups.is_some() {
            shared.changed.notify_all();
        }
    }
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> &str {
    panic
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| panic.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(no message)")
}

#[cfg(test)]
mod tests {
    use std::ops::Range;

    use super::*;

    /// Reports a made-up device time (the task's length in milliseconds) for every task.
    struct Timed;

    impl Executor<Range<usize>> for Timed {
        type Output = usize;
        fn run(&mut self, task: &Range<usize>) -> Result<usize, DeviceError> {
            Ok(task.len())
        }
        fn run_batch(
            &mut self,
            tasks: &[&Range<usize>],
            sink: &mut Sink<usize>,
        ) -> Result<(), DeviceError> {
            for t in tasks {
                sink.push_timed(t.len(), t.len() as f64 * 1e-3);
            }
            Ok(())
        }
    }

    /// Each job runs once, all at the same time, the first on the calling thread.
    #[test]
    fn device_threads_run_each_job_once_side_by_side() {
        let caller = std::thread::current().id();
        let barrier = std::sync::Barrier::new(3);
        let mut ran = vec![None; 3];
        let jobs: Vec<Box<dyn FnOnce() + Send + '_>> = ran
            .iter_mut()
            .map(|out| {
                let barrier = &barrier;
                Box::new(move || {
                    // Every job waits for the others: run one after another, none would end.
                    barrier.wait();
                    *out = Some(std::thread::current().id());
                }) as Box<dyn FnOnce() + Send + '_>
            })
            .collect();
        Runtime::on_device_threads(jobs).expect("threads");
        let ran: Vec<_> = ran.into_iter().map(|t| t.expect("ran")).collect();
        assert_eq!(ran[0], caller);
        assert!(ran[1] != ran[2] && !ran[1..].contains(&caller));
        Runtime::on_device_threads(Vec::new()).expect("nothing to run");
    }

    #[test]
    fn device_measured_times_reach_the_timeline_and_host_times_stay_unset() {
        let tasks = crate::split_ranges(100, 7);
        let costs = Costs::uniform(tasks.len());
        for policy in Policy::ALL {
            let run = Runtime::new(policy)
                .run(&tasks, &costs, &mut [Timed, Timed])
                .expect("run");
            assert_eq!(run.timeline.spans.len(), tasks.len());
            for s in &run.timeline.spans {
                let want = tasks[s.task as usize].len() as f64 * 1e-3;
                assert_eq!(s.device_seconds, Some(want), "{policy:?}");
            }
        }
        struct Plain;
        impl Executor<Range<usize>> for Plain {
            type Output = usize;
            fn run(&mut self, task: &Range<usize>) -> Result<usize, DeviceError> {
                Ok(task.len())
            }
        }
        let run = Runtime::new(Policy::QueueFifo)
            .run(&tasks, &costs, &mut [Plain])
            .expect("run");
        assert!(
            run.timeline
                .spans
                .iter()
                .all(|s| s.device_seconds.is_none())
        );
    }

    /// Sleeps `per_task` for each task, in slices, giving up on a task another device has
    /// delivered.
    struct Sleeper {
        per_task: std::time::Duration,
        speed: f64,
    }

    impl Executor<Range<usize>> for Sleeper {
        type Output = usize;
        fn run(&mut self, task: &Range<usize>) -> Result<usize, DeviceError> {
            std::thread::sleep(self.per_task);
            Ok(task.start)
        }
        fn run_batch(
            &mut self,
            tasks: &[&Range<usize>],
            sink: &mut Sink<usize>,
        ) -> Result<(), DeviceError> {
            for t in tasks {
                let until = Instant::now() + self.per_task;
                while sink.wanted() && Instant::now() < until {
                    std::thread::sleep(std::time::Duration::from_millis(1));
                }
                if sink.wanted() {
                    sink.push(t.start);
                } else {
                    sink.skip();
                }
            }
            Ok(())
        }
        fn speed(&self) -> f64 {
            self.speed
        }
    }

    #[test]
    fn an_idle_device_copies_a_slow_ones_tasks_and_the_slow_one_stops() {
        let tasks = crate::split_ranges(10, 1);
        let costs = Costs::uniform(tasks.len());
        let devices = || {
            [
                Sleeper {
                    per_task: std::time::Duration::from_millis(2),
                    speed: 1.0,
                },
                // Declared as fast as the other, 200 times slower.
                Sleeper {
                    per_task: std::time::Duration::from_millis(400),
                    speed: 1.0,
                },
            ]
        };
        let started = Instant::now();
        let run = Runtime::new(Policy::StaticEqual)
            .run(&tasks, &costs, &mut devices())
            .expect("run");
        let seconds = started.elapsed().as_secs_f64();
        assert_eq!(run.outputs, (0..10).collect::<Vec<_>>());
        assert_eq!(run.timeline.spans.len(), 10);
        assert!(run.copies >= 5, "{} copies", run.copies);
        // Without copies the slow device's five tasks take 2 s.
        assert!(seconds < 1.0, "{seconds} s");
        let plain = Runtime::new(Policy::StaticEqual)
            .backups(false)
            .run(&tasks, &costs, &mut devices())
            .expect("run");
        assert_eq!(plain.copies, 0);
        assert_eq!(
            plain.timeline.assignment(10),
            vec![0, 0, 0, 0, 0, 1, 1, 1, 1, 1]
        );
    }
}
