//! Whether AO tasks can be estimated at no traversal cost, from their parents: each AO ray's
//! primary ray's counts (nodes entered, triangles tested), summed over the task. Compared with
//! the default estimator (the trace walk of 12.5 % of each task's rays, in runs of 8) and
//! with the bound (the AO rays' own counts), all calibrated to the tasks' measured
//! single-thread times as `cobalt estimate` does.
//!
//! `cargo run --release -p raytrace --example ao_parents -- SCENE [SIZE]`
//!
//! The parents' counts are free only where the primary generation is traced counted: what
//! that costs beyond the uncounted primary trace, over the AO trace, is the parents' net
//! overhead, printed beside the default estimator's overhead (its sample's hits are reused, so
//! what it costs a render is less; `cobalt estimate` measures that).

use std::time::Instant;

use raytrace::cost::{
    ReducedTraversal, SampleRate, Work, calibrate, error_vs_time, measure_seconds, spearman,
};
use raytrace::{BuildPreset, Bvh, Camera, RayKind, SceneNeeds, SceneSource, Walk, traverse};

/// The wall time of one run of `f`.
fn timed(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let scene_arg = args.get(1).ok_or("usage: ao_parents SCENE [SIZE]")?;
    let size: u32 = match args.get(2) {
        Some(s) => s
            .parse()
            .map_err(|_| format!("size `{s}` is not a whole number"))?,
        None => 512,
    };
    let scene = SceneSource::parse(scene_arg)?.load(SceneNeeds::AO)?;
    let bvh = Bvh::build(&scene, BuildPreset::Medium)?;
    let primary = Camera::orbit(&scene.bounds(), 0)
        .primary_rays(size, size)
        .rays;
    let (hits, parent_counts) = traverse::closest_hits_counted(&bvh, &primary);
    // As `cobalt estimate --rays ao`: 32 probes a hit, 5 % of the scene's diagonal, seed 1.
    let length = 0.05 * scene.bounds().extent().length();
    let ao = raytrace::ao::ao_rays(&scene, &primary, &hits, 32, length, 1);
    let tasks = sched::split_ranges(ao.rays.len(), 4096);
    if tasks.len() < 2 {
        return Err("too few AO rays to cut into tasks; try a larger SIZE".into());
    }
    let seconds = measure_seconds(&bvh, &ao.rays, &tasks, RayKind::Ao, 3, sched::Clock::Wall)?;

    let own = traverse::any_hits_counted(&bvh, &ao.rays).1;
    let bound: Vec<Work> = tasks.iter().map(|r| Work::sum(&own[r.clone()])).collect();
    let parents: Vec<Work> = tasks
        .iter()
        .map(|r| {
            let counts: Vec<_> = r
                .clone()
                .map(|i| parent_counts[ao.source[i] as usize])
                .collect();
            Work::sum(&counts)
        })
        .collect();
    let estimator = ReducedTraversal::new(&bvh, &ao.rays, SampleRate::THESIS)
        .with_walk(Walk::Trace { any: true });
    let sampled = estimator.try_work(&tasks)?;
    let uniform: Vec<Work> = tasks
        .iter()
        .map(|r| Work {
            nodes: r.len() as f64,
            tris: 0.0,
            rays: r.len() as f64,
        })
        .collect();

    // Taken in turns, each the least of five: the AO trace, the primary trace uncounted and
    // counted, and the default estimate.
    let mut t = [f64::INFINITY; 4];
    for _ in 0..5 {
        let round = [
            timed(|| {
                std::hint::black_box(traverse::any_hits(&bvh, &ao.rays));
            }),
            timed(|| {
                std::hint::black_box(traverse::closest_hits(&bvh, &primary));
            }),
            timed(|| {
                std::hint::black_box(traverse::closest_hits_counted(&bvh, &primary));
            }),
            timed(|| {
                std::hint::black_box(estimator.try_work(&tasks).ok());
            }),
        ];
        for (t, r) in t.iter_mut().zip(round) {
            *t = t.min(r);
        }
    }
    let [ao_trace, plain, counted, estimate] = t;

    println!(
        "{scene_arg}: {} AO rays in {} tasks of 4096",
        ao.rays.len(),
        tasks.len()
    );
    println!("| estimate | error vs time | spearman | cost over the AO trace |");
    println!("|---|---:|---:|---:|");
    let rows = [
        ("bound: the AO rays' own counts", &bound, None),
        (
            "trace walk, 12.5 % in runs of 8",
            &sampled,
            Some(estimate / ao_trace),
        ),
        (
            "parents' counts (no traversal)",
            &parents,
            Some((counted - plain).max(0.0) / ao_trace),
        ),
        ("none (every task alike)", &uniform, Some(0.0)),
    ];
    for (name, work, cost) in rows {
        let fit = calibrate(work, &seconds)?;
        let costs = fit.model.costs(work);
        let error = error_vs_time(&costs, &seconds)?;
        // A constant estimate has no rank order.
        let rank = spearman(&costs, &seconds).map_or("–".to_string(), |r| format!("{r:.3}"));
        let cost = cost.map_or("–".to_string(), |c| format!("{:.1} %", 100.0 * c));
        println!("| {name} | {error:.3} | {rank} | {cost} |");
    }
    Ok(())
}
