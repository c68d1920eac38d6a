//! A run: the frames of one view rendered through one [`PathRenderer`], the fastest kept, a
//! frame whose every device failed finished on the host when the caller allows it, and the
//! calibration recalled before the first frame and remembered after the last. `cobalt render`
//! and its `mpirun` form report a run the same way ([`RunReport`]).
//!
//! ## Example
//!
//! ```
//! use raytrace::devices::parse_devices;
//! use raytrace::run::Run;
//! use raytrace::shade::{RenderOptions, Shader};
//! use raytrace::{BuildPreset, Bvh, Camera, SceneSource};
//!
//! let shader = Shader::Ao(Default::default());
//! let scene = SceneSource::parse("builtin:cornell:0.2")?.load(shader.needs())?;
//! let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
//! let options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 0), shader);
//! let specs = parse_devices("cpu:2")?;
//! let run = Run { frames: 2, ..Run::new(&specs) };
//! let (film, report) = run.render(&scene, &bvh, &options, None)?;
//! assert_eq!((film.width(), report.frames, report.paths), (32, 2, 32 * 32));
//! assert!(report.task_size * report.tasks >= report.paths);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod report;
mod store;

pub use report::RunReport;
pub use store::{CalibrationReport, Store, workload};

use sched::{DeviceFailure, SchedError};

use crate::devices::DeviceSpec;
use crate::paths::{FailAfter, FrameRendering, PathRenderer, Settings, SlowBy, build_path_devices};
use crate::shade::RenderOptions;
use crate::{Bvh, Film, Scene};

/// Why a run gave no image.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Every device failed and the host was not allowed to finish the frame; each failure,
    /// in order (none when every device had failed on earlier frames).
    #[error("every device failed")]
    DevicesFailed(Vec<DeviceFailure>),
    /// The scheduler refused the plan.
    #[error(transparent)]
    Sched(#[from] SchedError),
    /// The devices could not be made.
    #[error(transparent)]
    Devices(#[from] crate::Error),
}

/// What a run is asked: the devices with their faults, the settings, how many frames, and
/// whether the host may finish a frame whose every device failed.
#[derive(Clone, Copy, Debug)]
pub struct Run<'a> {
    /// The devices (a parsed `--devices`).
    pub specs: &'a [DeviceSpec],
    /// Injected faults (`--fail`).
    pub faults: &'a [FailAfter],
    /// Devices made slower on purpose (`--slow`).
    pub slow: &'a [SlowBy],
    /// How every frame is cut, costed and planned.
    pub settings: Settings,
    /// Frames rendered through one renderer (each plans with the speeds measured on the ones
    /// before); the fastest is reported.
    pub frames: u32,
    /// When every device fails, the host's threads finish the frames instead of the run
    /// failing.
    pub host_fallback: bool,
}

impl<'a> Run<'a> {
    /// One frame on `specs` with the default settings, no faults and no fallback.
    pub fn new(specs: &'a [DeviceSpec]) -> Self {
        Self {
            specs,
            faults: &[],
            slow: &[],
            settings: Settings::default(),
            frames: 1,
            host_fallback: false,
        }
    }

    /// Renders [`Run::frames`] frames of `options`, keeping the fastest. With a
    /// `calibration` (and the workload's name, see [`workload`]), the first frame plans with
    /// what it holds and what the frames taught is kept in it.
    ///
    /// # Errors
    /// [`RunError::DevicesFailed`] when every device failed and the host may not take over;
    /// [`RunError::Devices`] when a device cannot be made; [`RunError::Sched`] for a plan the
    /// scheduler refuses.
    pub fn render(
        &self,
        scene: &Scene,
        bvh: &Bvh,
        options: &RenderOptions,
        calibration: Option<(&mut Store, &str)>,
    ) -> Result<(Film, RunReport), RunError> {
        let devices = build_path_devices(scene, bvh, self.specs, self.faults, self.slow)?;
        let renderer = PathRenderer::new(devices, self.settings)?;
        self.render_on(renderer, scene, bvh, options, calibration)
    }

    /// [`Run::render`] on `renderer`, made of the devices the caller chose (the ranks of an MPI
    /// job among them: `distributed::render_over_ranks`).
    ///
    /// # Errors
    /// As [`Run::render`].
    pub fn render_on(
        &self,
        mut renderer: PathRenderer<'_>,
        scene: &Scene,
        bvh: &Bvh,
        options: &RenderOptions,
        mut calibration: Option<(&mut Store, &str)>,
    ) -> Result<(Film, RunReport), RunError> {
        if let Some((store, workload)) = calibration.as_mut() {
            store.recall(&mut renderer, workload);
        }
        let mut host: Option<PathRenderer> = None;
        let mut lost: Vec<DeviceFailure> = Vec::new();
        let mut best: Option<FrameRendering> = None;
        let mut first_render_seconds = 0.0;
        for k in 0..self.frames.max(1) {
            let frame = match host.as_mut() {
                Some(host) => host.render(scene, bvh, options)?,
                None => match renderer.render(scene, bvh, options) {
                    Ok(frame) => frame,
                    Err(e @ (SchedError::AllDevicesFailed { .. } | SchedError::NoDevices)) => {
                        if let SchedError::AllDevicesFailed { failures, .. } = e {
                            lost.extend(failures);
                        }
                        let fallback = self.host_renderer(&lost, scene, bvh)?;
                        host.insert(fallback).render(scene, bvh, options)?
                    }
                    Err(e) => return Err(e.into()),
                },
            };
            if k == 0 {
                first_render_seconds = frame.stats.seconds;
            }
            if best
                .as_ref()
                .is_none_or(|b| frame.stats.seconds < b.stats.seconds)
            {
                best = Some(frame);
            }
        }
        // The host fallback's frames measured the host, not the devices asked for.
        if let Some((store, workload)) = calibration {
            store.remember(&renderer, workload);
        }
        let best = best.ok_or(RunError::Sched(SchedError::NoDevices))?;
        let mut report = RunReport::new(self.frames.max(1), first_render_seconds, &best.stats);
        report.host_fallback = host.is_some();
        report.failures.extend(lost.iter().map(ToString::to_string));
        Ok((best.film, report))
    }

    /// A renderer on every thread of the host, for the frames whose every device failed
    /// (`lost`, in order); [`RunError::DevicesFailed`] unless [`Run::host_fallback`] allows it.
    ///
    /// # Errors
    /// As said, and [`RunError::Devices`] when the host's threads cannot be started.
    pub fn host_renderer<'s>(
        &self,
        lost: &[DeviceFailure],
        scene: &'s Scene,
        bvh: &'s Bvh,
    ) -> Result<PathRenderer<'s>, RunError> {
        if !self.host_fallback {
            return Err(RunError::DevicesFailed(lost.to_vec()));
        }
        let threads = std::thread::available_parallelism().map_or(1, usize::from);
        let spec = [DeviceSpec::Cpu { count: 1, threads }];
        let devices = build_path_devices(scene, bvh, &spec, &[], &[])?;
        Ok(PathRenderer::new(devices, self.settings)?)
    }
}
