//! The sampling-rate trade of thesis Table 4.1: prediction error against estimation overhead
//! at 12.5, 25, 50 and 100 % of each task's rays, for coherent (primary) and diffuse (AO) rays,
//! and below the thesis's rates (3.125 and 6.25 %): on a CPU the reduced traversal of a ray
//! costs a far larger share of its trace than on the thesis's GPU, so the overhead target of
//! [`meets_target`] (4 %) is met only at the lower rates.

use serde::Serialize;

use super::error::BenchError;
use super::matrix::SceneMatrix;
use crate::cost::{Budget, CostError, ReducedTraversal, SampleRate, SampleRun};
use crate::estimate::{
    Device, EstimateError, Generations, Settings, WalkChoice, WalkFigures, measure,
};
use crate::ray::{RayBatch, RayKind};
use crate::traverse::Walk;
use crate::workload;

/// The sampling rates measured: the thesis's four, and two below them.
pub const RATES: [f64; 6] = [0.03125, 0.0625, 0.125, 0.25, 0.5, 1.0];

/// One cell pair of thesis Table 4.1: a sampling rate, and the prediction error and the
/// estimation overhead published for it.
type Published = (f64, f64, f64);

/// Thesis Table 4.1 (averaged over its nine scenes), per ray kind.
const THESIS: [(&str, [Published; 4]); 2] = [
    (
        "coherent",
        [
            (0.125, 0.032, 0.050),
            (0.25, 0.025, 0.125),
            (0.5, 0.007, 0.225),
            (1.0, 0.0, 0.425),
        ],
    ),
    (
        "diffuse",
        [
            (0.125, 0.041, 0.062),
            (0.25, 0.027, 0.152),
            (0.5, 0.012, 0.235),
            (1.0, 0.0, 0.435),
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
    /// The estimates judged by time, and what they cost a render. Their walk is `reduced`,
    /// `first-leaf`, `trace` (the real trace) or `trace-refined` (the real trace of a sample
    /// refined only as far as it needs); their prediction error is never `null` here.
    #[serde(flatten)]
    pub figures: WalkFigures,
    /// The same with each task's exact counts of the real trace: what no estimate of `B` and
    /// `T` can beat.
    pub error_vs_time_trace: Option<f64>,
    /// The real trace's counts' rank correlation with the times.
    pub spearman_trace_vs_time: Option<f64>,
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

/// The rates the trace walk is measured at: its net overhead is what matters, and above
/// these the sample costs what the trace it saves does.
const TRACE_RATES: [f64; 4] = [0.03125, 0.0625, 0.125, 0.25];

/// The trade's points of `rays` (`kind` rays, the table's `ray_kind`), for tasks of each of the
/// matrix's sizes: `cobalt estimate`'s measurement ([`measure`]) at every rate and at
/// the thesis's rate refined as `cobalt estimate` refines it by default, every walk timed in
/// the same rounds; of its walks, the thesis's reduced traversal at every rate, the trace walk
/// at [`TRACE_RATES`] and refined.
fn points(
    matrix: &SceneMatrix,
    rays: RayBatch,
    kind: RayKind,
    ray_kind: &'static str,
) -> Result<Vec<TradePoint>, BenchError> {
    let rays = Generations::of(rays, kind);
    let refined = (
        SampleRate::THESIS,
        Some(ReducedTraversal::DEFAULT_SAMPLE_ERROR),
    );
    let cost = |e: CostError| BenchError::from(EstimateError::from(e));
    let mut samples = Vec::new();
    for rate in RATES {
        samples.push((SampleRate::new(rate).map_err(|e| cost(e.into()))?, None));
    }
    samples.push(refined);
    let thesis = THESIS.iter().find(|(k, _)| *k == ray_kind).map(|(_, t)| t);
    let mut out = Vec::new();
    for &task_size in matrix.task_sizes {
        let settings = Settings {
            scene: matrix.scene_name,
            task_size,
            sample_run: SampleRun::DEFAULT,
            clock: sched::Clock::Wall,
            repeats: 3,
            budget: Budget::trade(),
            device: Device::Cpu,
            // The trace walk's sample is every report's `sampled_rays`.
            walk: WalkChoice::Fixed(Walk::Trace { any: false }),
        };
        let reports = measure(&settings, (matrix.scene, matrix.bvh), &rays, &samples)?;
        // The bench's walk: the thesis's reduced traversal.
        let bench_walk = Walk::Reduced.for_kind(kind);
        let traced = reports
            .iter()
            .filter(|r| r.sample_error.is_some() || TRACE_RATES.contains(&r.sample_rate));
        let picked = reports[..RATES.len()]
            .iter()
            .map(|r| (r, bench_walk))
            .chain(traced.map(|r| (r, Walk::Trace { any: false })));
        for (r, walk) in picked {
            // Every report has every walk's figures: the trace walk's and the reduced ones.
            let Some(f) = r.walks.iter().find(|f| f.figures.walk == walk.name()) else {
                continue;
            };
            let prediction_error = f.figures.prediction_error.ok_or_else(|| {
                cost(CostError::Degenerate {
                    what: "prediction error",
                    why: "the full costs sum to zero",
                })
            })?;
            // Beside the thesis's figures where it has them (its own walk, at its rates).
            let traced = walk == Walk::Trace { any: false };
            let thesis_at = thesis
                .filter(|_| !traced)
                .and_then(|t| t.iter().find(|x| x.0 == r.sample_rate));
            out.push(TradePoint {
                source: "sampling_trade",
                scene: r.scene.clone(),
                ray_kind,
                task_size: r.task_size,
                rays: r.rays,
                sample_rate: r.sampled_rays as f64 / r.rays.max(1) as f64,
                sample_error: r.sample_error,
                figures: WalkFigures {
                    walk: if r.sample_error.is_some() {
                        "trace-refined"
                    } else {
                        f.figures.walk
                    },
                    ..f.figures.clone()
                },
                error_vs_time_trace: r.error_vs_time_trace,
                spearman_trace_vs_time: r.spearman_trace_vs_time,
                thesis_prediction_error: thesis_at.map(|x| x.1),
                thesis_overhead: thesis_at.map(|x| x.2),
                meets_target: meets_target(ray_kind, prediction_error, f.figures.overhead),
                lpt_balance: f.lpt_balance,
            });
        }
    }
    Ok(out)
}

/// The trade on orbit camera 0 at the matrix's size, for tasks of each of its task sizes, with
/// the thesis's reduced traversal.
pub fn sampling_trade(matrix: &SceneMatrix) -> Result<Vec<TradePoint>, BenchError> {
    let (scene, bvh) = (matrix.scene, matrix.bvh);
    let (width, height, ao_samples) = (matrix.width, matrix.height, matrix.ao_samples);
    let primary = workload::orbit_primary(scene, width, height, 0..1);
    let ao = workload::orbit_ao(scene, bvh, width, height, 0, ao_samples).rays;
    let mut out = points(matrix, primary, RayKind::Primary, "coherent")?;
    if !ao.is_empty() {
        out.extend(points(matrix, ao, RayKind::Ao, "diffuse")?);
    }
    Ok(out)
}
