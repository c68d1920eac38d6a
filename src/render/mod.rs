//! `cobalt render`: a scene, a camera and a shader in; a PNG, an optional cost image and a
//! JSON report out (see README.md, "cobalt render").
//!
//! The arguments are typed and checked by clap before anything runs; [`run`] checks what
//! depends on several flags, checks the output paths, loads the scene and hands it to one
//! pipeline: [`paths`] (every frame as tasks of whole paths, the default) or [`generations`]
//! (every generation of rays scheduled on its own). Each returns its encoded outputs and a
//! report ([`report`] for generations), written all together at the end.

mod generations;
mod header;
mod paths;
mod rendered;
mod report;

use std::path::{Path, PathBuf};
use std::time::Instant;

use raytrace::devices::{DeviceSpec, GpuSelect};
use raytrace::scheduled::{EstimateOn, FailAfter, Settings};
use raytrace::shade::{RenderOptions, Shader};
use raytrace::{Bvh, Camera, Scene, SceneSource, Walk};

use crate::args::{
    CameraArgs, CameraChoice, Pipeline, ReportArgs, SceneArgs, ScheduleArgs, ShaderArgs, Size,
};
use crate::error::CliError;
use crate::output::Outputs;
use header::{Drawn, Header};

/// What `cobalt render --pipeline` takes: a [`Pipeline`], or `gpu`, the path pipeline on the
/// first GPU alone. One type for the pipelines both `render` and `bench` take; `gpu` is
/// render's shorthand for a device list, so it wraps them rather than being one more.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RenderPipeline {
    /// One of the pipelines, on `--devices`.
    Of(Pipeline),
    /// `paths` on `--devices gpu:0`.
    Gpu,
}

impl RenderPipeline {
    /// The pipeline that renders.
    fn pipeline(self) -> Pipeline {
        match self {
            Self::Of(pipeline) => pipeline,
            Self::Gpu => Pipeline::Paths,
        }
    }

    /// The name the report gives: the pipeline's, or `gpu`.
    fn name(self) -> &'static str {
        match self {
            Self::Of(pipeline) => pipeline.name(),
            Self::Gpu => "gpu",
        }
    }
}

impl clap::ValueEnum for RenderPipeline {
    fn value_variants<'a>() -> &'a [Self] {
        &[
            Self::Of(Pipeline::Paths),
            Self::Of(Pipeline::Generations),
            Self::Gpu,
        ]
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        match self {
            Self::Of(pipeline) => pipeline.to_possible_value(),
            Self::Gpu => Some(clap::builder::PossibleValue::new("gpu").help(
                "`paths` on `--devices gpu:0` (software adapters only with \
                 `COBALT_GPU_SOFTWARE=1`)",
            )),
        }
    }
}

/// Arguments of `cobalt render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    shader: ShaderArgs,
    /// Image size, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "1024x1024")]
    size: Size,
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    schedule: ScheduleArgs,
    /// How the frame is rendered: `paths` (the default), `generations` or `gpu`. Under
    /// `mpirun`, `paths` makes every other rank a path device of rank 0.
    #[arg(long, value_enum)]
    pipeline: Option<RenderPipeline>,
    /// With `--pipeline paths` or `gpu`: render this many frames through one renderer (each
    /// plans with the speeds measured on the ones before) and report the fastest.
    #[arg(long, default_value = "1", value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Where cost mode's estimate runs: `cpu` (the host's cores; the default) or `gpu` (the
    /// first GPU among `--devices`; the host where there is none). `--pipeline generations`
    /// only.
    #[arg(long)]
    estimate_on: Option<EstimateOn>,
    /// How cost mode traces each task's sample: `reduced` (the reduced traversal of the whole
    /// ray), `first-leaf` (closest-hit rays end at the exit of the first leaf they reach;
    /// better on closed meshes; shadow and AO rays keep the whole reduced traversal), or
    /// `trace` (the real trace, counted; on the CPU). See `cobalt estimate --walk`.
    /// `--pipeline generations` only: the path pipeline renders its sampled paths for real.
    #[arg(long, alias = "probe")]
    walk: Option<Walk>,
    /// How far cost mode's estimate refines its sample on the CPU: from a quarter of
    /// --sample-rate, up to it, while its two interleaved halves disagree by more than this
    /// share of the tasks' cost; `off` (the default, as the thesis does) samples every task at
    /// --sample-rate. See `cobalt estimate --sample-error`. `--pipeline generations` only.
    #[arg(long)]
    sample_error: Option<crate::args::SampleError>,
    /// Fault injection, `DEVICE@TASKS[,…]`: device DEVICE (0-based, in `--devices` order, a
    /// GPU included) fails after completing TASKS tasks; its unfinished tasks are re-run
    /// elsewhere.
    #[arg(long, value_delimiter = ',', value_parser = crate::args::fail_after)]
    fail: Vec<FailAfter>,
    /// When every device of `--devices` fails, finish the frame on the host's threads and say
    /// so, instead of exiting with status 3 and writing nothing.
    #[arg(long)]
    host_fallback: bool,
    /// The image (PNG, 8-bit sRGB).
    #[arg(long, default_value = "image.png")]
    out: PathBuf,
    /// A heat map of the primary rays' work: nodes entered `B` (left) and triangle tests `T`
    /// (right), each normalised to its maximum (PNG, twice as wide as the image).
    #[arg(long)]
    cost_image: Option<PathBuf>,
    #[command(flatten)]
    output: ReportArgs,
    #[command(flatten)]
    calibration: crate::calibration::CalibrationArgs,
}

