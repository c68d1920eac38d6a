//! `cobalt render`: a scene, a camera and a shader in; a PNG, an optional cost image and a
//! JSON report of every generation of rays out (see README.md, "cobalt render").
//!
//! Every generation of rays is scheduled by `sched` over the `--devices` (see
//! [`raytrace::scheduled`]): cut into `--task-size` tasks, costed (`--mode`), planned by
//! `--policy`; the report gives each generation's balance, overheads, launches and device
//! speeds, and the calibration of `kB`, `kT` per device and ray kind.

use std::num::NonZeroUsize;
use std::path::PathBuf;
use std::time::Instant;

use raytrace::cost::SampleRate;
use raytrace::cost_image::{cost_image, max_counts};
use raytrace::devices::DeviceSpec;
use raytrace::film::ToneMap;
use raytrace::glam::Vec3;
use raytrace::scheduled::{
    EstimateOn, FailAfter, GenerationStats, Mode, ScheduledTracer, Settings, build_devices,
};
use raytrace::shade::{AoSettings, RenderOptions, Rendering, Shader, WhittedSettings, render};
use raytrace::{BuildPreset, Bvh, Camera, Probe, Scene, SceneSource};
use sched::Policy;
use serde::Serialize;

use crate::error::CliError;

/// Largest image side: keeps a typo like `--size 1024000x1` from allocating gigabytes.
const MAX_SIDE: u32 = 16384;

/// Most devices, and most threads per device: a typo should not start a million threads.
const MAX_DEVICES: usize = 1024;

/// Largest task: a generation of a 16384² image with 32 AO probes fits `u32` task indices
/// at any size above this, and no sensible task is larger.
const MAX_TASK_SIZE: usize = 1 << 24;

/// Which shader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShaderArg {
    /// Ambient occlusion: Halton probes per hit (the diffuse workload).
    Ao,
    /// Whitted: shadow rays and two mirror bounces (the coherent workload).
    Whitted,
}

/// Where a render runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PipelineArg {
    /// Every frame scheduled over `--devices` by `--policy` as tasks of whole paths, each
    /// made, traced and shaded on the device that runs it.
    Paths,
    /// Every generation of rays scheduled over `--devices` by `--policy` on its own, the rays
    /// made and shaded on the host (per-generation statistics and calibration).
    #[value(alias = "scheduled")]
    Generations,
    /// `paths` on `--devices gpu:0` (software adapters only with `COBALT_GPU_SOFTWARE=1`).
    Gpu,
}

fn pipeline_name(p: PipelineArg) -> &'static str {
    match p {
        PipelineArg::Paths => "paths",
        PipelineArg::Generations => "generations",
        PipelineArg::Gpu => "gpu",
    }
}

