//! `cobalt render --pipeline paths` (and `gpu`): every frame through one path renderer
//! ([`crate::path_run`]), its report and its summary.

use raytrace::cost_image::{cost_image, primary_counts};
use raytrace::film::ToneMap;
use raytrace::scheduled::{FailAfter, Settings};
use raytrace::shade::RenderOptions;
use raytrace::{Bvh, Scene};
use sched::Policy;
use serde::Serialize;

use super::header::Header;
use super::rendered::Rendered;
use crate::calibration::{CalibrationReport, Store};
use crate::error::CliError;
use crate::path_run::{Fallback, PathRun};

/// The report of `--pipeline paths` (and `gpu`).
#[derive(Debug, Serialize)]
pub struct PathsReport {
    #[serde(flatten)]
    header: Header,
    pipeline: &'static str,
    devices: String,
    policy: Policy,
    mode: &'static str,
    task_size: usize,
    sample_rate: f64,
    #[serde(flatten)]
    run: PathRun,
    /// The calibration file read before the first frame and written after the run.
    calibration: CalibrationReport,
}

impl PathsReport {
    /// The summary printed without `--json`.
    pub fn summary(&self) -> String {
        let r = &self.run;
        format!(
            "{} on {} by paths, {} {}, tasks of {}: {}; fastest of {} frame(s)\n{}",
            self.header.what(),
            self.devices,
            self.policy.name(),
            self.mode,
            self.task_size,
            r.figures(),
            r.frames,
            r.notes(),
        )
    }
}

/// What a path render is asked: the pipeline's name, the devices (as typed, and parsed) with
/// their faults, the settings, the frames to render and the fallback.
pub struct PathJob<'a> {
    pub pipeline: &'static str,
    pub devices: &'a str,
    pub specs: &'a [raytrace::devices::DeviceSpec],
    pub faults: &'a [FailAfter],
    pub settings: Settings,
    pub frames: u32,
    pub host_fallback: bool,
    pub cost_image: bool,
}

/// Renders `options` as `job` says; with a calibration `store`, the first frame plans with
/// what it holds for `workload`, and what the frames taught is written back.
pub fn render_paths(
    scene: &Scene,
    bvh: &Bvh,
    options: &RenderOptions,
    job: &PathJob<'_>,
    (mut store, workload): (Option<Store>, &str),
    header: Header,
) -> Result<Rendered<PathsReport>, CliError> {
    let fallback = Fallback {
        devices: job.devices,
        host_fallback: job.host_fallback,
    };
    let (film, run) = crate::path_run::render(
        scene,
        bvh,
        options,
        job.specs,
        job.faults,
        job.settings,
        job.frames,
        &fallback,
        store.as_mut().map(|s| (s, workload)),
    )?;
    let calibration = store.as_ref().map(Store::save).unwrap_or_default();
    let image = film.png(ToneMap::Srgb)?;
    // The path devices count nothing per pixel: the cost image's counts are traced apart.
    let cost_image = if job.cost_image {
        let (w, h) = (options.width, options.height);
        let counts = primary_counts(bvh, &options.camera, w, h);
        Some(cost_image(&counts, w, h).png(ToneMap::Display)?)
    } else {
        None
    };
    let report = PathsReport {
        header,
        pipeline: job.pipeline,
        devices: job.devices.to_string(),
        policy: job.settings.policy,
        mode: job.settings.mode.name(),
        task_size: job.settings.task_size.get(),
        sample_rate: job.settings.sample_rate.get(),
        run,
        calibration,
    };
    Ok(Rendered {
        image,
        cost_image,
        report,
    })
}
