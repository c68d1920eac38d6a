//! `cobalt estimate`: how well an estimate of each task's cost predicts its measured time,
//! and what estimating costs a render (see `raytrace::cost::metrics`).
//!
//! For one generation of rays cut into tasks it leads with the error and rank correlation of
//! the calibrated estimates against each task's measured single-thread trace time, beside
//! their bound (the real trace's own counts) and the net overhead; the thesis's prediction
//! error (against the walk's full count) and overhead (estimation time over the full trace
//! time, both on all cores) follow. On the CPU every walk is timed in the same rounds, so the
//! report holds the whole trade.
//!
//! [`Args`] are its arguments; [`run`] checks them, loads the scene and makes the rays ([`rays`]);
//! [`measure`] times the estimates against the tasks' traces; [`report`] holds the figures
//! and prints them as a table or one JSON object.

mod args;
mod measure;
mod rays;
mod report;

use raytrace::{Bvh, Camera, SceneSource};

use crate::error::CliError;
use rays::{RaySettings, RaySource};

pub use args::Args;

/// Runs the command: all arguments are checked before the scene is loaded.
pub fn run(args: Args) -> Result<(), CliError> {
    let source = RaySource::parse(&args.rays, args.ray_kind);

    let scene = SceneSource::parse(&args.scene.scene)?.load(source.needs())?;
    let bvh = Bvh::build(&scene, args.scene.preset)?;
    let camera = Camera::orbit(&scene.bounds(), args.camera);
    let settings = RaySettings {
        size: args.size,
        ao_samples: args.ao_samples,
        ao_distance: args.ao_distance,
    };
    let rays = source.generations(&scene, &bvh, camera, &settings)?;
    let report = measure::measure(&args, &scene, &bvh, rays)?;
    if args.json {
        crate::print::print_json(&report)
    } else {
        crate::print::print_text(&report.table())
    }
}
