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

/// Rounds of the interleaved comparison.
const REPS: usize = 3;

/// Best of two runs, to skip warm-up noise.
fn best<T>(f: impl Fn() -> T) -> (T, Duration) {
    let mut out = None;
    let mut best = Duration::MAX;
    for _ in 0..2 {
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
        let sub = Camera::thesis(&bounds, 0).primary_rays(size / 2, size / 2);
        let sub_hits = closest_hits(&bvh, &sub.rays);
        let radius = 0.05 * bounds.extent().length();
        let ao = ao::ao_rays(&scene, &sub.rays, &sub_hits, 32, radius, 1);

        // obvhs's CwBvh on the same rays, with its own (Möller–Trumbore) triangle test.
        let mut core = Duration::ZERO;
        let t = Instant::now();
        let cw = build_cwbvh_from_tris(&tris, preset.params(), &mut core);
        let cw_build = t.elapsed();
        let cw_trace = |rays: &RayBatch| -> usize {
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
        let ours_trace = |rays: &RayBatch| -> usize {
            let h = closest_hits(&bvh, rays);
            (0..h.len()).filter(|&i| h.get(i).is_some()).count()
        };

        // Interleaved repetitions, best of each: the machine is shared, and a burst of load
        // then hits both sides alike instead of one.
        let mut t = [Duration::MAX; 5];
        let mut n_hit = [0usize; 2];
        for _ in 0..REPS {
            let runs: [&dyn Fn() -> usize; 5] = [
                &|| ours_trace(&primary),
                &|| cw_trace(&primary),
                &|| ours_trace(&ao.rays),
                &|| cw_trace(&ao.rays),
                &|| {
                    let h = any_hits(&bvh, &ao.rays);
                    h.len()
                },
            ];
            for (k, run) in runs.iter().enumerate() {
                let (n, dt) = best(run);
                t[k] = t[k].min(dt);
                if k < 2 {
                    n_hit[k] = n;
                }
            }
        }
        let pct = |n: usize| 100.0 * n as f64 / primary.len() as f64;
        println!(
            "{:>9}: build {:.3} s (total {:.3} s), SAH {:.1}, {} nodes, depth {} | primary {:.2} MRays/s ({} rays, {:.0}% hit) | AO any {:.2}, closest {:.2} MRays/s ({} rays)",
            preset.name(),
            r.build_seconds,
            r.total_seconds,
            r.sah_cost,
            r.nodes,
            bvh.depth(),
            mrays(primary.len(), t[0]),
            primary.len(),
            pct(n_hit[0]),
            mrays(ao.rays.len(), t[4]),
            mrays(ao.rays.len(), t[2]),
            ao.rays.len(),
        );
        println!(
            "{:>9}  obvhs CwBvh: build {:.3} s | primary {:.2} MRays/s ({:.0}% hit) | AO closest {:.2} MRays/s | ours/obvhs primary {:.2}, AO closest {:.2}",
            "",
            cw_build.as_secs_f64(),
            mrays(primary.len(), t[1]),
            pct(n_hit[1]),
            mrays(ao.rays.len(), t[3]),
            t[1].as_secs_f64() / t[0].as_secs_f64(),
            t[3].as_secs_f64() / t[2].as_secs_f64(),
        );
    }
    Ok(())
}
