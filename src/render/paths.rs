//! `cobalt render`'s run ([`raytrace::run::Run`]), its report (opening with the scene, the
//! image, the camera and the shader) and its summary, and the encoded outputs.

use raytrace::cost_image::primary_cost_image;
use raytrace::film::ToneMap;
use raytrace::run::{CalibrationReport, Run, RunReport, Store};
use raytrace::shade::{RenderOptions, Shader};
use raytrace::{Bvh, Scene};
use sched::Policy;
use serde::Serialize;

use crate::error::CliError;
use crate::output::Outputs;

/// The opening fields of a render report.
#[derive(Debug, Serialize)]
pub struct Header {
    pub scene: String,
    pub triangles: usize,
    pub shader: &'static str,
    pub size: String,
    pub width: u32,
    pub height: u32,
    /// The orbit camera's index; null for `--eye`/`--at`.
    pub camera: Option<usize>,
    pub eye: [f32; 3],
    pub at: [f32; 3],
    pub preset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_distance: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    pub load_seconds: f64,
    pub build_seconds: f64,
}

impl Header {
    /// The summary's opening words: shader, size, scene and its triangles.
    pub fn what(&self) -> String {
        format!(
            "{} {} of {} ({} triangles)",
            self.shader, self.size, self.scene, self.triangles
        )
    }
}

/// The image, the cost image if asked for, and the pipeline's report.
pub struct Rendered {
    pub image: Vec<u8>,
    pub cost_image: Option<Vec<u8>>,
    pub report: RenderReport,
}

impl Rendered {
    /// Writes every output at once (nothing is written until every output is encoded, so a
    /// failure leaves no partial set of files), then prints the report as JSON or its summary.
    pub fn write(self, outputs: &Outputs, json: bool) -> Result<(), CliError> {
        let text = serde_json::to_string_pretty(&self.report)
            .map_err(|e| CliError::Write(e.to_string()))?;
        let text = format!("{text}\n");
        outputs.commit(&[
            ("out", &self.image),
            ("cost-image", self.cost_image.as_deref().unwrap_or_default()),
            ("report", text.as_bytes()),
        ])?;
        if json {
            outputs.print_json(&self.report)
        } else {
            outputs.print(&self.report.summary())
        }
    }
}

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
    /// The report of `run` of `shader` on `devices` (the `--devices` text): its header,
    /// settings and figures, and the calibration it read and wrote.
    pub fn new(
        header: Header,
        (run, devices, shader): (&Run<'_>, &str, &Shader),
        report: RunReport,
        calibration: CalibrationReport,
    ) -> Self {
        Self {
            header,
            device_list: devices.to_string(),
            policy: run.settings.policy,
            mode: run.settings.mode.name(),
            requested_task_size: run.settings.task_size.get(),
            sample_rate: run.settings.rate_for(shader).get(),
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
) -> Result<Rendered, CliError> {
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
    let report = RenderReport::new(header, (run, devices, &options.shader), report, calibration);
    Ok(Rendered {
        image,
        cost_image,
        report,
    })
}
