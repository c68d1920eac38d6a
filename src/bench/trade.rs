//! The sampling-rate trade of thesis Table 4.1: prediction error against estimation overhead
//! at 12.5, 25, 50 and 100 % of each task's rays, for coherent (primary) and diffuse (AO) rays,
//! and below the thesis's rates (3.125 and 6.25 %), where on a CPU the overhead first meets
//! the 4 %: here the reduced traversal of every ray costs 21–26 % (coherent) and
//! 59–63 % (diffuse) of the trace (forest, Conference), where the thesis's GPU paid 43 %
//! (see `raytrace/src/packet.rs`).

use std::time::Instant;

use raytrace::cost::{CostModel, ReducedTraversal, SampleRate, full_work, prediction_error};
use raytrace::{Bvh, Probe, RayBatch, RayKind, traverse, workload};
use serde::Serialize;

use super::matrix::Plan;
use crate::error::CliError;

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
    pub scene: String,
    pub ray_kind: &'static str,
    pub task_size: usize,
    pub rays: usize,
    pub sample_rate: f64,
    /// The reduced traversal traced: `thesis` or `first-leaf`.
    pub probe: &'static str,
    pub prediction_error: f64,
    /// Estimation time over the full trace's time, both on all cores, best of three.
    pub overhead: f64,
    /// The thesis's error and overhead at this rate and ray kind, where Table 4.1 has them.
    pub thesis_prediction_error: Option<f64>,
    pub thesis_overhead: Option<f64>,
    /// The target met: error ≤ 2 % coherent / 3 % diffuse, overhead ≤ 4 %.
    pub meets_target: bool,
}

fn best_of_3(mut f: impl FnMut()) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::MAX, f64::min)
}

fn points(
    scene: &str,
    bvh: &Bvh,
    rays: &RayBatch,
    kind: &'static str,
    occlusion: bool,
    probe: Probe,
    task_sizes: &[usize],
) -> Result<Vec<TradePoint>, CliError> {
    let cost_err = |e: raytrace::cost::CostError| CliError::Write(format!("estimate: {e}"));
    let model = CostModel::default();
    let trace = best_of_3(|| {
        let hits = if occlusion {
            traverse::any_hits(bvh, rays)
        } else {
            traverse::closest_hits(bvh, rays)
        };
        std::hint::black_box(hits);
    });
    let thesis = THESIS.iter().find(|(k, _)| *k == kind).map(|(_, t)| t);
    let mut out = Vec::new();
    for &task_size in task_sizes {
        let tasks = sched::split_ranges(rays.len(), task_size);
        let full = model.costs(&full_work(bvh, rays, &tasks, probe).map_err(cost_err)?);
        for rate in RATES {
            let rate = SampleRate::new(rate).map_err(|e| cost_err(e.into()))?;
            let estimator = ReducedTraversal::new(bvh, rays, rate).with_probe(probe);
            let mut est = Vec::new();
            let seconds = best_of_3(|| est = estimator.try_estimate(&tasks).unwrap_or_default());
            let prediction_error = prediction_error(&est, &full).map_err(cost_err)?;
            let overhead = seconds / trace.max(1e-12);
            let thesis_at = thesis.and_then(|t| t.iter().find(|p| p.rate == rate.get()));
            out.push(TradePoint {
                source: "sampling_trade",
                scene: scene.to_string(),
                ray_kind: kind,
                task_size,
                rays: rays.len(),
                sample_rate: rate.get(),
                probe: probe.name(),
                prediction_error,
                overhead,
                thesis_prediction_error: thesis_at.map(|p| p.error),
                thesis_overhead: thesis_at.map(|p| p.overhead),
                meets_target: meets_target(kind, prediction_error, overhead),
            });
        }
    }
    Ok(out)
}

/// The trade on thesis camera 0 at the plan's size, for tasks of each of its task sizes, with its
/// probe for the coherent rays.
pub fn sampling_trade(plan: &Plan) -> Result<Vec<TradePoint>, CliError> {
    let (name, scene, bvh) = (plan.scene_name, plan.scene, plan.bvh);
    let (width, height, ao_samples) = (plan.width, plan.height, plan.ao_samples);
    let (task_sizes, probe) = (plan.task_sizes, plan.probe);
    let primary = workload::thesis_primary(scene, width, height, 0..1);
    let ao = workload::thesis_ao(scene, bvh, width, height, 0, ao_samples).rays;
    let coherent = probe.for_kind(RayKind::Primary);
    let mut out = points(name, bvh, &primary, "coherent", false, coherent, task_sizes)?;
    if !ao.is_empty() {
        let diffuse = probe.for_kind(RayKind::Ao);
        out.extend(points(
            name, bvh, &ao, "diffuse", true, diffuse, task_sizes,
        )?);
    }
    Ok(out)
}
