//! The sampling-rate trade of thesis Table 4.1: prediction error against estimation overhead
//! at 12.5, 25, 50 and 100 % of each task's rays, for coherent (primary) and diffuse (AO) rays,
//! and below the thesis's rates (3.125 and 6.25 %): on a CPU the reduced traversal of a ray
//! costs a far larger share of its trace than on the thesis's GPU, so the overhead target of
//! [`meets_target`] (4 %) is met only at the lower rates.

use serde::Serialize;

use super::error::BenchError;
use super::matrix::SceneMatrix;
use crate::bvh::Bvh;
use crate::cost::judge::judge;
use crate::cost::{
    Budget, CostModel, ReducedTraversal, Rounds, Sample, SampleRate, SlicedStep, SlicedTraces,
    Work, full_work, measure_seconds, prediction_error,
};
use crate::ray::{RayBatch, RayKind};
use crate::traverse::{self, Walk};
use crate::workload;

/// The sampling rates measured: the thesis's four, and two below them.
pub const RATES: [f64; 6] = [0.03125, 0.0625, 0.125, 0.25, 0.5, 1.0];

/// One cell pair of thesis Table 4.1: error and overhead at a sampling rate.
struct Published {
    rate: f64,
    error: f64,
    overhead: f64,
}

const fn published(rate: f64, error: f64, overhead: f64) -> Published {
    Published {
        rate,
        error,
        overhead,
    }
}

/// Thesis Table 4.1 (averaged over its nine scenes), per ray kind.
const THESIS: [(&str, [Published; 4]); 2] = [
    (
        "coherent",
        [
            published(0.125, 0.032, 0.050),
            published(0.25, 0.025, 0.125),
            published(0.5, 0.007, 0.225),
            published(1.0, 0.0, 0.425),
        ],
    ),
    (
        "diffuse",
        [
            published(0.125, 0.041, 0.062),
            published(0.25, 0.027, 0.152),
            published(0.5, 0.012, 0.235),
            published(1.0, 0.0, 0.435),
        ],
    ),
];

/// The targets the bench checks: prediction error at most 2 % (coherent) or 3 % (diffuse)
/// rays, with an overhead of at most 4 % of the full trace.
fn meets_target(kind: &str, error: f64, overhead: f64) -> bool {
    let most = if kind == "coherent" { 0.02 } else { 0.03 };
    error <= most && overhead <= 0.04
}

/// One point of the trade.
#[derive(Clone, Debug, Serialize)]
pub struct TradePoint {
    /// Always `sampling_trade` (the bench JSON's records are told apart by `source`).
    pub source: &'static str,
    /// The scene (`--scene`).
    pub scene: String,
    /// Its rays: `coherent` or `diffuse`.
    pub ray_kind: &'static str,
    /// Paths (rays) per task.
    pub task_size: usize,
    /// Rays traced over the frames.
    pub rays: usize,
    /// The share of the rays the estimate traced.
    pub sample_rate: f64,
    /// With walk `trace-refined`: the halves' disagreement its sample refined to, up to the
    /// thesis's rate (`ReducedTraversal::with_sample_error`).
    pub sample_error: Option<f64>,
    /// How the sample was traced: `reduced`, `first-leaf`, `trace` (the real trace) or
    /// `trace-refined` (the real trace of a sample refined only as far as it needs).
    pub walk: &'static str,
    /// The estimates, calibrated (`kB`, `kT`), against each task's measured single-thread
    /// trace time: what a plan needs of them.
    pub error_vs_time: Option<f64>,
    /// Their rank correlation with the measured task times.
    pub spearman_vs_time: Option<f64>,
    /// The same with each task's exact counts of the real trace: what no estimate of `B` and
    /// `T` can beat.
    pub error_vs_time_trace: Option<f64>,
    /// The real trace's counts' rank correlation with the times.
    pub spearman_trace_vs_time: Option<f64>,
    /// The thesis's, against the walk's own full count (secondary: it does not see time).
    pub prediction_error: f64,
    /// Estimation time over the full trace's time, both on all cores: the median over pairs
    /// of rounds of each pair's share (see [`Rounds`]).
    pub overhead: f64,
    /// What estimating costs a render: the overhead less the sample's trace, where the walk
    /// traced it for real and the render reuses its hits; else the overhead.
    pub net_overhead: f64,
    /// The thesis's error and overhead at this rate and ray kind, where Table 4.1 has them.
    pub thesis_prediction_error: Option<f64>,
    /// The thesis's overhead at this rate and ray kind.
    pub thesis_overhead: Option<f64>,
    /// The target met: error ≤ 2 % coherent / 3 % diffuse, overhead ≤ 4 %.
    pub meets_target: bool,
    /// What the estimates buy a plan: the balance of an LPT plan by them (calibrated) on 8
    /// equal devices, judged by the measured task times.
    pub lpt_balance: Option<f64>,
}

