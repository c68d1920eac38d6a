//! `cobalt render`'s run ([`raytrace::run::Run`]), its report and its summary.

use raytrace::cost_image::primary_cost_image;
use raytrace::film::ToneMap;
use raytrace::run::{CalibrationReport, Run, RunReport, Store};
use raytrace::shade::RenderOptions;
use raytrace::{Bvh, Scene};
use sched::Policy;
use serde::Serialize;

use super::header::Header;
use super::rendered::Rendered;
use crate::error::CliError;

/// The report of `cobalt render`.
#[derive(Debug, Serialize)]
pub struct RenderReport {
    #[serde(flatten)]
    header: Header,
    /// `--devices`, as given.
    device_list: String,
    policy: Policy,
    mode: &'static str,
    /// `--task-size`: the frame's tasks are cut to it, or finer (the run's `task_size`).
    requested_task_size: usize,
    sample_rate: f64,
    /// `--walk`: how the estimate counted a sampled path.
    walk: &'static str,
    #[serde(flatten)]
    run: RunReport,
    /// The calibration file read before the first frame and written after the run.
    calibration: CalibrationReport,
    /// Under `mpirun`: the ranks of the job, each with the devices of `device_list`.
    #[serde(skip_serializing_if = "Option::is_none")]
    ranks: Option<usize>,
}

impl RenderReport {
    /// The report of `run` on `devices` (the `--devices` text): its header, settings and
    /// figures, and the calibration it read and wrote.
    pub fn new(
        header: Header,
        (run, devices): (&Run<'_>, &str),
        report: RunReport,
        calibration: CalibrationReport,
    ) -> Self {
        Self {
            header,
            device_list: devices.to_string(),
            policy: run.settings.policy,
            mode: run.settings.mode.name(),
            requested_task_size: run.settings.task_size.get(),
            sample_rate: run.settings.sample_rate.get(),
            walk: run.settings.walk.name(),
            run: report,
            calibration,
            ranks: None,
        }
    }

    /// The same report, of a render over `ranks` ranks of an MPI job.
    #[cfg(feature = "mpi")]
    pub fn over_ranks(self, ranks: usize) -> Self {
        Self {
            ranks: Some(ranks),
            ..self
        }
    }

    /// The summary printed without `--json`.
    pub fn summary(&self) -> String {
        let r = &self.run;
        let devices = match self.ranks {
            Some(ranks) => format!("{ranks} rank(s) × {}", self.device_list),
            None => self.device_list.clone(),
        };
        format!(
            "{} on {}, {} {}, {} tasks of {} paths: {}; fastest of {} frame(s)\n{}",
            self.header.what(),
            devices,
            self.policy.name(),
            self.mode,
            r.tasks,
            r.task_size,
            r.figures(),
            r.frames,
            r.notes(),
        )
    }
}

/// Renders `options` as `run` says on `devices` (the `--devices` text); with a calibration
/// `store`, the first frame plans with what it holds for `workload`, and what the frames
/// taught is written back. With `cost_image`, the primary rays' counts are drawn too.
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    options: &RenderOptions,
    (run, devices): (&Run<'_>, &str),
    (mut store, workload): (Option<Store>, &str),
    (header, cost_image_wanted): (Header, bool),
) -> Result<Rendered<RenderReport>, CliError> {
    let calibration = store.as_mut().map(|s| (s, workload));
    let (film, report) = run
        .render(scene, bvh, options, calibration)
        .map_err(|e| CliError::run(devices, e))?;
    let calibration = store.as_ref().map(Store::save).unwrap_or_default();
    let image = film.png(ToneMap::Srgb)?;
    // The devices count nothing per pixel: the cost image's counts are traced apart.
    let cost_image = if cost_image_wanted {
        let (w, h) = (options.width, options.height);
        Some(primary_cost_image(bvh, &options.camera, w, h).png(ToneMap::Display)?)
    } else {
        None
    };
    let report = RenderReport::new(header, (run, devices), report, calibration);
    Ok(Rendered {
        image,
        cost_image,
        report,
    })
}
