//! Quick throughput measurement: build time and SAH per preset, closest-hit and AO MRays/s on
//! all cores, side by side with obvhs's own CwBvh traversal on the same rays.
//!
//! `cargo run --release -p raytrace --example measure -- [SCENE] [SIZE] [PRESETS]`
//! e.g. `-- builtin:forest 512 fastest,medium`.

use std::time::{Duration, Instant};

use glam::Vec3A;
use obvhs::{cwbvh::builder::build_cwbvh_from_tris, ray::RayHit, triangle::Triangle};
use rayon::prelude::*;
use raytrace::traverse::{any_hits, closest_hits};
use raytrace::{BuildPreset, Bvh, Camera, RayBatch, SceneNeeds, SceneSource, ao};

fn mrays(n: usize, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64() / 1e6
}

/// Best of three runs, to skip warm-up noise.
fn best<T>(mut f: impl FnMut() -> T) -> (T, Duration) {
    let mut out = None;
    let mut best = Duration::MAX;
    for _ in 0..3 {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed());
        out = Some(r);
    }
    (out.expect("ran"), best)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene_arg = args.get(1).map_or("builtin:forest", String::as_str);
    let size: u32 = args.get(2).map_or(Ok(512), |s| s.parse())?;
    let presets: Vec<BuildPreset> = match args.get(3) {
        Some(s) => s.split(',').map(str::parse).collect::<Result<_, _>>()?,
        None => vec![
            BuildPreset::Fastest,
            BuildPreset::Medium,
            BuildPreset::VerySlow,
        ],
    };
    let t = Instant::now();
    let scene = SceneSource::parse(scene_arg)?.load(SceneNeeds::AO)?;
    println!(
        "{scene_arg}: {} triangles ({} degenerate), loaded in {:.2} s, {} threads",
        scene.len(),
        scene.report.degenerate,
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    let bounds = scene.bounds();
    let mut primary = RayBatch::default();
    for cam in 0..4 {
        let p = Camera::thesis(&bounds, cam).primary_rays(size, size);
        for i in 0..p.rays.len() {
            primary.push(&p.rays.get(i));
        }
    }
    let tris: Vec<Triangle> = (0..scene.len())
        .map(|i| {
            let [a, b, c] = scene.vertices(i).map(Vec3A::from);
            Triangle {
                v0: a,
                v1: b,
                v2: c,
            }
        })
        .collect();

    for preset in presets {
        let bvh = Bvh::build(&scene, preset)?;
        let r = bvh.report();
        let (hits, dt) = best(|| closest_hits(&bvh, &primary));
        let n_hit = (0..hits.len()).filter(|&i| hits.get(i).is_some()).count();
        let sub = Camera::thesis(&bounds, 0).primary_rays(size / 2, size / 2);
        let sub_hits = closest_hits(&bvh, &sub.rays);
        let radius = 0.05 * bounds.extent().length();
        let ao = ao::ao_rays(&scene, &sub.rays, &sub_hits, 32, radius, 1);
        let (_, dt_ao) = best(|| any_hits(&bvh, &ao.rays));
        let (_, dt_ao_closest) = best(|| closest_hits(&bvh, &ao.rays));
        println!(
            "{:>9}: build {:.3} s (total {:.3} s), SAH {:.1}, {} nodes, depth {} | primary {:.2} MRays/s ({} rays, {:.0}% hit) | AO any {:.2}, closest {:.2} MRays/s ({} rays)",
            preset.name(),
            r.build_seconds,
            r.total_seconds,
            r.sah_cost,
            r.nodes,
            bvh.depth(),
            mrays(primary.len(), dt),
            primary.len(),
            100.0 * n_hit as f64 / primary.len() as f64,
            mrays(ao.rays.len(), dt_ao),
            mrays(ao.rays.len(), dt_ao_closest),
            ao.rays.len(),
        );

        // obvhs's CwBvh on the same rays, with its own (Möller–Trumbore) triangle test.
        let mut core = Duration::ZERO;
        let t = Instant::now();
        let cw = build_cwbvh_from_tris(&tris, preset.params(), &mut core);
        let cw_build = t.elapsed();
        let trace = |rays: &RayBatch| -> usize {
            (0..rays.len())
                .into_par_iter()
                .with_min_len(256)
                .filter(|&i| {
                    let r = rays.get(i);
                    let ray = obvhs::ray::Ray::new(r.origin.into(), r.dir.into(), r.tmin, r.tmax);
                    let mut hit = RayHit::none();
                    cw.ray_traverse(ray, &mut hit, |ray, id| {
                        tris[cw.primitive_indices[id] as usize].intersect(ray)
                    })
                })
                .count()
        };
        let (cw_hits, cw_dt) = best(|| trace(&primary));
        let (_, cw_dt_ao) = best(|| trace(&ao.rays));
        println!(
            "{:>9}  obvhs CwBvh: build {:.3} s | primary {:.2} MRays/s ({:.0}% hit) | AO closest {:.2} MRays/s | ours/obvhs primary {:.2}, AO closest {:.2}",
            "",
            cw_build.as_secs_f64(),
            mrays(primary.len(), cw_dt),
            100.0 * cw_hits as f64 / primary.len() as f64,
            mrays(ao.rays.len(), cw_dt_ao),
            cw_dt.as_secs_f64() / dt.as_secs_f64(),
            cw_dt_ao.as_secs_f64() / dt_ao_closest.as_secs_f64(),
        );
    }
    Ok(())
}
