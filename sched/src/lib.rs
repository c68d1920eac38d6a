//! Cost-based scheduling of irregular tasks across heterogeneous devices.
//!
//! Estimate what each task will cost ([`CostEstimator`]), let a [`Policy`] assign the tasks
//! to devices of different speeds, and run them on real devices ([`Runtime`], one host thread
//! per [`Executor`]) or on virtual ones ([`Simulation`], with launch latency and faults).
//! Either way, a device left with nothing to do may run backup copies of tasks that another
//! device holds, when the model says the copy would finish sooner; the first output of each
//! task is kept (`Runtime::backups`, `Simulation::backups`).
//! The method is the cost-based static balancing of Rincón-Nigro (2012, University of Houston): sort tasks by
//! decreasing estimated cost and give each to the device that would finish it first (LPT,
//! within 4/3 of optimal), so a single launch per device balances almost as well as a
//! dynamic queue without its per-task dispatch cost.
//!
//! # Example
//!
//! Depending on `sched` from another crate: describe a device, estimate, run.
//!
//! ```
//! use std::ops::Range;
//! use sched::{CostEstimator, DeviceError, Executor, Policy, Runtime};
//!
//! /// A device that counts primes in a range of integers.
//! struct PrimeCounter { speed: f64 }
//!
//! impl Executor<Range<usize>> for PrimeCounter {
//!     type Output = usize;
//!     fn run(&mut self, task: &Range<usize>) -> Result<usize, DeviceError> {
//!         Ok(task.clone().filter(|&n| n > 1 && (2..n).take_while(|d| d * d <= n).all(|d| n % d != 0)).count())
//!     }
//!     fn speed(&self) -> f64 { self.speed }
//! }
//!
//! // Work grows with the numbers tested: a cheap estimate of each task's cost.
//! let estimate = |t: &Range<usize>| (t.start..t.end).map(|n| (n as f64).sqrt()).sum::<f64>();
//! let tasks = sched::split_ranges(20_000, 500);
//! let costs = estimate.estimate_timed(&tasks)?.costs;
//!
//! let mut devices = [PrimeCounter { speed: 1.0 }, PrimeCounter { speed: 2.0 }];
//! let run = Runtime::new(Policy::StaticLpt).run(&tasks, &costs, &mut devices)?;
//! assert_eq!(run.outputs.iter().sum::<usize>(), 2262);
//! // A static plan launches once per device; a device left idle may launch backup copies
//! // of tasks the other holds, unless they are turned off.
//! let run = Runtime::new(Policy::StaticLpt)
//!     .backups(false)
//!     .run(&tasks, &costs, &mut devices)?;
//! assert_eq!(run.launches, vec![1, 1]);
//! # Ok::<(), sched::SchedError>(())
//! ```
//!
//! The [`bounds`] module states each policy's guarantee and a lower bound on the optimum;
//! [`exact`] computes the optimum of small instances, against which the guarantees are
//! property-tested.
//!
//! [`study`] compares the policies on a workload of your own: real runs in regular and cost
//! mode, their replay on a simulated machine of mixed speeds, and the estimator's error and
//! overhead against its sampling rate (what `cobalt knn` and `cobalt collide` print).
//!
//! Two helpers for building workloads: [`locality`] sorts 3D points along a Z curve, so that
//! a range of them (a task) is a compact region of space, and [`Rng`] is a small seeded
//! generator for reproducible workloads and tests.
//!
//! Runnable examples in `sched/examples/` go further: `custom_workload` (your own [`Task`]
//! and [`Executor`], and a device that fails without losing work), `custom_estimator` (a
//! sampling [`CostEstimator`] and the plan it buys) and `simulate` (every [`Policy`] in the
//! [`Simulation`], with latency, wrong estimates and a fault). Run one with
//! `cargo run -p sched --example simulate`.
//!
//! With the `mpi` feature, `mpi` makes the ranks of an MPI job the nodes of one run: a
//! `RemoteNode` is another rank seen as an [`Executor`] by rank 0's runtime.

mod backup;
pub mod bounds;
mod clock;
mod cost;
mod dispatch;
mod error;
pub mod exact;
mod executor;
mod homes;
mod load;
pub mod locality;
#[cfg(feature = "mpi")]
pub mod mpi;
pub mod outliers;
mod placement;
mod plan;
mod policy;
mod replay;
mod rng;
mod runtime;
mod sample;
mod simulate;
mod speeds;
pub mod study;
mod task;
mod timeline;

pub use clock::{Clock, thread_cpu_seconds};
pub use cost::{
    ByItems, CostEstimator, Costs, Estimate, Uniform, prediction_error, rank_correlation,
};
pub use dispatch::Dispatch;
pub use error::{DeviceFailure, SchedError};
pub use executor::{DeviceError, Executor, Sink};
pub use homes::{Homes, plan_lpt_homed};
pub use load::Load;
pub use plan::Plan;
pub use policy::{HybridDispatch, Policy, QueueDispatch, StaticDispatch, plan_equal, plan_lpt};
pub use replay::{MeasuredRun, MeasuredTask};
pub use rng::Rng;
pub use runtime::{RunReport, Runtime};
pub use sample::{BadSampleRate, SampleRate};
pub use simulate::{Fault, SimReport, Simulation};
pub use speeds::Speeds;
pub use task::{Task, split_ranges};
pub use timeline::{Metrics, Span, Timeline};

/// The Rust code of the workspace's `README.md`, run as doctests so that the example a user
/// copies first keeps compiling.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeDoctests;
