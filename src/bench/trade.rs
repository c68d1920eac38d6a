//! The sampling-rate trade of thesis Table 4.1: prediction error against estimation overhead
//! at 12.5, 25, 50 and 100 % of each task's rays, for coherent (primary) and diffuse (AO) rays.

use std::time::Instant;

use raytrace::cost::{CostModel, ReducedTraversal, SampleRate, full_work, prediction_error};
use raytrace::{Bvh, RayBatch, Scene, traverse, workload};
use serde::Serialize;

use crate::error::CliError;

/// The thesis's sampling rates.
pub const RATES: [f64; 4] = [0.125, 0.25, 0.5, 1.0];

/// One point of the trade.
#[derive(Clone, Debug, Serialize)]
pub struct TradePoint {
    pub scene: String,
    pub ray_kind: &'static str,
    pub task_size: usize,
    pub rays: usize,
    pub sample_rate: f64,
    pub prediction_error: f64,
    /// Estimation time over the full trace's time, both on all cores, best of three.
    pub overhead: f64,
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
    task_size: usize,
) -> Result<Vec<TradePoint>, CliError> {
    let tasks = sched::split_ranges(rays.len(), task_size);
    let cost_err = |e: raytrace::cost::CostError| CliError::Write(format!("estimate: {e}"));
    let model = CostModel::default();
    let full = model.costs(&full_work(bvh, rays, &tasks).map_err(cost_err)?);
    let trace = best_of_3(|| {
        let hits = if occlusion {
            traverse::any_hits(bvh, rays)
        } else {
            traverse::closest_hits(bvh, rays)
        };
        std::hint::black_box(hits);
    });
    let mut out = Vec::new();
    for rate in RATES {
        let rate = SampleRate::new(rate).map_err(|e| cost_err(e.into()))?;
        let estimator = ReducedTraversal::new(bvh, rays, rate);
        let mut est = Vec::new();
        let seconds = best_of_3(|| est = estimator.try_estimate(&tasks).unwrap_or_default());
        out.push(TradePoint {
            scene: scene.to_string(),
            ray_kind: kind,
            task_size,
            rays: rays.len(),
            sample_rate: rate.get(),
            prediction_error: prediction_error(&est, &full).map_err(cost_err)?,
            overhead: seconds / trace.max(1e-12),
        });
    }
    Ok(out)
}

/// The trade on thesis camera 0 at `width x height`, tasks of `task_size` rays.
pub fn sampling_trade(
    name: &str,
    scene: &Scene,
    bvh: &Bvh,
    width: u32,
    height: u32,
    ao_samples: u32,
    task_size: usize,
) -> Result<Vec<TradePoint>, CliError> {
    let primary = workload::thesis_primary(scene, width, height, 0..1);
    let ao = workload::thesis_ao(scene, bvh, width, height, 0, ao_samples).rays;
    let mut out = points(name, bvh, &primary, "coherent", false, task_size)?;
    if !ao.is_empty() {
        out.extend(points(name, bvh, &ao, "diffuse", true, task_size)?);
    }
    Ok(out)
}
