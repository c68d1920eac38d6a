//! How well an estimate of each task's cost predicts its measured time, and what estimating
//! costs a render: `cobalt estimate`'s measurement.
//!
//! For one or more generations of rays cut into tasks ([`Generations`]), [`measure`] times
//! each task's single-thread trace, then the estimates and the full trace (on the CPU, every
//! walk in the same [`Rounds`](crate::cost::Rounds)), and judges the estimates against the
//! times ([`crate::cost::judge`]): the error and rank correlation of the calibrated estimates,
//! beside their bound (the real trace's own counts) and the net overhead, then the thesis's
//! prediction error and overhead. The [`Report`] holds the figures; [`Report::table`] prints
//! them.

mod error;
mod measure;
mod rays;
mod report;
mod table;

pub use error::EstimateError;
pub use measure::{Device, Settings, WalkChoice, measure};
pub use rays::Generations;
pub use report::{Calibration, Report, WalkFigures, WalkFit, WalkTrade};