/// Arguments of `cobalt render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// An OBJ file, or `builtin:forest|hairball|cornell[:detail]`.
    #[arg(long)]
    scene: String,
    /// The shader.
    #[arg(long, value_enum, default_value = "whitted")]
    shader: ShaderArg,
    /// Image size, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "1024x1024")]
    size: String,
    /// One of the thesis's four cameras, 0..3 (at the top of the scene's bounding box, looking
    /// at its centre); the default when no `--eye`/`--at` is given.
    #[arg(long, conflicts_with_all = ["eye", "at"], allow_hyphen_values = true)]
    camera: Option<String>,
    /// Camera position `X,Y,Z` (with `--at`).
    #[arg(long, requires = "at", allow_hyphen_values = true)]
    eye: Option<String>,
    /// Point looked at `X,Y,Z` (with `--eye`).
    #[arg(long, requires = "eye", allow_hyphen_values = true)]
    at: Option<String>,
    /// AO probes per primary hit.
    #[arg(long, default_value = "32")]
    ao_samples: String,
    /// AO probe length (default: 5 % of the scene's bounding-box diagonal).
    #[arg(long)]
    ao_distance: Option<String>,
    /// Devices: `cpu:N` (N devices of one thread), `cpu:N/T` (T threads each), several
    /// comma-separated, or `cpu` (one device with every core); `gpu:all` or `gpu:K` adds wgpu
    /// adapters (software ones only with `COBALT_GPU_SOFTWARE=1`). At most 1024 CPU devices,
    /// 1024 threads each and 4096 threads in all.
    #[arg(long, default_value = "cpu:2")]
    devices: String,
    /// `paths` (every frame over `--devices` as tasks of whole paths, rendered where they
    /// run; the default), `generations` (every generation of rays over `--devices` on its
    /// own, made and shaded on the host), or `gpu` (`paths` on `--devices gpu:0`). Under
    /// `mpirun`, `paths` makes every other rank a path device of rank 0.
    #[arg(long, value_enum)]
    pipeline: Option<PipelineArg>,
    /// With `--pipeline paths` or `gpu`: render this many frames through one renderer (each
    /// plans with the speeds measured on the ones before) and report the fastest.
    #[arg(long, default_value = "1", value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// How tasks go to devices: static-equal, static-lpt (lpt), queue-fifo (fifo),
    /// queue-sorted (sorted) or hybrid.
    #[arg(long, default_value = "static-lpt")]
    policy: Policy,
    /// Task costs: `cost` (reduced traversal of sampled rays) or `regular` (all equal).
    #[arg(long, default_value = "cost")]
    mode: Mode,
    /// Rays per task.
    #[arg(long, default_value = "4096")]
    task_size: String,
    /// Fraction of each task's rays the cost estimate traces, in (0, 1].
    #[arg(long, default_value = "0.125")]
    sample_rate: String,
    /// Where cost mode's estimate runs: `cpu` (the host's cores; the default) or `gpu` (the
    /// first GPU among `--devices`, as the thesis does; the host where there is none).
    /// `--pipeline generations` only.
    #[arg(long)]
    estimate_on: Option<EstimateOn>,
    /// How cost mode traces each task's sample: `thesis` (the reduced traversal of the whole
    /// ray), `first-leaf` (closest-hit rays end at the exit of the first leaf they reach;
    /// better on closed meshes; shadow and AO rays keep the thesis's), or `trace` (the real
    /// trace, counted; on the CPU). See `cobalt estimate --probe`. `--pipeline generations`
    /// only: the path pipeline renders its sampled paths for real.
    #[arg(long)]
    probe: Option<Probe>,
    /// Fault injection, `DEVICE@TASKS[,…]`: device DEVICE (0-based, in `--devices` order, a
    /// GPU included) fails after completing TASKS tasks; its unfinished tasks are re-run
    /// elsewhere.
    #[arg(long)]
    fail: Option<String>,
    /// When every device of `--devices` fails, finish the frame on the host's threads and say
    /// so, instead of exiting with status 3 and writing nothing.
    #[arg(long)]
    host_fallback: bool,
    /// BVH build preset: fastest, very-fast, fast, medium, slow, very-slow.
    #[arg(long, default_value = "medium")]
    preset: String,
    /// The image (PNG, 8-bit sRGB).
    #[arg(long, default_value = "image.png")]
    out: PathBuf,
    /// A heat map of the primary rays' work: nodes entered `B` (left) and triangle tests `T`
    /// (right), each normalised to its maximum (PNG, twice as wide as the image).
    #[arg(long)]
    cost_image: Option<PathBuf>,
    /// A JSON report: scene, shader, size, and rays and seconds per generation.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Print the report as one JSON object on standard output instead of a summary.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    calibration: crate::calibration::CalibrationArgs,
}

#[derive(Debug, Serialize)]
struct GenerationReport {
    kind: &'static str,
    bounce: u32,
    rays: usize,
    /// Trace time: estimate, plan and run on the devices.
    seconds: f64,
    mrays_per_s: f64,
    #[serde(flatten)]
    schedule: Option<ScheduleReport>,
}

/// How one generation was scheduled.
#[derive(Debug, Serialize)]
struct ScheduleReport {
    tasks: usize,
    /// Rays in the longest task: `--task-size`, or less for a generation too small to give
    /// every device several tasks.
    task_size: usize,
    estimate_seconds: f64,
    plan_seconds: f64,
    /// Wall time of the run on the devices.
    run_seconds: f64,
    makespan: f64,
    balance_efficiency: f64,
    /// Per device that took part, in `devices` order.
    device_names: Vec<String>,
    /// The relative speeds the plan used.
    speeds: Vec<f64>,
    /// The speeds measured on this generation (null where a device ran nothing).
    measured_speeds: Vec<Option<f64>>,
    launches: Vec<u64>,
    busy: Vec<f64>,
    /// Per device: kernel seconds it measured itself (a GPU's timestamp queries), null
    /// where it cannot.
    device_seconds: Vec<Option<f64>>,
    reruns: u64,
    failures: Vec<String>,
    host_fallback: bool,
    /// What crossed between the host and the devices: the generation's rays and hits, and
    /// an estimate's samples and sums where a GPU estimated (0 for CPUs).
    host_to_device_bytes: u64,
    device_to_host_bytes: u64,
    /// Times the host blocked on a device.
    host_waits: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    estimate_error: Option<String>,
    /// Where the estimate ran (cost mode): a device's name or `host`.
    #[serde(skip_serializing_if = "Option::is_none")]
    estimated_on: Option<String>,
    calibration: Vec<FitReport>,
    /// Per task, in task order: planned cost, measured seconds, device index.
    task_costs: Vec<f64>,
    task_seconds: Vec<f64>,
    task_devices: Vec<usize>,
    /// Per task: the kernel time its device measured (a GPU's timestamp queries) where the
    /// task had a launch of its own (queue policies), else null.
    task_device_seconds: Vec<Option<f64>>,
}

