//! The thesis experiment, measured: for each workload (Whitted: coherent rays; AO: diffuse
//! rays), task size, policy and mode (`regular`: equal costs; `cost`: estimates from a sample
//! of each task's paths), every camera of a scene rendered by the render engine on the given
//! devices, one [`Record`] per cell ([`SceneMatrix::run`]).
//!
//! Cells run in rounds that each run the whole matrix once, and repeated runs of a cell are
//! combined into medians (`repeats.rs`). Each measured frame is replayed in `sched`'s
//! simulator with its own task times (`replay.rs`), and the measured tasks are replayed on
//! machines this one is not, or on more devices of the classes it measured ([`simulate`]). [`sampling_trade`] measures the sampling trade of
//! thesis Table 4.1; [`table`] turns all of it into Markdown tables. Over MPI, `mpi` does
//! the same between nodes (feature `mpi`).

mod error;
mod matrix;
#[cfg(feature = "mpi")]
pub mod mpi;
mod paths;
mod record;
mod repeats;
mod replay;
mod simulate;
pub mod table;
mod trade;

pub use error::BenchError;
pub use matrix::{Replays, SceneMatrix};
pub use record::{MpiFigures, Record};
pub use simulate::{Fleet, MAX_DEVICES, Machines, Projected, Projection, SimRecord, simulate};
pub use trade::{TradePoint, sampling_trade};
