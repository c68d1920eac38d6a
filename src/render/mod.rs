//! `cobalt render`: a scene, a camera and a shader in; a PNG, an optional cost image and a
//! JSON report out (see README.md, "cobalt render").
//!
//! The arguments are typed and checked by clap before anything runs; [`run`] checks what
//! depends on several flags, checks the output paths, loads the scene and hands it to the
//! render engine ([`paths`]), which returns the encoded outputs and the report, written all
//! together at the end.

mod paths;

use std::path::{Path, PathBuf};
use std::time::Instant;

#[cfg(feature = "mpi")]
use raytrace::distributed::render_over_ranks;
use raytrace::paths::{FailAfter, Settings, SlowBy};
#[cfg(feature = "mpi")]
use raytrace::paths::{Frame, build_path_devices};
use raytrace::run::Run;
use raytrace::shade::{RenderOptions, Shader};
use raytrace::{Bvh, Camera, Scene};

use crate::args::{
    CameraArgs, CameraChoice, ReportArgs, SceneArgs, ScheduleArgs, ShaderArgs, ShaderKind, Size,
};
use crate::error::CliError;
use crate::output::Outputs;
use paths::Header;

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
    /// Render this many frames through one renderer (each plans with the speeds measured on
    /// the ones before) and report the fastest.
    #[arg(long, default_value = "1", value_parser = clap::value_parser!(u32).range(1..=1000))]
    repeats: u32,
    /// Fault injection, `DEVICE@TASKS[,…]`: device DEVICE (0-based, in `--devices` order, a
    /// GPU included) fails after completing TASKS tasks; its unfinished tasks are re-run
    /// elsewhere.
    #[arg(long, value_delimiter = ',', value_parser = crate::args::fail_after)]
    fail: Vec<FailAfter>,
    /// Slowed devices, `DEVICE=K[,…]`: device DEVICE takes K times as long (it waits K − 1
    /// times each launch's busy time), to show devices of different speeds on equal cores.
    /// The image does not change.
    #[arg(long, value_delimiter = ',', value_parser = crate::args::slow_by)]
    slow: Vec<SlowBy>,
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
    let ao =
        (args.shader.shader == ShaderKind::Ao).then_some(("ao-samples", args.shader.ao_samples));
    crate::limits::frame(args.size, args.size.pixels(), ao)?;
    // GPU entries open however many adapters exist: the indices of faults on them are
    // checked once the devices are built (naming the fault).
    let faults = crate::args::check_faults(&args.fail, args.schedule.devices.known_count())?;
    let slow = crate::args::check_slow(&args.slow, args.schedule.devices.known_count())?;
    let settings = args.schedule.settings();
    let camera = args.camera.choice()?;
    let shader = args.shader.shader();

    // Under `mpirun`, every rank renders the same image together.
    #[cfg(feature = "mpi")]
    if sched::mpi::Cluster::launched() {
        return mpi(&args, shader, camera, &faults, settings);
    }

    let outputs = outputs(&args)?;
    // Read before the scene, so that a calibration file that cannot be used fails first.
    let store = args.calibration.open()?;
    let (scene, bvh, view, header) = load(&args, &shader, camera)?;
    let workload = raytrace::run::workload(&args.scene.scene, &shader);
    let options = RenderOptions::new(args.size.width, args.size.height, view, shader);
    let run = Run {
        frames: args.repeats,
        slow: &slow,
        ..one_frame(&args, &faults, settings)
    };
    let rendered = paths::render(
        &scene,
        &bvh,
        &options,
        (&run, args.schedule.devices.as_str()),
        (store, &workload),
        (header, args.cost_image.is_some()),
    )?;
    rendered.write(&outputs, args.output.json)
}

/// Checks every output path before any work: none may be an input (the scene, the
/// calibration) or another output, and the calibration may not be the scene.
fn outputs(args: &Args) -> Result<Outputs, CliError> {
    let scene = ("scene", Path::new(&args.scene.scene));
    let calibration = args.calibration.check(&[scene])?;
    let mut inputs = vec![scene];
    inputs.extend(calibration.as_deref().map(|c| ("calibration", c)));
    Outputs::check(
        &[
            ("out", Some(&args.out)),
            ("cost-image", args.cost_image.as_deref()),
            ("report", args.output.report.as_deref()),
        ],
        &inputs,
    )
}

