//! Writes what `scripts/embree-compare` needs to trace a scene with Embree on the rays cobalt
//! traces: the scene's triangles as loaded (built-in scenes included) and its primary and AO
//! rays in `cobalt trace`'s ray format.
//!
//! `cargo run --release -p raytrace --example embree_inputs -- SCENE DIR [SIZE] [AO_SAMPLES]`
//! writes `DIR/vertices.f32` (`f32 × 3` per vertex), `DIR/triangles.u32` (`u32 × 3` per
//! triangle, file order, degenerate ones included, so indices are `cobalt trace`'s `prim`),
//! `DIR/primary.rays` (SIZE × SIZE camera rays), `DIR/ao.rays` (AO_SAMPLES rays from each
//! hit of a SIZE/2 × SIZE/2 image, each hit's probes in a run) and `DIR/ao_random.rays` (4
//! rays from each hit of that image, their directions scrambled per hit, in a shuffled order:
//! no ray shares its neighbours' origin), all little-endian and in the scene file's units
//! (`cobalt trace` scales rays as its loader scales the scene).

use std::path::{Path, PathBuf};

use raytrace::{BuildPreset, Bvh, RayBatch, Scene, SceneNeeds, SceneSource, workload};

fn write(path: &Path, words: impl Iterator<Item = [u8; 4]>) -> Result<(), String> {
    let bytes: Vec<u8> = words.flatten().collect();
    std::fs::write(path, bytes).map_err(|e| format!("{}: {e}", path.display()))
}

fn rays(path: &Path, scene: &Scene, rays: &RayBatch, order: &[usize]) -> Result<(), String> {
    let words = order.iter().flat_map(|&i| {
        let r = rays.get(i);
        let (o, d) = (r.origin, r.dir);
        let s = |v: f32| scene.length_to_source(v).to_le_bytes();
        [o.x, o.y, o.z, d.x, d.y, d.z]
            .map(s)
            .into_iter()
            .chain([r.tmin, r.tmax].map(f32::to_le_bytes))
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
    let random = workload::orbit_ao(&scene, &bvh, size / 2, size / 2, 0, 4).rays;
    // A fixed shuffle: the rays sorted by a hash (SplitMix64's finalizer) of their index.
    let mut shuffled: Vec<usize> = (0..random.len()).collect();
    shuffled.sort_by_key(|&i| {
        let z = (i as u64 ^ 0x9E37_79B9_7F4A_7C15).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB)
    });
    let vertices = scene.positions.iter().flat_map(|p| {
        p.to_array()
            .map(|v| scene.length_to_source(v).to_le_bytes())
    });
    write(&dir.join("vertices.f32"), vertices)?;
    let tris = scene.triangles.iter().flat_map(|t| t.map(u32::to_le_bytes));
    write(&dir.join("triangles.u32"), tris)?;
    let all = |b: &RayBatch| (0..b.len()).collect::<Vec<_>>();
    rays(&dir.join("primary.rays"), &scene, &primary, &all(&primary))?;
    rays(&dir.join("ao.rays"), &scene, &ao.rays, &all(&ao.rays))?;
    rays(&dir.join("ao_random.rays"), &scene, &random, &shuffled)?;
    println!(
        "{scene_arg}: {} triangles, {} primary rays, {} AO rays, {} shuffled AO rays",
        scene.len(),
        primary.len(),
        ao.rays.len(),
        random.len()
    );
    Ok(())
}