/// `estimator`'s overhead and net overhead on `tasks` of `rays` (traced for any hits with
/// `any`, else closest hits): the trace, the trace left after the sample (where `known`, the
/// sampled rays, are reused) and the estimate timed in rounds, each figure the median of its
/// pairs of rounds' own shares of the trace, as `cobalt estimate` takes them (see
/// [`Rounds`]).
fn shares(
    (bvh, rays, any): (&Bvh, &RayBatch, bool),
    estimator: &ReducedTraversal<'_>,
    tasks: &[std::ops::Range<usize>],
    known: Option<Vec<usize>>,
) -> Result<(f64, f64), BenchError> {
    let reuses = known.is_some();
    let known = known.unwrap_or_default();
    let traces = SlicedTraces::new(bvh, [(rays, any, &known[..])]);
    let mut trace = |s: usize| {
        traces.run(s, false);
        Ok(())
    };
    let mut rest = |s: usize| {
        traces.run(s, true);
        Ok(())
    };
    let mut estimate = || -> Result<(), BenchError> {
        std::hint::black_box(estimator.try_sample(tasks)?);
        Ok(())
    };
    // The rest is timed only where the render reuses the sample's hits.
    let sliced: &mut [SlicedStep<'_, BenchError>] = if reuses {
        &mut [&mut trace, &mut rest]
    } else {
        &mut [&mut trace]
    };
    let steps = sliced.len();
    let timed = Rounds::time(
        Budget::trade(),
        sched::Clock::Wall,
        traces.count(),
        sliced,
        &mut [&mut estimate],
    )?;
    let overhead = timed.median_share(|r| r[steps]);
    let net = if reuses {
        timed.median_share(|r| r[2] + r[1] - r[0])
    } else {
        overhead
    };
    Ok((overhead, net))
}

/// The rates the trace walk is measured at: its net overhead is what matters, and above
/// these the sample costs what the trace it saves does.
const TRACE_RATES: [f64; 4] = [0.03125, 0.0625, 0.125, 0.25];