/// `kB`, `kT` of one device for one ray kind, fitted by least squares to measured task times.
#[derive(Debug, Clone, Serialize)]
struct FitReport {
    device: String,
    kind: &'static str,
    kb: f64,
    kt: f64,
    form: &'static str,
    r2: f64,
    rms_residual: f64,
    tasks: usize,
}

#[derive(Debug, Serialize)]
struct CostReport {
    max_nodes: u32,
    max_tris: u32,
    mean_nodes: f64,
    mean_tris: f64,
    seconds: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    #[serde(flatten)]
    header: Header,
    devices: String,
    /// Every device, in order.
    device_names: Vec<String>,
    /// Threads over all devices.
    threads: usize,
    policy: Policy,
    mode: &'static str,
    task_size: usize,
    sample_rate: f64,
    /// Cost mode's probe of closest-hit generations.
    probe: &'static str,
    generations: Vec<GenerationReport>,
    total_rays: usize,
    /// Sum of the generations' trace times.
    trace_seconds: f64,
    /// Wall time of the render: ray generation, tracing and shading.
    render_seconds: f64,
    /// Rendering efficiency (thesis): total rays over `render_seconds`.
    mrays_per_s: f64,
    /// Σ busy / Σ (makespan × devices) over the generations: balance of the whole render.
    balance_efficiency: f64,
    /// Estimation and planning time over all generations.
    estimate_seconds: f64,
    plan_seconds: f64,
    launches: u64,
    reruns: u64,
    /// Generations traced on the host because every device had failed (`--host-fallback`).
    host_fallback_generations: usize,
    /// The last fit of every device and ray kind: the calibration the next render would use.
    calibration: Vec<FitReport>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cost: Option<CostReport>,
}

/// The report of `--pipeline paths` (and `gpu`).
#[derive(Debug, Serialize)]
struct PathsReport {
    #[serde(flatten)]
    header: Header,
    pipeline: &'static str,
    devices: String,
    policy: Policy,
    mode: &'static str,
    task_size: usize,
    sample_rate: f64,
    #[serde(flatten)]
    run: crate::render_paths::PathRun,
    /// The calibration file read before the first frame and written after the run.
    calibration: crate::calibration::CalibrationReport,
}

/// What every render report opens with: the scene, the image, the camera and the shader.
#[derive(Debug, Serialize)]
struct Header {
    scene: String,
    triangles: usize,
    shader: &'static str,
    size: String,
    width: u32,
    height: u32,
    camera: Option<usize>,
    eye: [f32; 3],
    at: [f32; 3],
    preset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    ao_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ao_distance: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    bounces: Option<u32>,
    load_seconds: f64,
    build_seconds: f64,
}

impl Header {
    #[allow(clippy::too_many_arguments)] // one call, every value named there
    fn new(
        source: &str,
        scene: &Scene,
        bvh: &Bvh,
        shader: &Shader,
        (width, height): (u32, u32),
        (camera, index): (&Camera, Option<usize>),
        preset: BuildPreset,
        load_seconds: f64,
    ) -> Self {
        Self {
            scene: source.to_string(),
            triangles: scene.len(),
            shader: shader.name(),
            size: format!("{width}x{height}"),
            width,
            height,
            camera: index,
            eye: camera.eye.to_array(),
            at: camera.at.to_array(),
            preset: preset.name().to_string(),
            ao_samples: match shader {
                Shader::Ao(s) => Some(s.samples),
                Shader::Whitted(_) => None,
            },
            ao_distance: match shader {
                Shader::Ao(s) => Some(s.distance(scene)),
                Shader::Whitted(_) => None,
            },
            bounces: match shader {
                Shader::Whitted(s) => Some(s.bounces),
                Shader::Ao(_) => None,
            },
            load_seconds,
            build_seconds: bvh.report().build_seconds,
        }
    }
}

/// Where the camera comes from.
pub(crate) enum CameraChoice {
    Thesis(usize),
    LookAt(Vec3, Vec3),
}

impl CameraChoice {
    /// The camera for a scene with these bounds, and the thesis camera's index if it is one.
    pub(crate) fn resolve(&self, bounds: &raytrace::Aabb) -> (Camera, Option<usize>) {
        match *self {
            CameraChoice::Thesis(i) => (Camera::thesis(bounds, i), Some(i)),
            CameraChoice::LookAt(eye, at) => (Camera::look_at(eye, at), None),
        }
    }
}

