//! The seam between the generations pipeline and the hardware: a device that traces ranges of
//! a generation's rays ([`RayDevice`]), the adapter that makes one a [`sched::Executor`] for one
//! generation ([`Bound`]), and fault injection for any of them ([`FailingAfter`]).
//!
//! It sits below both the devices that implement it ([`crate::cpu`], `crate::gpu`) and the
//! tracer that drives them ([`crate::scheduled`]), so neither imports the other.

mod device;
mod fault;

pub use device::{BadRange, Bound, RayDevice};
pub use fault::{FailingAfter, InjectedFault};