/// Runs the command: every argument is checked before the scene is loaded, and nothing is
/// written until the render is done.
pub fn run(args: Args) -> Result<(), CliError> {
    // The film, the rays of a generation and their hits, per pixel and sample.
    crate::limits::memory("size", &args.size.to_string(), &[(args.size.pixels(), 256)])?;
    let faults = faults(&args)?;
    let settings = Settings {
        policy: args.schedule.policy,
        mode: args.schedule.mode,
        task_size: args.schedule.task_size,
        sample_rate: args.schedule.sample_rate,
        estimate_on: args.estimate_on.unwrap_or_default(),
        walk: args.walk.unwrap_or(Walk::Reduced),
        sample_error: args.sample_error.and_then(|e| e.0),
    };
    let camera = args.camera.choice()?;
    let shader = args.shader.shader();

    // Under `mpirun`, every rank renders the same image together (see `crate::cluster`).
    #[cfg(feature = "mpi")]
    if sched::mpi::Cluster::launched() {
        return mpi(&args, shader, camera, &faults, settings);
    }

    let chosen = args.pipeline.unwrap_or(RenderPipeline::Of(Pipeline::Paths));
    let pipeline = chosen.pipeline();
    check_pipeline_flags(&args, pipeline)?;
    let outputs = Outputs::check(
        &[
            ("out", Some(&args.out)),
            ("cost-image", args.cost_image.as_deref()),
            ("report", args.output.report.as_deref()),
        ],
        &[("scene", Path::new(&args.scene.scene))],
    )?;
    // Read before the scene, so that a calibration file that cannot be used fails first.
    let store = match pipeline {
        Pipeline::Generations => None,
        Pipeline::Paths => crate::calibration::Store::open(&args.calibration)?,
    };
    let (scene, bvh, view, header) = load(&args, &shader, camera)?;
    let workload = crate::calibration::workload(&args.scene.scene, &shader);
    let mut options = RenderOptions::new(args.size.width, args.size.height, view, shader);
    let json = args.output.json;
    if pipeline == Pipeline::Generations {
        options.count_primary = args.cost_image.is_some();
        let devices = (&args.schedule.devices, &faults[..]);
        let rendered = generations::render_generations(
            &scene,
            &bvh,
            &options,
            devices,
            settings,
            args.host_fallback,
            header,
        )?;
        let summary = rendered.report.summary();
        return rendered.write(&outputs, json, &summary);
    }
    let gpu0 = [DeviceSpec::Gpu(GpuSelect::Index(0))];
    let (devices, specs) = match chosen {
        RenderPipeline::Gpu => ("gpu:0", &gpu0[..]),
        _ => (
            args.schedule.devices.as_str(),
            args.schedule.devices.specs(),
        ),
    };
    let job = paths::PathJob {
        pipeline: chosen.name(),
        devices,
        specs,
        faults: &faults,
        settings,
        frames: args.repeats,
        host_fallback: args.host_fallback,
        cost_image: args.cost_image.is_some(),
    };
    let rendered = paths::render_paths(&scene, &bvh, &options, &job, (store, &workload), header)?;
    let summary = rendered.report.summary();
    rendered.write(&outputs, json, &summary)
}

/// Loads the scene and builds its BVH, and the report's header of a render of it.
fn load(
    args: &Args,
    shader: &Shader,
    camera: CameraChoice,
) -> Result<(Scene, Bvh, Camera, Header), CliError> {
    let loading = Instant::now();
    let scene = SceneSource::parse(&args.scene.scene)?.load(shader.needs())?;
    let load_seconds = loading.elapsed().as_secs_f64();
    let bvh = Bvh::build(&scene, args.scene.preset)?;
    let (view, camera_index) = camera.resolve(&scene.bounds());
    let header = Header::new(&Drawn {
        source: &args.scene.scene,
        scene: &scene,
        bvh: &bvh,
        preset: args.scene.preset,
        load_seconds,
        shader,
        size: args.size,
        camera: &view,
        camera_index,
    });
    Ok((scene, bvh, view, header))
}