/// Runs the command: every argument is checked before the scene is loaded, and nothing is
/// written until the render is done.
pub fn run(args: Args) -> Result<(), CliError> {
    let (width, height) = parse_size(&args.size)?;
    // The film, the rays of a generation and their hits, per pixel and sample.
    let pixels = width as usize * height as usize;
    crate::limits::memory("size", &args.size, &[(pixels, 256)])?;
    let specs = parse_devices(&args.devices)?;
    let threads: usize = specs
        .iter()
        .map(|s| match s {
            DeviceSpec::Cpu { count, threads } => count * threads,
            DeviceSpec::Gpu(_) => 0,
        })
        .sum();
    let device_count: usize = specs
        .iter()
        .map(|s| match s {
            DeviceSpec::Cpu { count, .. } => *count,
            DeviceSpec::Gpu(_) => 0,
        })
        .sum();
    // GPU entries open however many adapters exist: their indices are checked once the
    // devices are built (naming the fault).
    let has_gpu = specs.iter().any(|s| matches!(s, DeviceSpec::Gpu(_)));
    let faults = match &args.fail {
        Some(text) => parse_faults(text, if has_gpu { usize::MAX } else { device_count })?,
        None => Vec::new(),
    };
    let settings = Settings {
        policy: args.policy,
        mode: args.mode,
        task_size: parse_task_size(&args.task_size)?,
        sample_rate: match args.sample_rate.trim().parse::<f64>().map(SampleRate::new) {
            Ok(Ok(rate)) => rate,
            _ => {
                return Err(arg(
                    "sample-rate",
                    &Some(args.sample_rate.clone()),
                    "expected a fraction in (0, 1], e.g. 0.125",
                ));
            }
        },
        estimate_on: args.estimate_on.unwrap_or_default(),
        probe: args.probe.unwrap_or(Probe::Thesis),
    };
    let camera_choice = match (&args.camera, &args.eye, &args.at) {
        (_, Some(eye), Some(at)) => {
            let (eye, at) = (parse_point("eye", eye)?, parse_point("at", at)?);
            if eye == at {
                return Err(arg(
                    "at",
                    &args.at,
                    "the camera cannot look at its own position",
                ));
            }
            CameraChoice::LookAt(eye, at)
        }
        (Some(c), _, _) => CameraChoice::Thesis(parse_camera(c)?),
        _ => CameraChoice::Thesis(0),
    };
    let preset: BuildPreset = args
        .preset
        .parse()
        .map_err(|e: String| arg("preset", &Some(args.preset.clone()), &e))?;
    let samples: u32 = match args.ao_samples.parse() {
        Ok(n) if (1..=4096).contains(&n) => n,
        _ => {
            return Err(arg(
                "ao-samples",
                &Some(args.ao_samples.clone()),
                "expected a whole number in 1..=4096",
            ));
        }
    };
    let ao_distance = match &args.ao_distance {
        None => None,
        Some(text) => match text.parse::<f32>() {
            Ok(d) if d.is_finite() && d > 0.0 => Some(d),
            _ => {
                return Err(arg(
                    "ao-distance",
                    &args.ao_distance,
                    "expected a finite number > 0",
                ));
            }
        },
    };
    let shader = match args.shader {
        ShaderArg::Ao => Shader::Ao(AoSettings {
            samples,
            max_distance: ao_distance,
            ..Default::default()
        }),
        ShaderArg::Whitted => Shader::Whitted(WhittedSettings::default()),
    };

    // Under `mpirun`, every rank renders the same image together (see `crate::cluster`).
    #[cfg(feature = "mpi")]
    if sched::mpi::Cluster::launched() {
        if args.cost_image.is_some() {
            return Err(arg(
                "cost-image",
                &args.cost_image.as_ref().map(|p| p.display().to_string()),
                "not available under mpirun; render the cost image in one process",
            ));
        }
        if args.estimate_on == Some(EstimateOn::Gpu) {
            return Err(arg(
                "estimate-on",
                &Some("gpu".to_string()),
                "not available under mpirun: every rank estimates its slice on its host",
            ));
        }
        let pipeline = args.pipeline.unwrap_or(PipelineArg::Paths);
        if pipeline == PipelineArg::Gpu {
            return Err(arg(
                "pipeline",
                &Some("gpu".to_string()),
                "not available under mpirun; give each rank `--devices …,gpu:all` instead",
            ));
        }
        if let (PipelineArg::Paths, Some(probe)) = (pipeline, args.probe) {
            return Err(arg(
                "probe",
                &Some(probe.name().to_string()),
                "the path pipeline renders its sampled paths for real; it applies to \
                 --pipeline generations",
            ));
        }
        let job = crate::cluster::Job {
            scene: &args.scene,
            shader,
            width,
            height,
            camera: camera_choice,
            preset,
            specs: &specs,
            faults: &faults,
            settings,
            out: &args.out,
            report: args.report.as_deref(),
            json: args.json,
            host_fallback: args.host_fallback,
        };
        return if pipeline == PipelineArg::Paths {
            crate::cluster::render_paths(job)
        } else {
            crate::cluster::render(job)
        };
    }

    let pipeline = args.pipeline.unwrap_or(PipelineArg::Paths);
    let by_paths = pipeline != PipelineArg::Generations;
    if !by_paths && args.repeats != 1 {
        let value = Some(args.repeats.to_string());
        return Err(arg("repeats", &value, "only with --pipeline paths or gpu"));
    }
    if by_paths {
        let refuse = |flag: &'static str, value: Option<&str>, why: &str| {
            Err(arg(
                flag,
                &value.map(str::to_string),
                &format!("{why}; it applies to --pipeline generations"),
            ))
        };
        if let Some(on) = args.estimate_on {
            let why = "the path pipeline estimates on the devices of the first one's kind";
            return refuse("estimate-on", Some(on.name()), why);
        }
        if let Some(probe) = args.probe {
            let why = "the path pipeline renders its sampled paths for real";
            return refuse("probe", Some(probe.name()), why);
        }
    } else if let Some(file) = &args.calibration.calibration {
        return Err(arg(
            "calibration",
            &Some(file.display().to_string()),
            "the generations pipeline learns within one render; it applies to --pipeline \
             paths or gpu",
        ));
    }

    let outputs = crate::output::Outputs::check(
        &[
            ("out", Some(&args.out)),
            ("cost-image", args.cost_image.as_deref()),
            ("report", args.report.as_deref()),
        ],
        &[("scene", std::path::Path::new(&args.scene))],
    )?;
    // Read before the scene, so that a calibration file that cannot be used fails first.
    let mut store = if by_paths {
        crate::calibration::Store::open(&args.calibration)?
    } else {
        None
    };
    let loading = Instant::now();
    let scene = SceneSource::parse(&args.scene)?.load(shader.needs())?;
    let load_seconds = loading.elapsed().as_secs_f64();
    let bvh = Bvh::build(&scene, preset)?;
    let (camera, camera_index) = camera_choice.resolve(&scene.bounds());
    let header = Header::new(
        &args.scene,
        &scene,
        &bvh,
        &shader,
        (width, height),
        (&camera, camera_index),
        preset,
        load_seconds,
    );
    if by_paths {
        let (devices, specs) = match pipeline {
            PipelineArg::Gpu => (
                String::from("gpu:0"),
                vec![DeviceSpec::Gpu(raytrace::devices::GpuSelect::Index(0))],
            ),
            _ => (args.devices.clone(), specs),
        };
        let pipeline = pipeline_name(pipeline);
        let workload = crate::calibration::workload(&args.scene, &shader);
        let options = RenderOptions::new(width, height, camera, shader);
        let (film, run) = crate::render_paths::render(
            &scene,
            &bvh,
            &options,
            &specs,
            &faults,
            settings,
            args.repeats,
            &crate::render_paths::Fallback {
                devices: &devices,
                host_fallback: args.host_fallback,
            },
            store.as_mut().map(|s| (s, workload.as_str())),
        )?;
        let calibration = store.as_ref().map(|s| s.save()).unwrap_or_default();
        let image = film.png(ToneMap::Srgb)?;
        let cost_png = match &args.cost_image {
            Some(_) => {
                let counts = raytrace::cost_image::primary_counts(&bvh, &camera, width, height);
                Some(cost_image(&counts, width, height).png(ToneMap::Display)?)
            }
            None => None,
        };
        let report = PathsReport {
            header,
            pipeline,
            devices,
            policy: settings.policy,
            mode: settings.mode.name(),
            task_size: settings.task_size.get(),
            sample_rate: settings.sample_rate.get(),
            run,
            calibration,
        };
        let json =
            serde_json::to_string_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;
        let json = format!("{json}\n");
        outputs.commit(&[
            ("out", &image),
            ("cost-image", cost_png.as_deref().unwrap_or_default()),
            ("report", json.as_bytes()),
        ])?;
        return if args.json {
            outputs.print_json(&report)
        } else {
            let r = &report.run;
            let text = format!(
                "{} {} of {} ({} triangles) on {} by paths, {} {}, tasks of {}: {}; fastest of {} \
                 frame(s)\n{}",
                report.header.shader,
                report.header.size,
                report.header.scene,
                report.header.triangles,
                report.devices,
                report.policy.name(),
                report.mode,
                report.task_size,
                r.figures(),
                r.frames,
                r.notes(),
            );
            outputs.print(&text)
        };
    }
    let devices = build_devices(&bvh, &specs, &faults)?;
    let mut tracer = ScheduledTracer::new(&bvh, devices, settings)?;
    let mut options = RenderOptions::new(width, height, camera, shader);
    options.count_primary = args.cost_image.is_some();
    let rendering = render(&scene, &mut tracer, &options);
    let host_fallback_generations = tracer.stats().iter().filter(|g| g.host_fallback).count();
    if host_fallback_generations > 0 && !args.host_fallback {
        let failures: Vec<_> = tracer
            .stats()
            .iter()
            .flat_map(|g| g.failures.iter().cloned())
            .collect();
        return Err(CliError::devices_failed(&args.devices, &failures));
    }

    // Encode everything first, so a failure leaves no partial set of outputs.
    let image = rendering.film.png(ToneMap::Srgb)?;
    let cost_png = match (&args.cost_image, &rendering.primary_counts) {
        (Some(_), Some(counts)) => Some(cost_image(counts, width, height).png(ToneMap::Display)?),
        _ => None,
    };
    let report = Report {
        header,
        devices: args.devices.clone(),
        device_names: tracer.device_names(),
        threads,
        policy: settings.policy,
        mode: settings.mode.name(),
        task_size: settings.task_size.get(),
        sample_rate: settings.sample_rate.get(),
        probe: settings.probe.name(),
        generations: generation_reports(&rendering, tracer.stats()),
        total_rays: rendering.total_rays(),
        trace_seconds: rendering.trace_seconds(),
        render_seconds: rendering.seconds,
        mrays_per_s: rendering.mrays_per_s(),
        balance_efficiency: overall_balance(tracer.stats()),
        estimate_seconds: tracer.stats().iter().map(|g| g.estimate_seconds).sum(),
        plan_seconds: tracer.stats().iter().map(|g| g.plan_seconds).sum(),
        launches: tracer.stats().iter().map(GenerationStats::launches).sum(),
        reruns: tracer.stats().iter().map(|g| g.reruns).sum(),
        host_fallback_generations,
        calibration: final_calibration(tracer.stats()),
        cost: rendering.primary_counts.as_ref().map(|counts| {
            let max = max_counts(counts);
            let n = counts.len().max(1) as f64;
            CostReport {
                max_nodes: max.nodes,
                max_tris: max.tris,
                mean_nodes: counts.iter().map(|c| c.nodes as f64).sum::<f64>() / n,
                mean_tris: counts.iter().map(|c| c.tris as f64).sum::<f64>() / n,
                seconds: rendering.count_seconds,
            }
        }),
    };
    let report_json =
        serde_json::to_string_pretty(&report).map_err(|e| CliError::Write(e.to_string()))?;

    let report_json = format!("{report_json}\n");
    outputs.commit(&[
        ("out", &image),
        ("cost-image", cost_png.as_deref().unwrap_or_default()),
        ("report", report_json.as_bytes()),
    ])?;
    if args.json {
        outputs.print_json(&report)
    } else {
        outputs.print(&summary(&report))
    }
}

