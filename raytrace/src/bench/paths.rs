//! One cell of the matrix on path-resident devices ([`raytrace::paths`]): every camera is a
//! frame of whole paths, each task's paths made, traced and shaded on the device that runs
//! it. A record covers every ray of the frames (an AO record's primary rays included), and
//! the simulator replays each frame's tasks.

use super::error::BenchError;
use super::matrix::{CellRun, SceneMatrix};
use super::record::Record;
use super::replay::{Replayed, replay};
use crate::camera::Camera;
use crate::cost::SampleRate;
use crate::paths::Settings;
use crate::paths::{Frame, FrameStats, PathRenderer, build_path_devices, walk_paths};
use crate::run::workload;
use crate::shade::{RenderOptions, Shader};
use crate::traverse::walk::Walk;

impl SceneMatrix<'_> {
    /// Renders every camera once with `settings` through one path renderer (each frame plans
    /// with the device speeds measured on the frames before it); when `measure_error`, also the
    /// prediction error of each frame's estimate against every path counted.
    pub(super) fn run_paths(
        &self,
        w: Shader,
        settings: Settings,
        measure_error: bool,
    ) -> Result<CellRun, BenchError> {
        #[cfg(feature = "mpi")]
        if let Some(cluster) = self.cluster {
            return self.run_over_ranks(cluster, w, settings);
        }
        let kept = self.path_devices.borrow_mut().take();
        let mut renderer = match kept {
            Some(kept) => PathRenderer::from_kept(kept, settings)?,
            None => {
                let devices =
                    build_path_devices(self.scene, self.bvh, self.devices, &[], self.slow)?;
                PathRenderer::new(devices, settings)?
            }
        };
        let workload = workload(self.scene_name, &w);
        let recalled =
            (self.calibration).map(|store| store.borrow_mut().recall(&mut renderer, &workload));
        let mut frames = Vec::with_capacity(self.cameras);
        let (mut estimated, mut full) = (Vec::new(), Vec::new());
        for cam in 0..self.cameras {
            let options = self.options(w, cam);
            let frame = renderer
                .render(self.scene, self.bvh, &options)
                .map_err(|e| self.failed(e))?;
            for f in &frame.stats.failures {
                eprintln!(
                    "cobalt bench: {} {} {} {}, camera {cam}: {f}",
                    self.scene_name,
                    w.name(),
                    settings.policy.name(),
                    settings.mode.name(),
                );
            }
            // A frame on one device is not estimated: there is no estimate to judge.
            if measure_error && frame.stats.estimated {
                let frame_of = Frame {
                    scene: self.scene,
                    bvh: self.bvh,
                    options: &options,
                };
                let (e, f) = frame_error(&frame_of, &frame.stats, settings.walk);
                estimated.extend(e);
                full.extend(f);
            }
            frames.push(frame.stats);
        }
        if let Some(store) = self.calibration {
            store.borrow_mut().remember(&renderer, &workload);
        }
        // A device that failed is built anew for the next cell.
        *self.path_devices.borrow_mut() = renderer.into_kept();
        // Σ|estimated − full| / Σ full over the frames (0 for no work).
        let error =
            measure_error.then(|| sched::prediction_error(&estimated, &full).unwrap_or(0.0));
        let mut record = self.frames_record(w, settings, &frames);
        record.calibration = recalled;
        Ok(CellRun {
            record,
            frames,
            error,
        })
    }

    /// The bench's error for a frame that could not be rendered: every device failing names
    /// the devices.
    pub(super) fn failed(&self, e: sched::SchedError) -> BenchError {
        match e {
            sched::SchedError::AllDevicesFailed { failures, .. } => BenchError::DevicesFailed {
                devices: self.device_list.to_string(),
                failures,
            },
            e => e.into(),
        }
    }

    /// The record of one run of the cell (`w`, `settings`) from its frames: their sums, and
    /// their replays where every frame could be replayed.
    pub(super) fn frames_record(
        &self,
        w: Shader,
        settings: Settings,
        frames: &[FrameStats],
    ) -> Record {
        let devices = frames.first().map_or(0, |f| f.devices.len());
        let mut r = Record::new(self, w, settings, devices);
        let sum = |f: &dyn Fn(&FrameStats) -> f64| frames.iter().map(f).sum::<f64>();
        r.rays = frames.iter().map(|f| f.rays).sum();
        r.seconds = sum(&|f| f.seconds);
        r.mrays_per_s = r.rays as f64 / r.seconds.max(1e-12) / 1e6;
        let capacity = sum(&|f| f.makespan * f.devices.len() as f64);
        if capacity > 0.0 {
            r.balance_efficiency = sum(&|f| f.devices.iter().map(|d| d.busy).sum()) / capacity;
        }
        r.estimate_seconds = sum(&|f| f.estimate_seconds);
        r.estimates_reused = frames.iter().filter(|f| f.estimate_reused).count();
        r.plan_seconds = sum(&|f| f.plan_seconds);
        r.launches = frames.iter().map(FrameStats::launches).sum();
        r.reruns = frames.iter().map(|f| f.reruns).sum();
        r.run_mrays_per_s = vec![r.mrays_per_s];
        r.run_balance_efficiency = vec![r.balance_efficiency];
        let replayed: Option<Vec<Replayed>> = frames.iter().map(replay).collect();
        if let Some(p) = replayed.map(|all| all.into_iter().fold(Replayed::default(), |a, b| a + b))
        {
            r.makespan_seconds = p.makespan;
            r.simulated_makespan_seconds = Some(p.simulated_makespan);
            // Only the makespan is simulated: estimating, planning, starting the devices'
            // threads and writing the film are taken as measured.
            let simulated = r.seconds - p.makespan + p.simulated_makespan;
            r.simulated_seconds = Some(simulated);
            r.run_simulated_over_measured = vec![simulated / r.seconds.max(1e-12)];
            r.lower_bound_seconds = Some(p.lower_bound);
            r.fractional_bound_seconds = Some(p.fractional_bound);
            r.makespan_over_bound = Some(p.makespan / p.lower_bound.max(1e-300));
        }
        // Only the makespan is predicted; the rest of each frame is taken as measured.
        let predicted: Option<f64> = frames
            .iter()
            .map(|f| f.predicted_makespan.map(|p| f.seconds - f.makespan + p))
            .sum();
        r.predicted_seconds = predicted;
        r.run_predicted_over_measured = predicted
            .map(|p| vec![p / r.seconds.max(1e-12)])
            .unwrap_or_default();
        if let Some(f) = frames.first() {
            (r.tasks, r.cut_task_size) = (f.tasks, f.task_size);
        }
        for f in frames {
            r.traffic += f.traffic();
        }
        r.film_bytes = frames.iter().map(FrameStats::film_bytes).sum();
        r.left_idle = frames.iter().flat_map(|f| f.left_idle.clone()).collect();
        r.left_idle.sort();
        r.left_idle.dedup();
        r
    }

    /// The image, camera and shader of camera `cam` for workload `w`.
    pub(super) fn options(&self, w: Shader, cam: usize) -> RenderOptions {
        RenderOptions::new(
            self.width,
            self.height,
            Camera::orbit(&self.scene.bounds(), cam),
            w,
        )
    }
}

/// The frame's estimates, and every path of each task counted by the same `walk` (the
/// estimate at full sampling, as the thesis judges a walk by its own full count), in the
/// renderer's cost units; outside every clock of the frame.
fn frame_error(frame: &Frame<'_>, stats: &FrameStats, walk: Walk) -> (Vec<f64>, Vec<f64>) {
    let tasks = sched::split_ranges(stats.paths, stats.task_size.max(1));
    let full = stats
        .cost_model
        .costs(&walk_paths(frame, &tasks, SampleRate::FULL, walk));
    (stats.task_stats.iter().map(|t| t.cost).collect(), full)
}