/// `--fail`, each device an index into `--devices`. GPU entries open however many adapters
/// exist: their indices are checked once the devices are built (naming the fault).
fn faults(args: &Args) -> Result<Vec<FailAfter>, CliError> {
    let devices = &args.schedule.devices;
    let known = if devices.has_gpu() {
        usize::MAX
    } else {
        devices.cpu_devices()
    };
    crate::args::check_faults(&args.fail, known)
}

/// Refuses the flags that do not apply to `pipeline`, naming the one they apply to.
fn check_pipeline_flags(args: &Args, pipeline: Pipeline) -> Result<(), CliError> {
    let refuse = |flag: &'static str, value: &str, why: &str| {
        Err(CliError::Arg {
            flag,
            value: value.to_string(),
            message: why.to_string(),
        })
    };
    let generations = "it applies to --pipeline generations";
    match pipeline {
        Pipeline::Generations if args.repeats != 1 => refuse(
            "repeats",
            &args.repeats.to_string(),
            "only with --pipeline paths or gpu",
        ),
        Pipeline::Generations => match &args.calibration.calibration {
            Some(file) => refuse(
                "calibration",
                &file.display().to_string(),
                "the generations pipeline learns within one render; it applies to --pipeline \
                 paths or gpu",
            ),
            None => Ok(()),
        },
        Pipeline::Paths => match (args.estimate_on, args.walk, args.sample_error) {
            (Some(on), _, _) => refuse(
                "estimate-on",
                on.name(),
                &format!(
                    "the path pipeline estimates on the devices of the first one's kind; \
                     {generations}"
                ),
            ),
            (_, Some(walk), _) => refuse(
                "walk",
                walk.name(),
                &format!("the path pipeline renders its sampled paths for real; {generations}"),
            ),
            (_, _, Some(e)) => refuse(
                "sample-error",
                &e.to_string(),
                &format!("the path pipeline samples its paths at --sample-rate; {generations}"),
            ),
            _ => Ok(()),
        },
    }
}

/// `cobalt render` under `mpirun`: the flags a cluster cannot honour are refused, then every
/// rank renders the same image together ([`crate::cluster`]).
#[cfg(feature = "mpi")]
fn mpi(
    args: &Args,
    shader: raytrace::shade::Shader,
    camera: CameraChoice,
    faults: &[FailAfter],
    settings: Settings,
) -> Result<(), CliError> {
    let refuse = |flag: &'static str, value: String, why: &str| {
        Err(CliError::Arg {
            flag,
            value,
            message: why.to_string(),
        })
    };
    let chosen = args.pipeline.unwrap_or(RenderPipeline::Of(Pipeline::Paths));
    if let Some(path) = &args.cost_image {
        let why = "not available under mpirun; render the cost image in one process";
        return refuse("cost-image", path.display().to_string(), why);
    }
    if args.estimate_on == Some(EstimateOn::Gpu) {
        let why = "not available under mpirun: every rank estimates its slice on its host";
        return refuse("estimate-on", "gpu".into(), why);
    }
    if chosen == RenderPipeline::Gpu {
        let why = "not available under mpirun; give each rank `--devices …,gpu:all` instead";
        return refuse("pipeline", "gpu".into(), why);
    }
    let pipeline = chosen.pipeline();
    if let (Pipeline::Paths, Some(walk)) = (pipeline, args.walk) {
        let why = "the path pipeline renders its sampled paths for real; it applies to \
                   --pipeline generations";
        return refuse("walk", walk.name().to_string(), why);
    }
    if let (Pipeline::Paths, Some(e)) = (pipeline, args.sample_error) {
        let why = "the path pipeline samples its paths at --sample-rate; it applies to \
                   --pipeline generations";
        return refuse("sample-error", e.to_string(), why);
    }
    let job = crate::cluster::Job {
        scene: &args.scene.scene,
        shader,
        width: args.size.width,
        height: args.size.height,
        camera,
        preset: args.scene.preset,
        specs: args.schedule.devices.specs(),
        faults,
        settings,
        out: &args.out,
        report: args.output.report.as_deref(),
        json: args.output.json,
        host_fallback: args.host_fallback,
    };
    if pipeline == Pipeline::Paths {
        crate::cluster::render_paths(job)
    } else {
        crate::cluster::render(job)
    }
}