/// One report per generation; the tracer's stats are in the same order (one per traced
/// generation).
fn generation_reports(r: &Rendering, stats: &[GenerationStats]) -> Vec<GenerationReport> {
    r.generations
        .iter()
        .enumerate()
        .map(|(i, g)| GenerationReport {
            kind: g.kind.name(),
            bounce: g.bounce,
            rays: g.rays,
            seconds: g.seconds,
            mrays_per_s: g.mrays_per_s(),
            schedule: stats.get(i).map(schedule_report),
        })
        .collect()
}

fn schedule_report(g: &GenerationStats) -> ScheduleReport {
    ScheduleReport {
        tasks: g.tasks,
        task_size: g.task_size,
        estimate_seconds: g.estimate_seconds,
        plan_seconds: g.plan_seconds,
        run_seconds: g.run_seconds,
        makespan: g.makespan,
        balance_efficiency: g.balance_efficiency,
        device_names: g.devices.iter().map(|d| d.name.clone()).collect(),
        speeds: g.devices.iter().map(|d| d.speed).collect(),
        measured_speeds: g.devices.iter().map(|d| d.measured_speed).collect(),
        launches: g.devices.iter().map(|d| d.launches).collect(),
        busy: g.devices.iter().map(|d| d.busy).collect(),
        device_seconds: g.devices.iter().map(|d| d.device_seconds).collect(),
        reruns: g.reruns,
        failures: g.failures.iter().map(ToString::to_string).collect(),
        host_fallback: g.host_fallback,
        host_to_device_bytes: g.traffic.host_to_device_bytes,
        device_to_host_bytes: g.traffic.device_to_host_bytes,
        host_waits: g.traffic.host_waits,
        estimate_error: g.estimate_error.clone(),
        estimated_on: g.estimated_on.clone(),
        calibration: g.calibrations.iter().map(fit_report).collect(),
        task_costs: g.task_stats.iter().map(|t| t.cost).collect(),
        task_seconds: g.task_stats.iter().map(|t| t.seconds).collect(),
        task_devices: g.task_stats.iter().map(|t| t.device).collect(),
        task_device_seconds: g.task_stats.iter().map(|t| t.device_seconds).collect(),
    }
}

