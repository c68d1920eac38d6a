//! Ray throughput on all cores, in MRays/s (criterion's "elem/s"), side by side with obvhs's own
//! CwBvh traversal on the same rays: closest-hit primary rays of the thesis's four cameras, and
//! 32-sample AO rays (any-hit, and closest-hit) from one camera's hits. Scenes: `builtin:forest`
//! and, when present, `../shared/scenes/conference.obj`.
//!
//! `load/SCENE` times bringing a scene into range (`Scene::normalise`) beside loading it whole.
//!
//! Run: `cargo bench --bench raytrace` (filter with e.g. `-- conference`); each group prints
//! both traversals' throughput, so the ratio to obvhs is read from one run.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use raytrace::baseline::CwBvhBaseline;
use raytrace::traverse::{any_hits, closest_hits};
use raytrace::{BuildPreset, Bvh, SceneNeeds, SceneSource, testkit, workload};
use std::hint::black_box;

fn scenes() -> Vec<(String, String)> {
    let mut s = vec![("forest".to_string(), "builtin:forest".to_string())];
    if let Some(p) = testkit::shared_scene("conference.obj") {
        s.push(("conference".into(), p.display().to_string()));
    }
    s
}

fn trace(c: &mut Criterion) {
    for (name, source) in scenes() {
        let scene = SceneSource::parse(&source)
            .and_then(|s| s.load(SceneNeeds::AO))
            .expect("bench scene loads");
        let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("bvh builds");
        let cw = CwBvhBaseline::build(&scene, BuildPreset::Medium);
        let primary = workload::orbit_primary(&scene, 256, 256, 0..4);
        let ao = workload::orbit_ao(&scene, &bvh, 128, 128, 0, 32).rays;

        let mut g = c.benchmark_group(format!("trace/{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(primary.len() as u64));
        g.bench_function("primary/cobalt", |b| {
            b.iter(|| closest_hits(&bvh, black_box(&primary)))
        });
        g.bench_function("primary/obvhs-cwbvh", |b| {
            b.iter(|| cw.closest_hits(black_box(&primary)))
        });
        g.throughput(Throughput::Elements(ao.len() as u64));
        g.bench_function("ao-any/cobalt", |b| {
            b.iter(|| any_hits(&bvh, black_box(&ao)))
        });
        g.bench_function("ao-any/obvhs-cwbvh", |b| {
            b.iter(|| cw.occluded(black_box(&ao)))
        });
        g.bench_function("ao-closest/cobalt", |b| {
            b.iter(|| closest_hits(&bvh, black_box(&ao)))
        });
        g.bench_function("ao-closest/obvhs-cwbvh", |b| {
            b.iter(|| cw.closest_hits(black_box(&ao)))
        });
        g.finish();
    }
}

/// What bringing a scene into range costs on loading (`Scene::normalise`, one pass to find the
/// largest coordinate and one to scale), beside loading it whole.
fn normalise(c: &mut Criterion) {
    for (name, source) in scenes() {
        let source = SceneSource::parse(&source).expect("bench scene");
        let scene = source.load(SceneNeeds::AO).expect("bench scene loads");
        let mut g = c.benchmark_group(format!("load/{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(scene.positions.len() as u64));
        g.bench_function("normalise", |b| {
            b.iter(|| black_box(scene.clone()).normalise())
        });
        g.bench_function("load", |b| {
            b.iter(|| source.load(black_box(SceneNeeds::AO)))
        });
        g.finish();
    }
}

criterion_group!(benches, trace, normalise);
criterion_main!(benches);
