//! Writes what `scripts/embree-compare` needs to trace a scene with Embree on the rays cobalt
//! traces: the scene's triangles as loaded (built-in scenes included) and its primary and AO
//! rays in `cobalt trace`'s ray format.
//!
//! `cargo run --release -p raytrace --example embree_inputs -- SCENE DIR [SIZE] [AO_SAMPLES]`
//! writes `DIR/vertices.f32` (`f32 × 3` per vertex), `DIR/triangles.u32` (`u32 × 3` per
//! triangle, file order, degenerate ones included, so indices are `cobalt trace`'s `prim`),
//! `DIR/primary.rays` (SIZE × SIZE camera rays) and `DIR/ao.rays` (AO_SAMPLES rays from each
//! hit of a SIZE/2 × SIZE/2 image), all little-endian.

use std::path::{Path, PathBuf};

use raytrace::{BuildPreset, Bvh, RayBatch, SceneNeeds, SceneSource, workload};

fn write(path: &Path, words: impl Iterator<Item = [u8; 4]>) -> Result<(), String> {
    let bytes: Vec<u8> = words.flatten().collect();
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

fn rays(path: &Path, rays: &RayBatch) -> Result<(), String> {
    let words = (0..rays.len()).flat_map(|i| {
        let r = rays.get(i);
        let (o, d) = (r.origin, r.dir);
        [o.x, o.y, o.z, d.x, d.y, d.z, r.tmin, r.tmax].map(f32::to_le_bytes)
    });
    write(path, words)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(scene_arg), Some(dir)) = (args.get(1), args.get(2)) else {
        return Err("usage: embree_inputs SCENE DIR [SIZE] [AO_SAMPLES]".into());
    };
    let size: u32 = args.get(3).map_or(Ok(512), |s| s.parse())?;
    let samples: u32 = args.get(4).map_or(Ok(8), |s| s.parse())?;
    let dir = PathBuf::from(dir);
    let scene = SceneSource::parse(scene_arg)?.load(SceneNeeds::AO)?;
    let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
    let primary = workload::orbit_primary(&scene, size, size, 0..1);
    let ao = workload::orbit_ao(&scene, &bvh, size / 2, size / 2, 0, samples);
    let vertices = scene
        .positions
        .iter()
        .flat_map(|p| p.to_array().map(f32::to_le_bytes));
    write(&dir.join("vertices.f32"), vertices)?;
    let tris = scene.triangles.iter().flat_map(|t| t.map(u32::to_le_bytes));
    write(&dir.join("triangles.u32"), tris)?;
    rays(&dir.join("primary.rays"), &primary)?;
    rays(&dir.join("ao.rays"), &ao.rays)?;
    println!(
        "{scene_arg}: {} triangles, {} primary rays, {} AO rays",
        scene.len(),
        primary.len(),
        ao.rays.len()
    );
    Ok(())
}
