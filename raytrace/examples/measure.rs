//! Quick throughput measurement: build time and SAH per preset, closest-hit and AO MRays/s on
//! all cores, side by side with obvhs's own CwBvh traversal on the same rays.
//!
//! `cargo run --release -p raytrace --example measure -- [SCENE] [SIZE] [PRESETS]`
//! e.g. `-- builtin:forest 512 fastest,medium`.

use std::time::{Duration, Instant};

use raytrace::baseline::CwBvhBaseline;
use raytrace::traverse::{any_hits, closest_hits};
use raytrace::{BuildPreset, Bvh, RayBatch, SceneNeeds, SceneSource, workload};

/// Rounds of the interleaved comparison.
const REPS: usize = 3;

fn mrays(n: usize, d: Duration) -> f64 {
    n as f64 / d.as_secs_f64() / 1e6
}

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
    let primary = workload::orbit_primary(&scene, size, size, 0..4);

    for preset in presets {
        let bvh = Bvh::build(&scene, preset)?;
        let r = bvh.report();
        let ao = workload::orbit_ao(&scene, &bvh, size / 2, size / 2, 0, 32);
        let cw = CwBvhBaseline::build(&scene, preset);
        let hit_count =
            |h: raytrace::HitBatch| (0..h.len()).filter(|&i| h.get(i).is_some()).count();
        let ours = |rays: &RayBatch| hit_count(closest_hits(&bvh, rays));
        let theirs = |rays: &RayBatch| hit_count(cw.closest_hits(rays));

        // Interleaved repetitions, best of each: the machine is shared, and a burst of load
        // then hits both sides alike instead of one.
        let mut t = [Duration::MAX; 6];
        let mut n_hit = [0usize; 6];
        for _ in 0..REPS {
            let runs: [&dyn Fn() -> usize; 6] = [
                &|| ours(&primary),
                &|| theirs(&primary),
                &|| ours(&ao.rays),
                &|| theirs(&ao.rays),
                &|| hit_count(any_hits(&bvh, &ao.rays)),
                &|| cw.occluded(&ao.rays).into_iter().filter(|&o| o).count(),
            ];
            for (k, run) in runs.iter().enumerate() {
                let (n, dt) = best(run);
                t[k] = t[k].min(dt);
                n_hit[k] = n;
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
            "{:>9}  obvhs CwBvh: build {:.3} s | primary {:.2} MRays/s ({:.0}% hit) | AO any {:.2}, closest {:.2} MRays/s | ours/obvhs primary {:.2}, AO any {:.2}, AO closest {:.2} | AO occluded: ours {}, obvhs {}",
            "",
            cw.build_seconds,
            mrays(primary.len(), t[1]),
            pct(n_hit[1]),
            mrays(ao.rays.len(), t[5]),
            mrays(ao.rays.len(), t[3]),
            t[1].as_secs_f64() / t[0].as_secs_f64(),
            t[5].as_secs_f64() / t[4].as_secs_f64(),
            t[3].as_secs_f64() / t[2].as_secs_f64(),
            n_hit[4],
            n_hit[5],
        );
    }
    Ok(())
}
