//! Batched k-nearest-neighbour queries on [kiddo], balanced across devices by [`sched`].
//!
//! `sched`'s cost-based balancing on another spatial structure: queries are sorted along the
//! Z curve ([`sched::locality`]) and cut into tasks (ranges), a cheap [`DensityEstimator`]
//! predicts each task's cost from a coarse [`DensityGrid`] (no tree search, a sample of the
//! queries), and a `sched` policy spreads the tasks over [`Device`]s. Point clouds of
//! strongly varying density ([`PointCloud::clustered`], or the caller's own points such as a
//! mesh's vertices) make the costs irregular: queries in the sparse space beside a dense
//! cluster examine many more points than queries inside it.
//!
//! # Example
//!
//! ```
//! use knn::{Clustered, DensityEstimator, DensityGrid, Device, KnnIndex, KnnQueries, PointCloud, SampleRate};
//! use sched::{CostEstimator, Policy, Runtime};
//!
//! let cloud = PointCloud::clustered(20_000, Clustered::default(), 1);
//! let queries = cloud.queries(4_000, 2);
//! let index = KnnIndex::build(cloud.points.clone())?;
//! let batch = KnnQueries::new(queries.clone(), 8, &index)?;
//! let tasks = sched::split_ranges(batch.len(), 256);
//!
//! // Estimate each task from an eighth of its queries, then balance with LPT.
//! let grid = DensityGrid::new(index.points(), 32);
//! let estimator = DensityEstimator::new(&grid, &batch, SampleRate::new(0.125)?);
//! let costs = estimator.estimate_timed(&tasks)?.costs;
//! let mut devices = Device::many(&index, &batch, 2);
//! let run = Runtime::new(Policy::StaticLpt).run(&tasks, &costs, &mut devices)?;
//!
//! let neighbours = batch.gather(&run.outputs); // 8 per query, in input order
//! assert!(knn::reference::is_knn(index.points(), &queries[7], 8, &neighbours[56..64]));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod cloud;
mod error;
mod estimate;
mod grid;
mod query;
pub mod reference;
mod task;

pub use cloud::{Clustered, PointCloud};
pub use error::KnnError;
pub use estimate::{DensityEstimator, SampleRate, SampledQueries, prediction_error};
pub use grid::DensityGrid;
pub use query::{KnnIndex, KnnQueries};
pub use task::Device;