/// Greatest common divisor, for the finest task size every size is made of.
fn gcd(a: usize, b: usize) -> usize {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Sums `per` (values of consecutive chunks of `unit` rays) into tasks of `size` rays, a
/// multiple of `unit`.
fn regroup(per: &[f64], unit: usize, size: usize) -> Vec<f64> {
    per.chunks(size / unit).map(|c| c.iter().sum()).collect()
}

fn points(
    scene: &str,
    bvh: &Bvh,
    rays: &RayBatch,
    kind: &'static str,
    occlusion: bool,
    walk: Walk,
    task_sizes: &[usize],
) -> Result<Vec<TradePoint>, BenchError> {
    let model = CostModel::default();
    // Each task's measured time and real-trace counts, from chunks of the finest size that
    // all task sizes are made of, so the rays are timed once.
    let unit = task_sizes.iter().copied().fold(0, gcd).max(1);
    let chunks = sched::split_ranges(rays.len(), unit);
    let ray_kind = if occlusion {
        RayKind::Ao
    } else {
        RayKind::Primary
    };
    let chunk_seconds = measure_seconds(bvh, rays, &chunks, ray_kind, 3, sched::Clock::Wall)?;
    let counts = if occlusion {
        traverse::any_hits_counted(bvh, rays).1
    } else {
        traverse::closest_hits_counted(bvh, rays).1
    };
    let chunk_work: Vec<Work> = chunks
        .iter()
        .map(|r| Work::sum(&counts[r.clone()]))
        .collect();
    let thesis = THESIS.iter().find(|(k, _)| *k == kind).map(|(_, t)| t);
    let mut out = Vec::new();
    for &task_size in task_sizes {
        let tasks = sched::split_ranges(rays.len(), task_size);
        let seconds = regroup(&chunk_seconds, unit, task_size);
        let trace_work: Vec<Work> = chunk_work
            .chunks(task_size / unit)
            .map(|c| c.iter().fold(Work::default(), |a, &w| a.plus(w)))
            .collect();
        let trace_judged = judge(&trace_work, &seconds);
        let (error_vs_time_trace, spearman_trace_vs_time) =
            (trace_judged.error_vs_time, trace_judged.spearman_vs_time);
        let traced = Walk::Trace { any: occlusion };
        // Every rate fixed, and the trace walk's sample refined up to the thesis's rate as
        // `cobalt estimate` takes it by default.
        let refined = Some(ReducedTraversal::DEFAULT_SAMPLE_ERROR);
        let runs = RATES
            .iter()
            .map(|&r| (walk, r, None))
            .chain(TRACE_RATES.iter().map(|&r| (traced, r, None)))
            .chain(std::iter::once((traced, SampleRate::THESIS.get(), refined)));
        let mut fulls: Vec<(&'static str, Vec<f64>)> = Vec::new();
        for (p, rate, sample_error) in runs {
            let full = match fulls.iter().find(|(name, _)| *name == p.name()) {
                Some((_, f)) => f.clone(),
                None => {
                    let f = model.costs(&full_work(bvh, rays, &tasks, p)?);
                    fulls.push((p.name(), f.clone()));
                    f
                }
            };
            let rate = SampleRate::new(rate).map_err(crate::cost::CostError::from)?;
            let estimator = ReducedTraversal::new(bvh, rays, rate)
                .with_walk(p)
                .with_sample_error(sample_error);
            let Sample {
                work,
                sampled,
                traced: traced_sample,
            } = estimator.try_sample(&tasks)?;
            let est = model.costs(&work);
            let prediction_error = prediction_error(&est, &full)?;
            let (overhead, net_overhead) = shares(
                (bvh, rays, occlusion),
                &estimator,
                &tasks,
                (p == traced).then(|| traced_sample.map(|t| t.index).unwrap_or_default()),
            )?;
            let judged = judge(&work, &seconds);
            let (error_vs_time, spearman_vs_time) = (judged.error_vs_time, judged.spearman_vs_time);
            let lpt_balance = judged.lpt_balance;
            let thesis_at = thesis
                .filter(|_| p != traced)
                .and_then(|t| t.iter().find(|x| x.rate == rate.get()));
            out.push(TradePoint {
                source: "sampling_trade",
                scene: scene.to_string(),
                ray_kind: kind,
                task_size,
                rays: rays.len(),
                sample_rate: sampled as f64 / rays.len().max(1) as f64,
                sample_error,
                walk: if sample_error.is_some() {
                    "trace-refined"
                } else {
                    p.name()
                },
                error_vs_time,
                spearman_vs_time,
                error_vs_time_trace,
                spearman_trace_vs_time,
                prediction_error,
                overhead,
                net_overhead,
                thesis_prediction_error: thesis_at.map(|x| x.error),
                thesis_overhead: thesis_at.map(|x| x.overhead),
                meets_target: meets_target(kind, prediction_error, overhead),
                lpt_balance,
            });
        }
    }
    Ok(out)
}

/// The trade on orbit camera 0 at the matrix's size, for tasks of each of its task sizes, with
/// the thesis's reduced traversal.
pub fn sampling_trade(matrix: &SceneMatrix) -> Result<Vec<TradePoint>, BenchError> {
    let (name, scene, bvh) = (matrix.scene_name, matrix.scene, matrix.bvh);
    let (width, height, ao_samples) = (matrix.width, matrix.height, matrix.ao_samples);
    let task_sizes: Vec<usize> = matrix.task_sizes.iter().map(|t| t.get()).collect();
    let (task_sizes, walk) = (&task_sizes[..], Walk::Reduced);
    let primary = workload::orbit_primary(scene, width, height, 0..1);
    let ao = workload::orbit_ao(scene, bvh, width, height, 0, ao_samples).rays;
    let coherent = walk.for_kind(RayKind::Primary);
    let mut out = points(name, bvh, &primary, "coherent", false, coherent, task_sizes)?;
    if !ao.is_empty() {
        let diffuse = walk.for_kind(RayKind::Ao);
        out.extend(points(
            name, bvh, &ao, "diffuse", true, diffuse, task_sizes,
        )?);
    }
    Ok(out)
}
