//! `cobalt knn`: batched k-nearest-neighbour queries (kiddo) on a clustered cloud or a
//! scene's vertices, balanced over CPU devices in regular and cost mode.

use std::path::PathBuf;

use knn::{
    Clustered, DensityEstimator, DensityGrid, Device, KnnIndex, KnnQueries, PointCloud, SampleRate,
    SampledQueries,
};
use raytrace::SceneNeeds;
use sched::CostEstimator;
use sched::study::Workload;

use crate::args::{count, sample_rate};
use crate::error::CliError;
use crate::limits::memory;
use crate::spatial::RunArgs;

/// How a task's cost is estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Estimator {
    /// Points of a density grid near the task's queries: no search.
    Density,
    /// The timed real search of a sample of the task's queries.
    Sampled,
}

impl Estimator {
    fn name(self) -> &'static str {
        match self {
            Self::Density => "density",
            Self::Sampled => "sampled",
        }
    }
}

/// Arguments of `cobalt knn`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Points in the generated cloud (ignored with --scene), 1..=2^28.
    #[arg(long, default_value_t = 200_000, value_parser = count::<{ 1 << 28 }>)]
    points: usize,
    /// Use the vertices of this OBJ scene as the cloud.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Query points: half near the data, half uniform in its bounding box; 1..=2^28.
    #[arg(long, default_value_t = 100_000, value_parser = count::<{ 1 << 28 }>)]
    queries: usize,
    /// Neighbours per query, 1..=1024.
    #[arg(long, default_value_t = 16, value_parser = count::<1024>)]
    k: usize,
    /// Queries per task, 1..=2^24.
    #[arg(long, default_value_t = 1024, value_parser = count::<{ 1 << 24 }>)]
    task_size: usize,
    /// Share of each task's queries the estimator looks at, in (0, 1].
    #[arg(long, default_value = "0.125", value_parser = sample_rate)]
    sample_rate: SampleRate,
    /// `density` (a density grid, no search: cheap, deterministic, rough) or `sampled` (times
    /// the real search of sampled queries: better ranks, timing noise, costlier).
    #[arg(long, value_enum, default_value = "density")]
    estimator: Estimator,
    /// Seed of the cloud and the queries.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    run: RunArgs,
}

/// Runs the command.
pub fn run(args: Args) -> Result<(), CliError> {
    if args.scene.is_none() {
        // The cloud, its copy in the index and the index's own nodes.
        memory("points", &args.points.to_string(), &[(args.points, 64)])?;
    }
    // Each query, its sorted copy and its k neighbours (index and distance).
    let per_query = 32 + 8 * args.k as u64;
    memory(
        "queries",
        &args.queries.to_string(),
        &[(args.queries, per_query)],
    )?;
    let density = args.estimator == Estimator::Density;
    let knn_err = |flag: &'static str, value: String| {
        move |e: knn::KnnError| CliError::Arg {
            flag,
            value,
            message: e.to_string(),
        }
    };
    let (cloud, source) = match &args.scene {
        Some(path) => {
            // Geometry only: the cloud is the scene's vertices, which sample its surfaces
            // densely where the modeller put detail and sparsely elsewhere.
            let scene = crate::limits::scene(&path.to_string_lossy())?.load(SceneNeeds::AO)?;
            let points = scene.positions.iter().map(|p| p.to_array()).collect();
            (PointCloud { points }, path.display().to_string())
        }
        None => (
            PointCloud::clustered(args.points, Clustered::default(), args.seed),
            "clustered".to_string(),
        ),
    };
    let queries = cloud.queries(args.queries, args.seed);
    let index =
        KnnIndex::build(cloud.points).map_err(knn_err("points", args.points.to_string()))?;
    let batch =
        KnnQueries::new(queries, args.k, &index).map_err(knn_err("k", args.k.to_string()))?;
    let grid = DensityGrid::new(index.points(), 64);
    let (index, batch, grid) = (&index, &batch, &grid);
    let k = args.k;
    let work = Workload {
        name: format!(
            "knn {source} ({} points, k {k}, {} estimator)",
            index.points().len(),
            args.estimator.name()
        ),
        items: batch.len(),
        task_size: args.task_size,
        tasks: sched::split_ranges(batch.len(), args.task_size),
        estimate: Box::new(move |rate, tasks| {
            let e = if density {
                DensityEstimator::new(grid, batch, rate).estimate_timed(tasks)?
            } else {
                SampledQueries::new(index, batch, rate).estimate_timed(tasks)?
            };
            Ok((e.costs.as_slice().to_vec(), e.seconds))
        }),
        devices: Box::new(move |n| Device::many(index, batch, n)),
        check: Box::new(move |outputs| {
            let got = batch.gather(outputs);
            // Spot-check a few queries against brute force: the property tests check all.
            for i in (0..batch.len()).step_by((batch.len() / 7).max(1)) {
                let q = &batch.points[i];
                let input = batch.order[i] as usize;
                if !knn::reference::is_knn(index.points(), q, k, &got[input * k..(input + 1) * k]) {
                    return Err(CliError::Write(format!("query {input}: wrong neighbours")));
                }
            }
            Ok(())
        }),
    };
    crate::spatial::run(&work, &args.run, args.sample_rate)
}
