//! `mpirun -np N cobalt render …`: every rank renders the same image together
//! ([`raytrace::distributed`]); rank 0 writes the PNG, the report and the summary.
//!
//! Every fallible step before the render (loading the scene, building the BVH, opening this
//! node's devices) ends with an agreement between all ranks, so a failure on any rank ends
//! every rank with an error naming the ranks at fault, never a hang.

use std::path::Path;

use raytrace::devices::DeviceSpec;
use raytrace::distributed::render_over_ranks;
use raytrace::film::ToneMap;
use raytrace::paths::build_path_devices;
use raytrace::run::{Run, RunReport};
use raytrace::shade::{RenderOptions, Shader};
use raytrace::{BuildPreset, Bvh, SceneSource};
use sched::mpi::Cluster;
use serde::Serialize;

use crate::args::CameraChoice;
use crate::error::CliError;
use crate::output::Outputs;

/// A checked `cobalt render` command line, as every rank parsed it.
pub(crate) struct Job<'a> {
    pub scene: &'a str,
    pub shader: Shader,
    pub width: u32,
    pub height: u32,
    pub camera: CameraChoice,
    pub preset: BuildPreset,
    /// The devices of each rank, the settings, and whether rank 0's host may finish a frame
    /// whose every device failed (one frame: `--repeats` is not offered over ranks).
    pub run: Run<'a>,
    pub out: &'a Path,
    pub report: Option<&'a Path>,
    pub json: bool,
}

/// What every rank has agreed on before it renders: the job, rank 0's checked outputs
/// (`None` elsewhere), and the scene with its BVH.
struct Start {
    cluster: Cluster,
    outputs: Option<Outputs>,
    scene: raytrace::Scene,
    bvh: Bvh,
}

/// Joins the MPI job, checks rank 0's outputs (rank 0 writes every one, so before any rank
/// starts work) and loads the scene on every rank, each step agreed by all.
fn start(job: &Job<'_>) -> Result<Start, CliError> {
    let cluster = Cluster::init()?;
    let outputs = cluster.is_root().then(|| {
        Outputs::check(
            &[("out", Some(job.out)), ("report", job.report)],
            &[("scene", Path::new(job.scene))],
        )
    });
    let outputs = cluster.agree("checking the outputs", outputs.transpose())?;
    let loaded = SceneSource::parse(job.scene)
        .and_then(|s| s.load(job.shader.needs()))
        .and_then(|scene| Bvh::build(&scene, job.preset).map(|bvh| (scene, bvh)));
    let (scene, bvh) = cluster.agree("loading the scene", loaded)?;
    Ok(Start {
        cluster,
        outputs,
        scene,
        bvh,
    })
}

fn device_list(specs: &[DeviceSpec]) -> String {
    let items: Vec<String> = specs
        .iter()
        .map(|s| match s {
            DeviceSpec::Cpu { count, threads } => format!("cpu:{count}/{threads}"),
            DeviceSpec::Gpu(g) => format!("gpu:{g:?}"),
        })
        .collect();
    items.join(",")
}

/// The report of a render over ranks (rank 0's view).
#[derive(Debug, Serialize)]
struct Report {
    scene: String,
    shader: &'static str,
    width: u32,
    height: u32,
    ranks: usize,
    /// Devices of each rank, as given to `--devices`.
    devices_per_rank: String,
    policy: sched::Policy,
    mode: &'static str,
    /// `--task-size`: the frame's tasks are cut to it, or finer (the run's `task_size`).
    requested_task_size: usize,
    #[serde(flatten)]
    run: RunReport,
}

/// Renders `job` on every rank of the MPI job: on rank 0, every other rank is one path
/// device beside rank 0's own devices; the others render the tasks they are sent on their
/// own devices and return the paths' values.
pub(crate) fn render(job: Job<'_>) -> Result<(), CliError> {
    let Start {
        cluster,
        outputs,
        scene,
        bvh,
    } = start(&job)?;
    let run = &job.run;
    let local = build_path_devices(&scene, &bvh, run.specs, run.faults);
    let devices = cluster.agree("opening this rank's devices", local)?;
    let (camera, _) = job.camera.resolve(&scene);
    let options = RenderOptions::new(job.width, job.height, camera, job.shader);
    let rendered = render_over_ranks(&cluster, devices, run.settings, &scene, &bvh, &options);
    let Some(outputs) = outputs else {
        // Another rank: it rendered what rank 0 sent until the frame was done.
        return rendered.map(drop).map_err(Into::into);
    };
    let mut lost = Vec::new();
    let frame = match rendered {
        Ok(Some(frame)) => frame,
        // Only the other ranks get no frame, and they have no outputs.
        Ok(None) => return Ok(()),
        Err(sched::SchedError::AllDevicesFailed { failures, .. }) => {
            let devices = device_list(run.specs);
            let mut host = run
                .host_renderer(&failures, &scene, &bvh)
                .map_err(|e| CliError::run(&devices, e))?;
            lost = failures;
            host.render(&scene, &bvh, &options)?
        }
        Err(e) => return Err(e.into()),
    };
    let mut figures = RunReport::new(1, frame.stats.seconds, &frame.stats);
    figures.host_fallback = !lost.is_empty();
    figures
        .failures
        .extend(lost.iter().map(ToString::to_string));
    let image = frame.film.png(ToneMap::Srgb)?;
    let report = Report {
        scene: job.scene.to_string(),
        shader: job.shader.name(),
        width: job.width,
        height: job.height,
        ranks: cluster.size(),
        devices_per_rank: device_list(run.specs),
        policy: run.settings.policy,
        mode: run.settings.mode.name(),
        requested_task_size: run.settings.task_size.get(),
        run: figures,
    };
    let json = serde_json::to_string_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;
    let json = format!("{json}\n");
    outputs.commit(&[("out", &image), ("report", json.as_bytes())])?;
    if job.json {
        return outputs.print_json(&report);
    }
    let r = &report.run;
    let text = format!(
        "{} {}x{} of {} on {} rank(s) × {}, {} {}, {} tasks of {} paths: {}\n{}",
        report.shader,
        report.width,
        report.height,
        report.scene,
        report.ranks,
        report.devices_per_rank,
        report.policy,
        report.mode,
        r.tasks,
        r.task_size,
        r.figures(),
        r.notes(),
    );
    outputs.print(&text)
}
