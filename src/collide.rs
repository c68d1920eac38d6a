//! `cobalt collide`: contacts of many moving bodies (parry3d) with each other and a static
//! mesh, balanced over CPU devices in regular and cost mode.

use std::path::PathBuf;

use collision::{
    BroadPhaseCount, Device, SampleRate, Swarms, World, random_bodies, terrain, unit_cube_mesh,
};
use raytrace::SceneNeeds;
use sched::CostEstimator;
use sched::study::Workload;

use crate::args::{count, sample_rate};
use crate::error::CliError;
use crate::limits::memory;
use crate::spatial::RunArgs;

/// Arguments of `cobalt collide`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Moving bodies (balls, cuboids, convex hulls), half of them in swarms; 1..=2^24.
    #[arg(long, default_value_t = 20_000, value_parser = count::<{ 1 << 24 }>)]
    bodies: usize,
    /// Use this OBJ scene, scaled into the unit cube, as the static mesh.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Quads per side of the built-in terrain (two triangles each), 1..=8192.
    #[arg(long, default_value_t = 128, value_parser = count::<{ 1 << 13 }>)]
    terrain: usize,
    /// Bodies per task, 1..=2^24.
    #[arg(long, default_value_t = 128, value_parser = count::<{ 1 << 24 }>)]
    task_size: usize,
    /// Share of each task's bodies whose broad phase the estimator counts, in (0, 1].
    #[arg(long, default_value = "0.125", value_parser = sample_rate)]
    sample_rate: SampleRate,
    /// Seed of the bodies.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[command(flatten)]
    run: RunArgs,
}

/// Runs the command.
pub fn run(args: Args) -> Result<(), CliError> {
    // A body's shape (a convex hull at most), its pose, bounds and contacts.
    memory("bodies", &args.bodies.to_string(), &[(args.bodies, 1024)])?;
    if args.scene.is_none() {
        // Two triangles per quad, with the mesh's vertices, indices and BVH.
        let quads = args.terrain * args.terrain;
        memory("terrain", &args.terrain.to_string(), &[(quads, 2 * 128)])?;
    }
    let (mesh, source) = match &args.scene {
        Some(path) => {
            let scene = crate::limits::scene(&path.to_string_lossy())?.load(SceneNeeds::AO)?;
            let vertices: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
            let mesh = unit_cube_mesh(&vertices, scene.triangles).map_err(|e| CliError::Arg {
                flag: "scene",
                value: path.display().to_string(),
                message: e.to_string(),
            })?;
            (mesh, path.display().to_string())
        }
        None => (
            terrain(args.terrain).map_err(|e| CliError::Write(e.to_string()))?,
            format!("terrain {}", args.terrain),
        ),
    };
    let world = World::new(
        random_bodies(args.bodies, Swarms::default(), args.seed),
        mesh,
    );
    let world = &world;
    let work = Workload {
        name: format!(
            "collide {} bodies vs {source} ({} triangles)",
            world.len(),
            world.mesh.num_triangles()
        ),
        items: world.len(),
        task_size: args.task_size,
        tasks: sched::split_ranges(world.len(), args.task_size),
        estimate: Box::new(move |rate, tasks| {
            let e = BroadPhaseCount::new(world, rate).estimate_timed(tasks)?;
            Ok((e.costs.as_slice().to_vec(), e.seconds))
        }),
        devices: Box::new(move |n| Device::many(world, n)),
        check: Box::new(|_| Ok(())),
    };
    crate::spatial::run(&work, &args.run, args.sample_rate)
}