/// One frame on `--devices` with `faults` and `settings`, finished on the host if every
/// device fails and `--host-fallback` allows it.
fn one_frame<'a>(args: &'a Args, faults: &'a [FailAfter], settings: Settings) -> Run<'a> {
    Run {
        specs: args.schedule.devices.specs(),
        faults,
        slow: &[],
        settings,
        frames: 1,
        host_fallback: args.host_fallback,
    }
}

/// Loads the scene and builds its BVH, and the report's header of a render of it: the scene
/// as given and as loaded, its tree, and the view.
fn load(
    args: &Args,
    shader: &Shader,
    camera: CameraChoice,
) -> Result<(Scene, Bvh, Camera, Header), CliError> {
    let loading = Instant::now();
    let scene = crate::limits::scene(&args.scene.scene)?.load(shader.needs())?;
    let load_seconds = loading.elapsed().as_secs_f64();
    let bvh = Bvh::build(&scene, args.scene.preset)?;
    let (view, camera_index) = camera.resolve(&scene);
    let (ao, whitted) = match shader {
        Shader::Ao(s) => {
            let distance = scene.length_to_source(s.distance(&scene));
            (Some((s.samples, distance)), None)
        }
        Shader::Whitted(s) => (None, Some(s.bounces)),
    };
    let header = Header {
        scene: args.scene.scene.clone(),
        triangles: scene.len(),
        shader: shader.name(),
        size: args.size.to_string(),
        width: args.size.width,
        height: args.size.height,
        camera: camera_index,
        eye: scene.to_source(view.eye).to_array(),
        at: scene.to_source(view.at).to_array(),
        preset: bvh.report().preset.name().to_string(),
        ao_samples: ao.map(|(samples, _)| samples),
        ao_distance: ao.map(|(_, distance)| distance),
        bounces: whitted,
        load_seconds,
        build_seconds: bvh.report().build_seconds,
    };
    Ok((scene, bvh, view, header))
}

/// `cobalt render` under `mpirun`: the flags a cluster cannot honour are refused, then every
/// rank renders the same image together ([`raytrace::distributed`]); rank 0 writes the PNG,
/// the report and the summary. Every fallible step before the render (checking rank 0's
/// outputs, loading the scene, opening this node's devices) ends with an agreement between
/// all ranks, so a failure on any rank ends every rank with an error naming the ranks at
/// fault, never a hang. One frame: `--repeats` is not offered over ranks.
#[cfg(feature = "mpi")]
fn mpi(
    args: &Args,
    shader: Shader,
    camera: CameraChoice,
    faults: &[FailAfter],
    settings: Settings,
) -> Result<(), CliError> {
    if let Some(path) = &args.cost_image {
        return Err(CliError::Arg {
            flag: "cost-image",
            value: path.display().to_string(),
            message: "not available under mpirun; render the cost image in one process".into(),
        });
    }
    if let Some(s) = args.slow.first() {
        return Err(CliError::Arg {
            flag: "slow",
            value: format!("{}={}", s.device, s.factor),
            message: "not available under mpirun; slow a device in one process".into(),
        });
    }
    let cluster = sched::mpi::Cluster::init()?;
    // Rank 0 writes every output, so they are checked before any rank starts work.
    let outputs = cluster.is_root().then(|| outputs(args));
    let outputs = cluster.agree("checking the outputs", outputs.transpose())?;
    let (scene, bvh, view, header) =
        cluster.agree("loading the scene", load(args, &shader, camera))?;
    let run = one_frame(args, faults, settings);
    let local = build_path_devices(&scene, &bvh, run.specs, run.faults, run.slow);
    let devices = cluster.agree("opening this rank's devices", local)?;
    let options = RenderOptions::new(args.size.width, args.size.height, view, shader);
    let frame = Frame {
        scene: &scene,
        bvh: &bvh,
        options: &options,
    };
    let device_list = args.schedule.devices.as_str();
    let rendered = render_over_ranks(&cluster, devices, settings, &frame, |renderer| {
        run.render_on(renderer, &scene, &bvh, &options, None)
    });
    let rendered = rendered.map_err(|e| CliError::run(device_list, e))?;
    // Only rank 0 has outputs and a frame: the others rendered what it sent them.
    let (Some(outputs), Some((film, report))) = (outputs, rendered) else {
        return Ok(());
    };
    let whole = (&run, device_list, &options.shader);
    let report = paths::RenderReport::new(header, whole, report, Default::default())
        .over_ranks(cluster.size());
    let rendered = paths::Rendered {
        image: film.png(raytrace::film::ToneMap::Srgb)?,
        cost_image: None,
        report,
    };
    rendered.write(&outputs, args.output.json)
}