fn fit_report(f: &raytrace::scheduled::DeviceFit) -> FitReport {
    FitReport {
        device: f.device.clone(),
        kind: f.kind.name(),
        kb: f.fit.model.kb,
        kt: f.fit.model.kt,
        form: f.fit.form.name(),
        r2: f.fit.r2,
        rms_residual: f.fit.rms_residual,
        tasks: f.fit.n,
    }
}

/// The thesis's balance efficiency of the whole render: every generation's busy time over
/// its makespan times its devices, summed before dividing so long generations weigh more.
fn overall_balance(stats: &[GenerationStats]) -> f64 {
    let busy: f64 = stats
        .iter()
        .flat_map(|g| g.devices.iter().map(|d| d.busy))
        .sum();
    let capacity: f64 = stats
        .iter()
        .map(|g| g.makespan * g.devices.len() as f64)
        .sum();
    if capacity > 0.0 { busy / capacity } else { 1.0 }
}

/// The latest fit of each (device, kind), in order of first appearance.
fn final_calibration(stats: &[GenerationStats]) -> Vec<FitReport> {
    let mut out: Vec<FitReport> = Vec::new();
    for f in stats.iter().flat_map(|g| &g.calibrations) {
        let r = fit_report(f);
        match out
            .iter_mut()
            .find(|o| o.device == r.device && o.kind == r.kind)
        {
            Some(o) => *o = r,
            None => out.push(r),
        }
    }
    out
}

