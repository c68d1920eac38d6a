//! `cobalt estimate`: how well an estimate of each task's cost predicts its measured time,
//! and what estimating costs a render (measured by [`raytrace::estimate`]).
//!
//! For one generation of rays cut into tasks it leads with the error and rank correlation of
//! the calibrated estimates against each task's measured single-thread trace time, beside
//! their bound (the real trace's own counts) and the net overhead; the thesis's prediction
//! error (against the walk's full count) and overhead (estimation time over the full trace
//! time, both on all cores) follow. On the CPU every walk is timed in the same rounds, so the
//! report holds the whole trade.
//!
//! [`Args`] are its arguments; [`run`] checks them, loads the scene, makes the rays `--rays`
//! asks for (camera, AO, a Whitted render's generations or a ray file), has the library
//! measure, and prints the report as a table or one JSON object.

mod args;

use std::path::Path;

use raytrace::cost::SampleRun;
use raytrace::estimate::{Device, Generations, Settings, WalkChoice};
use raytrace::{Bvh, Camera, RayKind, SceneNeeds, Walk};

use crate::args::Size;
use crate::error::CliError;
use crate::trace::Device as DeviceArg;

pub use args::Args;

/// Runs the command: all arguments are checked before the scene is loaded, and the rays
/// before anything is timed.
pub fn run(args: Args) -> Result<(), CliError> {
    // A Whitted render's generations need the scene's materials.
    let needs = if args.rays == "whitted" {
        SceneNeeds::WHITTED
    } else {
        SceneNeeds::AO
    };
    let scene = crate::limits::scene(&args.scene.scene)?.load(needs)?;
    let bvh = Bvh::build(&scene, args.scene.preset)?;
    let camera = Camera::orbit(&scene.bounds(), args.camera);
    let Size { width, height } = args.size;
    let rays = match args.rays.as_str() {
        "primary" => Generations::of(camera.primary_rays(width, height).rays, RayKind::Primary),
        "ao" => Generations::ao(
            (&scene, &bvh),
            &camera,
            (width, height),
            args.ao_samples,
            args.ao_distance,
        ),
        "whitted" => Generations::whitted((&scene, &bvh), camera, width, height),
        path => {
            let mut rays = crate::trace::read_rays(Path::new(path))?;
            scene.rays_to_scene(&mut rays);
            Generations::of(rays, args.ray_kind)
        }
    };
    if rays.segments.iter().all(|(batch, _)| batch.is_empty()) {
        return Err(CliError::Arg {
            flag: "rays",
            value: args.rays.clone(),
            message: "there are no rays to estimate (no primary ray hit the scene?)".into(),
        });
    }
    let settings = checked(&args)?;
    let sample = [(args.sample_rate, args.sample_error.0)];
    let mut reports = raytrace::estimate::measure(&settings, (&scene, &bvh), &rays, &sample)?;
    let report = reports.swap_remove(0);
    if args.json {
        crate::print::print_json(&report)
    } else {
        crate::print::print_text(&report.table())
    }
}

/// The measurement's settings, where the flags agree with each other and the system.
fn checked(args: &Args) -> Result<Settings<'_>, CliError> {
    // The real trace where it can run: its hits are the render's, so it costs little more
    // than counting, and it stops where the trace stops, which the reduced traversals do not.
    let walk = args.walk.unwrap_or(match args.device {
        DeviceArg::Cpu => WalkChoice::Fixed(Walk::Trace { any: false }),
        DeviceArg::Gpu => WalkChoice::Fixed(Walk::Reduced),
    });
    let gpu = args.device == DeviceArg::Gpu;
    let refused = |flag: &'static str, value: String, message: String| CliError::Arg {
        flag,
        value,
        message,
    };
    if let (WalkChoice::Fixed(Walk::Trace { .. }), true) = (walk, gpu) {
        let message =
            "the `trace` walk runs on the CPU only; use reduced or first-leaf with --device gpu";
        return Err(refused("walk", "trace".into(), message.into()));
    }
    if args.clock != sched::Clock::Wall && gpu {
        let message = "a GPU's work is not the host's CPU time; use --clock wall with --device gpu";
        return Err(refused("clock", args.clock.to_string(), message.into()));
    }
    if !args.clock.is_available() {
        let message = "this system has no process CPU clock; use --clock wall";
        return Err(refused("clock", args.clock.to_string(), message.into()));
    }
    if args.sample_run != SampleRun::DEFAULT && gpu {
        let message = format!(
            "the GPU estimator samples in runs of {}; other runs are measured on the CPU",
            SampleRun::DEFAULT
        );
        return Err(refused("sample-run", args.sample_run.to_string(), message));
    }
    Ok(Settings {
        scene: &args.scene.scene,
        task_size: args.task_size,
        sample_run: args.sample_run,
        clock: args.clock,
        repeats: args.repeats,
        budget: raytrace::cost::Budget::estimate(args.repeats),
        device: if gpu { Device::Gpu } else { Device::Cpu },
        walk,
    })
}
