//! `cobalt render`: a scene, a camera and a shader in; a PNG, an optional cost image and a
//! JSON report of every generation of rays out (DESIGN.md, "Command line").
//!
//! Tracing runs on one CPU device for now; `--policy`, `--task-size` and `--sample-rate`
//! arrive with the scheduler behind [`raytrace::shade::Tracer`].

use std::path::PathBuf;
use std::time::Instant;

use raytrace::cost_image::{cost_image, max_counts};
use raytrace::film::ToneMap;
use raytrace::glam::Vec3;
use raytrace::shade::{
    AoSettings, CpuTracer, RenderOptions, Rendering, Shader, WhittedSettings, render,
};
use raytrace::{BuildPreset, Bvh, Camera, SceneSource};
use serde::Serialize;

use crate::error::CliError;

/// Largest image side: keeps a typo like `--size 1024000x1` from allocating gigabytes.
const MAX_SIDE: u32 = 16384;

/// Which shader.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShaderArg {
    /// Ambient occlusion: Halton probes per hit (the diffuse workload).
    Ao,
    /// Whitted: shadow rays and two mirror bounces (the coherent workload).
    Whitted,
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
    /// Devices: `cpu` (all cores) or `cpu:N` (a pool of N threads). GPUs are not built yet.
    #[arg(long, default_value = "cpu")]
    devices: String,
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
}

#[derive(Debug, Serialize)]
struct GenerationReport {
    kind: &'static str,
    bounce: u32,
    rays: usize,
    /// Trace time alone.
    seconds: f64,
    mrays_per_s: f64,
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
    scene: String,
    triangles: usize,
    shader: &'static str,
    size: String,
    width: u32,
    height: u32,
    camera: Option<usize>,
    eye: [f32; 3],
    at: [f32; 3],
    devices: String,
    threads: usize,
    preset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    ao_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ao_distance: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    bounces: Option<u32>,
    load_seconds: f64,
    build_seconds: f64,
    generations: Vec<GenerationReport>,
    total_rays: usize,
    /// Sum of the generations' trace times.
    trace_seconds: f64,
    /// Wall time of the render: ray generation, tracing and shading.
    render_seconds: f64,
    /// Rendering efficiency (thesis): total rays over `render_seconds`.
    mrays_per_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    cost: Option<CostReport>,
}

/// Where the camera comes from.
enum CameraChoice {
    Thesis(usize),
    LookAt(Vec3, Vec3),
}

/// Runs the command: every argument is checked before the scene is loaded, and nothing is
/// written until the render is done.
pub fn run(args: Args) -> Result<(), CliError> {
    let (width, height) = parse_size(&args.size)?;
    let threads = parse_devices(&args.devices)?;
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

    let loading = Instant::now();
    let scene = SceneSource::parse(&args.scene)?.load(shader.needs())?;
    let load_seconds = loading.elapsed().as_secs_f64();
    let bvh = Bvh::build(&scene, preset)?;
    let mut tracer = match threads {
        Some(n) => CpuTracer::with_threads(&bvh, n)?,
        None => CpuTracer::new(&bvh),
    };
    let (camera, camera_index) = match camera_choice {
        CameraChoice::Thesis(i) => (Camera::thesis(&scene.bounds(), i), Some(i)),
        CameraChoice::LookAt(eye, at) => (Camera::look_at(eye, at), None),
    };
    let mut options = RenderOptions::new(width, height, camera, shader);
    options.count_primary = args.cost_image.is_some();
    let rendering = render(&scene, &mut tracer, &options);

    // Encode everything first, so a failure leaves no partial set of outputs.
    let image = rendering.film.png(ToneMap::Srgb)?;
    let cost_png = match (&args.cost_image, &rendering.primary_counts) {
        (Some(_), Some(counts)) => Some(cost_image(counts, width, height).png(ToneMap::Display)?),
        _ => None,
    };
    let report = Report {
        scene: args.scene.clone(),
        triangles: scene.len(),
        shader: shader.name(),
        size: format!("{width}x{height}"),
        width,
        height,
        camera: camera_index,
        eye: camera.eye.to_array(),
        at: camera.at.to_array(),
        devices: args.devices.clone(),
        threads: tracer.threads(),
        preset: preset.name().to_string(),
        ao_samples: matches!(shader, Shader::Ao(_)).then_some(samples),
        ao_distance: match shader {
            Shader::Ao(s) => Some(s.distance(&scene)),
            Shader::Whitted(_) => None,
        },
        bounces: match shader {
            Shader::Whitted(s) => Some(s.bounces),
            Shader::Ao(_) => None,
        },
        load_seconds,
        build_seconds: bvh.report().build_seconds,
        generations: generation_reports(&rendering),
        total_rays: rendering.total_rays(),
        trace_seconds: rendering.trace_seconds(),
        render_seconds: rendering.seconds,
        mrays_per_s: rendering.mrays_per_s(),
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

    crate::write_file(&args.out, &image)?;
    if let (Some(path), Some(png)) = (&args.cost_image, &cost_png) {
        crate::write_file(path, png)?;
    }
    if let Some(path) = &args.report {
        crate::write_file(path, format!("{report_json}\n").as_bytes())?;
    }
    if args.json {
        crate::print_json(&report)
    } else {
        crate::print_text(&summary(&report))
    }
}

fn generation_reports(r: &Rendering) -> Vec<GenerationReport> {
    r.generations
        .iter()
        .map(|g| GenerationReport {
            kind: g.kind.name(),
            bounce: g.bounce,
            rays: g.rays,
            seconds: g.seconds,
            mrays_per_s: g.mrays_per_s(),
        })
        .collect()
}

fn summary(r: &Report) -> String {
    let mut s = format!(
        "{} {} of {} ({} triangles) on {} thread(s): {} rays in {:.3} s, {:.2} MRays/s\n",
        r.shader,
        r.size,
        r.scene,
        r.triangles,
        r.threads,
        r.total_rays,
        r.render_seconds,
        r.mrays_per_s
    );
    for g in &r.generations {
        s += &format!(
            "  {:<10} bounce {}  {:>10} rays  {:.4} s  {:.2} MRays/s\n",
            g.kind, g.bounce, g.rays, g.seconds, g.mrays_per_s
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

/// The CPU device's thread count (`None`: all cores). Several devices and GPUs come with the
/// scheduler and the wgpu pipeline.
fn parse_devices(text: &str) -> Result<Option<usize>, CliError> {
    let bad = |message: &str| CliError::Arg {
        flag: "devices",
        value: text.to_string(),
        message: message.to_string(),
    };
    let items: Vec<&str> = text.split(',').map(str::trim).collect();
    if items.iter().any(|d| d.starts_with("gpu")) {
        return Err(bad(
            "the GPU pipeline is not built yet (issue 5); use cpu or cpu:N",
        ));
    }
    let [item] = items[..] else {
        return Err(bad(
            "one device for now: cpu or cpu:N (several devices come with the scheduler)",
        ));
    };
    match item.split_once(':') {
        None if item == "cpu" => Ok(None),
        Some(("cpu", n)) => match n.parse::<usize>() {
            Ok(n) if (1..=1024).contains(&n) => Ok(Some(n)),
            _ => Err(bad(&format!("{n:?} is not a thread count in 1..=1024"))),
        },
        _ => Err(bad("expected cpu or cpu:N")),
    }
}