fn summary(r: &Report) -> String {
    let mut s = format!(
        "{} {} of {} ({} triangles) on {} ({} thread(s)), {} {}, tasks of {}: {} rays in {:.3} s, {:.2} MRays/s, balance {:.1} %\n",
        r.header.shader,
        r.header.size,
        r.header.scene,
        r.header.triangles,
        r.devices,
        r.threads,
        r.policy,
        r.mode,
        r.task_size,
        r.total_rays,
        r.render_seconds,
        r.mrays_per_s,
        100.0 * r.balance_efficiency,
    );
    if r.host_fallback_generations > 0 {
        s += &format!(
            "every device failed: {} generation(s) traced on the host instead (--host-fallback)\n",
            r.host_fallback_generations
        );
    }
    for g in &r.generations {
        s += &format!(
            "  {:<10} bounce {}  {:>10} rays  {:.4} s  {:.2} MRays/s",
            g.kind, g.bounce, g.rays, g.seconds, g.mrays_per_s
        );
        if let Some(x) = &g.schedule {
            let speeds: Vec<String> = x.speeds.iter().map(|v| format!("{v:.3}")).collect();
            s += &format!(
                "  {:>6} tasks  balance {:5.1} %  estimate {:.4} s  plan {:.5} s  launches {:?}  speeds [{}]",
                x.tasks,
                100.0 * x.balance_efficiency,
                x.estimate_seconds,
                x.plan_seconds,
                x.launches,
                speeds.join(", "),
            );
            if x.reruns > 0 {
                s += &format!("  reruns {}", x.reruns);
            }
            if x.host_fallback {
                s += "  traced on the host";
            }
            for f in &x.failures {
                s += &format!("\n    {f}");
            }
        }
        s += "\n";
    }
    for c in &r.calibration {
        s += &format!(
            "  calibration {:<6} {:<10} kB {:.3e} s  kT {:.3e} s  ({}, R² {:.3}, {} tasks)\n",
            c.device, c.kind, c.kb, c.kt, c.form, c.r2, c.tasks
        );
    }
    s
}

fn arg(flag: &'static str, value: &Option<String>, message: &str) -> CliError {
    CliError::Arg {
        flag,
        value: value.clone().unwrap_or_default(),
        message: message.to_string(),
    }
}

