//! One cell of the matrix on path-resident devices ([`raytrace::paths`]): every camera is a
//! frame of whole paths, each task's paths made, traced and shaded on the device that runs
//! it. A record covers every ray of the frames (an AO record's primary rays included), and
//! the simulator replays each frame's tasks.

use super::error::BenchError;
use super::matrix::{CellRun, Replay, SceneMatrix, Totals, Workload};
use super::prediction::ErrorSums;
use super::record::Record;
use super::replay::{Replayed, RunDevice};
use crate::bvh::Bvh;
use crate::camera::Camera;
use crate::cost::SampleRate;
use crate::paths::Settings;
use crate::paths::{Frame, FrameStats, PathRenderer, build_path_devices, walk_paths};
use crate::run::{CalibrationReport, workload};
use crate::scene::Scene;
use crate::shade::RenderOptions;
use crate::traffic::Traffic;
use crate::traverse::walk::Walk;

impl SceneMatrix<'_> {
    /// Renders every camera once with `settings` through one path renderer (each frame plans
    /// with the device speeds measured on the frames before it); when `measure_error`, also the
    /// prediction error of each frame's estimate against every path counted.
    pub(super) fn run_paths(
        &self,
        w: Workload,
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
                let devices = build_path_devices(self.scene, self.bvh, self.devices, &[])?;
                PathRenderer::new(devices, settings)?
            }
        };
        let workload = workload(self.scene_name, &w.shader(self.ao_samples));
        let recalled = self.calibration.map(|store| {
            let mut store = store.borrow_mut();
            let used = store.recall(&mut renderer, &workload);
            CalibrationReport {
                file: Some(store.file()),
                loaded_entries: used,
                written_entries: 0,
            }
        });
        let mut frames = Vec::with_capacity(self.cameras);
        let mut sums = ErrorSums::default();
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
                sums += frame_error(self.scene, self.bvh, &options, &frame.stats, settings.walk)?;
            }
            frames.push(frame.stats);
        }
        if let Some(store) = self.calibration {
            store.borrow_mut().remember(&renderer, &workload);
        }
        // A device that failed is built anew for the next cell.
        *self.path_devices.borrow_mut() = renderer.into_kept();
        let error = measure_error.then(|| sums.ratio());
        let mut record = self.frames_record(w, settings, &frames);
        record.calibration = recalled;
        Ok(CellRun {
            record,
            replay: frames.iter().map(replay_frame).collect(),
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

    pub(super) fn frames_record(
        &self,
        w: Workload,
        settings: Settings,
        frames: &[FrameStats],
    ) -> Record {
        let mut t = Totals::default();
        let mut traffic = Traffic::default();
        let mut film_bytes = 0;
        for f in frames {
            t.add(Totals {
                rays: f.rays,
                seconds: f.seconds,
                estimate: f.estimate_seconds,
                plan: f.plan_seconds,
                busy: f.devices.iter().map(|d| d.busy).sum(),
                capacity: f.makespan * f.devices.len() as f64,
                launches: f.launches(),
                reruns: f.reruns,
                replayed: replayed_frame(f),
            });
            traffic += f.traffic();
            film_bytes += f.film_bytes();
        }
        let devices = frames.first().map_or(0, |f| f.devices.len());
        let mut r = t.record(Record::new(self, w, settings, devices));
        if let Some(f) = frames.first() {
            (r.tasks, r.cut_task_size) = (f.tasks, f.task_size);
        }
        r.host_to_device_bytes = Some(traffic.host_to_device_bytes);
        r.device_to_host_bytes = Some(traffic.device_to_host_bytes);
        r.host_waits = Some(traffic.host_waits);
        r.film_bytes = Some(film_bytes);
        r.left_idle = frames.iter().flat_map(|f| f.left_idle.clone()).collect();
        r.left_idle.sort();
        r.left_idle.dedup();
        r
    }

    /// The image, camera and shader of camera `cam` for workload `w`.
    pub(super) fn options(&self, w: Workload, cam: usize) -> RenderOptions {
        RenderOptions::new(
            self.width,
            self.height,
            Camera::orbit(&self.scene.bounds(), cam),
            w.shader(self.ao_samples),
        )
    }
}

/// The frame's estimate judged against every path of each task counted by the same `walk`
/// (the estimate at full sampling, as the thesis judges a walk by its own full count), in the
/// renderer's cost units; outside every clock of the frame.
fn frame_error(
    scene: &Scene,
    bvh: &Bvh,
    options: &RenderOptions,
    stats: &FrameStats,
    walk: Walk,
) -> Result<ErrorSums, BenchError> {
    let frame = Frame {
        scene,
        bvh,
        options,
    };
    let tasks = sched::split_ranges(stats.paths, stats.task_size.max(1));
    let full = stats
        .cost_model
        .costs(&walk_paths(&frame, &tasks, SampleRate::FULL, walk));
    let estimated = stats.task_stats.iter().map(|t| t.cost);
    Ok(ErrorSums {
        diff: estimated.zip(&full).map(|(e, f)| (e - f).abs()).sum(),
        full: full.iter().sum(),
    })
}

/// A frame's replay in the simulator and its bounds.
fn replayed_frame(f: &FrameStats) -> Option<Replayed> {
    let devices: Vec<RunDevice> = f
        .devices
        .iter()
        .map(|d| RunDevice {
            index: d.index,
            speed: d.speed,
            launch_overhead: d.launch_overhead,
        })
        .collect();
    super::replay::replay(f.policy, f.makespan, &f.task_stats, &devices)
}

/// A frame's tasks for the simulator: each one's planned cost and measured time.
pub(super) fn replay_frame(f: &FrameStats) -> Replay {
    Replay {
        rays: f.rays,
        estimate_seconds: f.estimate_seconds,
        estimated: f.task_stats.iter().map(|t| t.cost).collect(),
        seconds: f.task_stats.iter().map(|t| t.seconds).collect(),
    }
}