/// `WIDTHxHEIGHT`, each side in `1..=MAX_SIDE`.
pub(crate) fn parse_size(text: &str) -> Result<(u32, u32), CliError> {
    let bad = |message: String| CliError::Arg {
        flag: "size",
        value: text.to_string(),
        message,
    };
    let (w, h) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| bad("expected WIDTHxHEIGHT, e.g. 1024x1024".into()))?;
    let side = |s: &str| match s.trim().parse::<u32>() {
        Ok(n) if (1..=MAX_SIDE).contains(&n) => Ok(n),
        _ => Err(bad(format!("{s:?} is not a side length in 1..={MAX_SIDE}"))),
    };
    Ok((side(w)?, side(h)?))
}

/// `0..3`.
pub(crate) fn parse_camera(text: &str) -> Result<usize, CliError> {
    match text.trim().parse::<usize>() {
        Ok(i) if i < 4 => Ok(i),
        _ => Err(CliError::Arg {
            flag: "camera",
            value: text.to_string(),
            message: "expected one of the thesis cameras 0, 1, 2 or 3 (or --eye and --at)".into(),
        }),
    }
}

/// `X,Y,Z`, finite.
fn parse_point(flag: &'static str, text: &str) -> Result<Vec3, CliError> {
    let v = crate::input::parse_list(flag, text)?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x as f32, y as f32, z as f32)),
        _ => Err(CliError::Arg {
            flag,
            value: text.to_string(),
            message: "expected three finite numbers X,Y,Z".into(),
        }),
    }
}

/// `--devices`: the list of [`raytrace::devices::parse_devices`], plus `cpu` alone for one
/// device with every core (the former default). GPU entries (`gpu:all`, `gpu:K`) open wgpu
/// adapters when the device list is built.
fn parse_devices(text: &str) -> Result<Vec<DeviceSpec>, CliError> {
    let bad = |message: String| CliError::Arg {
        flag: "devices",
        value: text.to_string(),
        message,
    };
    let specs = if text.trim() == "cpu" {
        let cores = std::thread::available_parallelism().map_or(1, usize::from);
        vec![DeviceSpec::Cpu {
            count: 1,
            threads: cores,
        }]
    } else {
        raytrace::devices::parse_devices(text).map_err(|e| bad(e.to_string()))?
    };
    let (mut devices, mut threads) = (0usize, 0usize);
    for spec in &specs {
        if let DeviceSpec::Cpu { count, threads: t } = *spec {
            devices = devices.saturating_add(count);
            threads = threads.max(t);
        }
    }
    let total = specs.iter().try_fold(0usize, |sum, spec| match *spec {
        DeviceSpec::Cpu { count, threads } => count.checked_mul(threads)?.checked_add(sum),
        DeviceSpec::Gpu(_) => Some(sum),
    });
    let max_threads = crate::limits::MAX_THREADS;
    if devices > MAX_DEVICES || threads > MAX_DEVICES || total.is_none_or(|t| t > max_threads) {
        return Err(bad(format!(
            "at most {MAX_DEVICES} devices, {MAX_DEVICES} threads per device and \
             {max_threads} threads in all"
        )));
    }
    Ok(specs)
}

/// `--task-size`: rays per task, in `1..=MAX_TASK_SIZE`.
fn parse_task_size(text: &str) -> Result<NonZeroUsize, CliError> {
    match text.trim().parse::<usize>() {
        Ok(n) if n <= MAX_TASK_SIZE => NonZeroUsize::new(n),
        _ => None,
    }
    .ok_or_else(|| CliError::Arg {
        flag: "task-size",
        value: text.to_string(),
        message: format!("expected a whole number of rays in 1..={MAX_TASK_SIZE}"),
    })
}

/// `--fail DEVICE@TASKS[,…]`, each device an index below `devices`.
fn parse_faults(text: &str, devices: usize) -> Result<Vec<FailAfter>, CliError> {
    let bad = |message: String| CliError::Arg {
        flag: "fail",
        value: text.to_string(),
        message,
    };
    text.split(',')
        .map(|item| {
            let (d, k) = item.trim().split_once('@').ok_or_else(|| {
                bad(format!(
                    "{item:?}: expected DEVICE@TASKS, e.g. 1@3 (device 1 fails after 3 tasks)"
                ))
            })?;
            let device = d
                .trim()
                .parse::<usize>()
                .map_err(|_| bad(format!("{d:?} is not a device index")))?;
            let tasks = k
                .trim()
                .parse::<u64>()
                .map_err(|_| bad(format!("{k:?} is not a task count")))?;
            if device >= devices {
                return Err(bad(format!(
                    "no device {device}: there are {devices} (numbered from 0)"
                )));
            }
            Ok(FailAfter { device, tasks })
        })
        .collect()
}
