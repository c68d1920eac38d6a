//! GPU against CPU on the same rays: hits (closest and any), reduced-traversal counts, the
//! launch split by binding limits, and the errors for limits that cannot be met.
//!
//! Without an adapter a test prints one note and passes, except where the environment
//! variable `CI` is set: there a missing adapter fails the test (CI installs lavapipe, so a
//! skip would hide a broken setup). Run with `WGPU_BACKEND=vulkan`.

use std::sync::Once;

use glam::Vec3;
use sched::CostEstimator;

use super::buffers::{GpuRay, SceneBuffers};
use super::staging::staged;
use super::trace::{BATCHES, CLOSEST, MAX_WORKGROUPS, TraceDevice};
use super::{GpuContext, GpuDevice, GpuError, GpuOptions, GpuRenderer};
use crate::cost::{CountRays, ReducedTraversal, SampleRate, full_work};
use crate::devices::GpuSelect;
use crate::shade::{AoSettings, CpuTracer, RenderOptions, Shader, WhittedSettings, render};
use crate::{BuildPreset, Bvh, Camera, HitBatch, Ray, RayBatch, Rng, SceneNeeds, SceneSource};
use crate::{testkit, traverse, workload};

/// The first adapter (software ones included), or `None` with a note when there is none
/// outside CI.
pub(crate) fn gpu() -> Option<GpuContext> {
    static NOTE: Once = Once::new();
    match GpuContext::open(
        GpuSelect::All,
        GpuOptions {
            allow_software: true,
        },
    ) {
        Ok(mut all) if !all.is_empty() => Some(all.swap_remove(0)),
        Ok(_) => unreachable!("open returns an error rather than no adapter"),
        Err(e) => {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI is set but no GPU adapter could be opened (install mesa-vulkan-drivers, \
                 run with WGPU_BACKEND=vulkan): {e}"
            );
            NOTE.call_once(|| eprintln!("note: no GPU adapter ({e}); GPU tests skipped"));
            None
        }
    }
}

/// A second open of the same selection shares the first's device: NVIDIA's driver found no
/// adapter after about 30 opens in one process (see `GpuContext::open`).
#[test]
fn adapters_are_opened_once_per_process() {
    let (Some(a), Some(b)) = (gpu(), gpu()) else {
        return;
    };
    assert!(a.same_device(&b));
}

fn scene_bvh(name: &str) -> Bvh {
    testkit::builtin_with_bvh(name).expect("built-in scene").1
}

/// What a raw launch needs on `ctx`: the kernels and buffers of `name`'s tree, and the rays
/// of `rays_for(name, seed)`.
fn launch_kit(ctx: &GpuContext, name: &str, seed: u64) -> (TraceDevice, RayBatch) {
    let bvh = scene_bvh(name);
    let dev = TraceDevice::with_layout(ctx.clone(), &bvh, crate::Layout::Binary)
        .expect("kernels and upload");
    (dev, rays_for(name, seed))
}

/// Camera rays of the four orbit cameras, AO rays from camera 0's hits, and random rays
/// (origins in and around the scene, random directions, some with a finite range), plus a few
/// degenerate ones (NaN, zero direction, empty range).
fn rays_for(name: &str, seed: u64) -> RayBatch {
    let scene = SceneSource::parse(name)
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let mut rays = workload::orbit_primary(&scene, 24, 24, 0..4);
    rays.extend(&workload::orbit_ao(&scene, &bvh, 12, 12, 0, 8).rays);
    let b = scene.bounds();
    let mut rng = Rng::new(testkit::seed(seed));
    for k in 0..1500 {
        let o = Vec3::new(
            rng.range(b.min.x, b.max.x),
            rng.range(b.min.y, b.max.y),
            rng.range(b.min.z, b.max.z),
        ) * 1.2;
        let tmax = if k % 3 == 0 {
            rng.range(0.0, b.extent().length() * 0.3)
        } else {
            f32::INFINITY
        };
        rays.push(&Ray::with_range(
            o,
            Vec3::from(rng.unit_vector()),
            0.0,
            tmax,
        ));
    }
    // Axis-aligned directions (zero components of both signs hit the NaN-slab rules).
    for d in [
        Vec3::X,
        -Vec3::Y,
        Vec3::new(0.0, -0.0, 1.0),
        Vec3::new(-0.0, 1.0, 0.0),
    ] {
        rays.push(&Ray::new(b.center(), d));
    }
    rays.push(&Ray::new(Vec3::NAN, Vec3::X));
    rays.push(&Ray::new(b.center(), Vec3::ZERO));
    rays.push(&Ray::with_range(b.center(), Vec3::Y, 2.0, 1.0));
    rays
}

/// Compares hits ray by ray: equal ids and distances within 1e-5 relative. A differing id is
/// accepted only at an equal distance (an exact-edge tie, which the CPU decides in f64 and the
/// GPU in f32) and for at most 1 in 1000 rays; each one is printed.
fn assert_same_hits(what: &str, cpu: &HitBatch, gpu: &HitBatch) {
    assert_eq!(cpu.len(), gpu.len(), "{what}: result counts");
    let mut ties = 0;
    for i in 0..cpu.len() {
        let (c, g) = (cpu.get(i), gpu.get(i));
        match (c, g) {
            (None, None) => {}
            (Some((tc, pc)), Some((tg, pg))) => {
                let close = (tc - tg).abs() <= 1e-5 * tc.abs().max(tg.abs());
                assert!(
                    close,
                    "{what}: ray {i}: CPU t={tc} prim {pc}, GPU t={tg} prim {pg}"
                );
                if pc != pg {
                    ties += 1;
                    eprintln!("{what}: ray {i}: tie at t={tc}: CPU prim {pc}, GPU prim {pg}");
                }
            }
            _ => panic!("{what}: ray {i}: CPU {c:?}, GPU {g:?}"),
        }
    }
    assert!(
        ties * 1000 <= cpu.len(),
        "{what}: {ties} id mismatches of {} rays",
        cpu.len()
    );
}

/// One device's launches reuse its buffers, growing them when a launch needs more: a small
/// launch, every ray, scattered ranges, and scattered ranges again under a binding limit low
/// enough to cut them into several launches, each equal to the CPU's hits of the same rays.
#[test]
fn launches_of_every_size_reuse_the_buffers() {
    let Some(ctx) = gpu() else { return };
    let name = "builtin:cornell:0.2";
    let bvh = scene_bvh(name);
    let rays = rays_for(name, 16);
    let n = rays.len();
    let cpu = traverse::closest_hits(&bvh, &rays);
    let pick = |ranges: &[&std::ops::Range<usize>]| {
        let mut want = HitBatch::misses(0);
        for r in ranges {
            want.t.extend_from_slice(&cpu.t[(*r).clone()]);
            want.prim.extend_from_slice(&cpu.prim[(*r).clone()]);
        }
        want
    };
    let (small, all, a, b) = (0..100, 0..n, 5..n / 3, n / 2..n - 7);
    let dev = GpuDevice::new(ctx, &bvh).expect("upload");
    for ranges in [&[&small][..], &[&all], &[&a, &b], &[&small]] {
        let got = dev.hits(false, &rays, ranges).expect("GPU hits");
        assert_same_hits(&format!("{ranges:?}"), &pick(ranges), &got);
    }
    // A binding of exactly the rays (the scene's own buffers must still fit it), and ranges
    // holding more than that between them.
    let Some(mut ctx) = gpu() else { return };
    ctx.limits.max_storage_buffer_binding_size = (n * size_of::<GpuRay>()) as u64;
    let dev = GpuDevice::new(ctx, &bvh).expect("the scene fits the rays' binding");
    let (a, b) = (5..n - 3, 0..n / 2);
    let got = dev
        .hits(false, &rays, &[&a, &b])
        .expect("GPU hits in several launches");
    assert_same_hits("several launches", &pick(&[&a, &b]), &got);
}

fn check_scene(name: &str, seed: u64) {
    let Some(ctx) = gpu() else { return };
    let bvh = scene_bvh(name);
    let rays = rays_for(name, seed);
    let n = rays.len();
    let dev = GpuDevice::new(ctx, &bvh).expect("upload");
    let all = 0..n;
    let closest = dev.hits(false, &rays, &[&all]).expect("GPU closest hits");
    // Timestamp queries time the kernels where the device has them.
    let seconds = dev.last_gpu_seconds();
    assert_eq!(seconds.is_some(), dev.context().timestamps);
    assert!(seconds.is_none_or(|s| s > 0.0 && s < 10.0), "{seconds:?}");
    assert_same_hits(
        &format!("{name} closest"),
        &traverse::closest_hits(&bvh, &rays),
        &closest,
    );
    let any = dev.hits(true, &rays, &[&all]).expect("GPU any hits");
    // An any-hit query returns the first hit its walk finds: the GPU walks the binary tree,
    // so the binary tree's CPU walk finds the same one (the wide tree's may find another).
    assert_same_hits(
        &format!("{name} any"),
        &traverse::hits_in(&bvh, &rays, true, traverse::Layout::Binary),
        &any,
    );
    let index: Vec<usize> = all.clone().collect();
    for walk in [crate::Walk::Reduced, crate::Walk::FirstLeaf] {
        let counts = dev.count_at(&rays, walk, &index).expect("GPU counts").1;
        let want = traverse::reduced_counts(&bvh, &rays, walk, all.clone());
        let bad: Vec<usize> = (0..n).filter(|&i| counts[i] != want[i]).collect();
        assert!(
            bad.is_empty(),
            "{name} {walk:?}: {} of {n} counts differ, first ray {}: CPU {:?} GPU {:?}",
            bad.len(),
            bad[0],
            want[bad[0]],
            counts[bad[0]]
        );
    }
    let counts = dev
        .count_at(&rays, crate::Walk::Reduced, &index)
        .expect("GPU counts")
        .1;
    // Some rays hit, some miss, and the counts are not trivial.
    let hits = closest
        .prim
        .iter()
        .filter(|&&p| p != HitBatch::MISS)
        .count();
    assert!(hits > n / 10 && hits < n, "{name}: {hits} hits of {n}");
    assert!(counts.iter().map(|c| c.tris).sum::<u32>() > n as u32);
}

#[test]
fn cornell_hits_and_counts_equal_cpu() {
    check_scene("builtin:cornell:0.2", 11);
}

#[test]
fn forest_hits_and_counts_equal_cpu() {
    check_scene("builtin:forest:0.05", 12);
}

/// The compressed wide layout finds every ray's hit as the binary layout does, bit for bit
/// (both kernels decide in f32 by the same rules), and the CPU's within `assert_same_hits`;
/// its any hits agree on hit or miss; its reduced walk counts wide nodes, no more than the
/// binary tree's; and it refuses the first-leaf walk.
fn check_wide(name: &str, bvh: &Bvh, rays: &RayBatch) {
    let (Some(a), Some(b)) = (gpu(), gpu()) else {
        return;
    };
    let n = rays.len();
    let all = 0..n;
    let binary = GpuDevice::with_layout(a, bvh, crate::Layout::Binary).expect("upload");
    let wide = GpuDevice::with_layout(b, bvh, crate::Layout::Wide).expect("upload");
    assert_eq!(wide.layout(), crate::Layout::Wide);
    let want = binary
        .hits(false, rays, &[&all])
        .expect("binary closest hits");
    let got = wide.hits(false, rays, &[&all]).expect("wide closest hits");
    for i in 0..n {
        assert_eq!(
            (want.t[i].to_bits(), want.prim[i]),
            (got.t[i].to_bits(), got.prim[i]),
            "{name}: ray {i}: binary against wide closest hit"
        );
    }
    assert_same_hits(
        &format!("{name} wide closest"),
        &traverse::closest_hits(bvh, rays),
        &got,
    );
    let cpu_any = traverse::hits_in(bvh, rays, true, traverse::Layout::Wide);
    let any = wide.hits(true, rays, &[&all]).expect("wide any hits");
    for i in 0..n {
        assert_eq!(
            cpu_any.prim[i] == HitBatch::MISS,
            any.prim[i] == HitBatch::MISS,
            "{name}: ray {i}: any hit or miss"
        );
    }
    let index: Vec<usize> = all.clone().collect();
    let count = |dev: &GpuDevice| -> u64 {
        let c = dev
            .count_at(rays, crate::Walk::Reduced, &index)
            .expect("GPU counts")
            .1;
        c.iter().map(|c| u64::from(c.nodes)).sum()
    };
    let (nb, nw) = (count(&binary), count(&wide));
    assert!(
        nw > 0 && nw <= nb,
        "{name}: {nw} wide nodes against {nb} binary"
    );
    assert!(matches!(
        wide.count_at(rays, crate::Walk::FirstLeaf, &index),
        Err(GpuError::LayoutUnsupported { .. })
    ));
}

#[test]
fn wide_layout_hits_equal_binary_and_cpu() {
    for (name, seed) in [
        ("builtin:cornell:0.2", 21),
        ("builtin:forest:0.05", 22),
        ("builtin:hairball:0.02", 23),
    ] {
        let bvh = scene_bvh(name);
        check_wide(name, &bvh, &rays_for(name, seed));
    }
}

#[test]
fn wide_layout_hits_equal_binary_on_random_scenes() {
    let mut rng = Rng::new(testkit::seed(24));
    for n in [1, 5, 64, 2000] {
        let scene = testkit::random_triangles(&mut rng, n, 10.0, 1.0);
        let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
        let mut rays = workload::orbit_primary(&scene, 16, 16, 0..2);
        rays.extend(&workload::orbit_ao(&scene, &bvh, 8, 8, 0, 4).rays);
        check_wide(&format!("{n} random triangles"), &bvh, &rays);
    }
}

/// A launch larger than the (lowered) binding limit is split into several, with the same
/// results; a scene beyond it is refused with the limit's name; ranges are concatenated.
#[test]
fn splits_launches_and_names_the_limit() {
    let Some(ctx) = gpu() else { return };
    let (mut dev, rays) = launch_kit(&ctx, "builtin:cornell:0.2", 13);
    let bvh = scene_bvh("builtin:cornell:0.2");
    let (a, b) = (0..1000, 1500..rays.len());
    let run = |dev: &TraceDevice, ranges: &[&std::ops::Range<usize>]| {
        let mut traffic = crate::Traffic::default();
        let mut staging = None;
        let mode = CLOSEST;
        staged(&mut staging, dev, &rays, ranges, mode, &mut traffic)
            .expect("launch")
            .0
    };
    let whole = run(&dev, &[&a, &b]);
    // 640 rays a launch: several launches, the last one partial.
    dev.ctx.limits.max_storage_buffer_binding_size = 640 * size_of::<GpuRay>() as u64;
    assert_eq!(whole, run(&dev, &[&a, &b]));
    let cpu = traverse::closest_hits(&bvh, &rays);
    let mut want = HitBatch::misses(0);
    let mut got = HitBatch::misses(0);
    for (k, i) in a.clone().chain(b.clone()).enumerate() {
        want.t.push(cpu.t[i]);
        want.prim.push(cpu.prim[i]);
        got.t.push(f32::from_bits(whole[k][0]));
        got.prim.push(whole[k][1]);
    }
    // Exact-distance ties may go to another triangle on the GPU (see `assert_same_hits`).
    assert_same_hits("split launches", &want, &got);
    let e = SceneBuffers::upload(&dev.ctx, &bvh).expect_err("nodes beyond the limit");
    assert!(matches!(e, GpuError::TooLarge { .. }), "{e:?}");
    assert!(
        e.to_string().contains("max_storage_buffer_binding_size"),
        "{e}"
    );
    // Empty launches return nothing.
    assert!(run(&dev, &[]).is_empty());
}

/// Throughput on the first adapter against the CPU (all cores), for forest primary and AO
/// rays:
/// `cargo test -p raytrace --features gpu --lib gpu::tests::throughput -- --ignored
/// --nocapture`. Wall time includes the rays' upload and the results' read-back; kernel time
/// is from timestamp queries where the device has them. Each figure is the best of three.
#[test]
#[ignore = "a measurement, not a check"]
fn throughput() {
    let Some(ctx) = gpu() else { return };
    let name = ctx.info.name.clone();
    let scene = SceneSource::parse("builtin:forest")
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let dev = GpuDevice::new(ctx, &bvh).expect("upload");
    let primary = workload::orbit_primary(&scene, 512, 512, [0]);
    let ao = workload::orbit_ao(&scene, &bvh, 256, 256, 0, 8).rays;
    for (what, rays, any) in [("primary", &primary, false), ("ao", &ao, true)] {
        let all = 0..rays.len();
        let mrays = |s: f64| rays.len() as f64 / s / 1e6;
        let t = std::time::Instant::now();
        let c = if any {
            traverse::any_hits(&bvh, rays)
        } else {
            traverse::closest_hits(&bvh, rays)
        };
        let cpu_s = t.elapsed().as_secs_f64();
        eprintln!(
            "forest {} tris, {what}: {} rays; CPU ({} threads) {:.2} MRays/s",
            scene.len(),
            rays.len(),
            rayon::current_num_threads(),
            mrays(cpu_s),
        );
        dev.hits(any, rays, &[&all]).expect("warm-up");
        let (mut wall, mut kernel) = (f64::INFINITY, f64::INFINITY);
        let mut same = 0;
        for _ in 0..3 {
            let t = std::time::Instant::now();
            let g = dev.hits(any, rays, &[&all]).expect("GPU");
            wall = wall.min(t.elapsed().as_secs_f64());
            kernel = kernel.min(dev.last_gpu_seconds().unwrap_or(f64::NAN));
            same = (0..rays.len()).filter(|&i| g.prim[i] == c.prim[i]).count();
        }
        eprintln!(
            "  GPU ({name}) {:.2} MRays/s wall, {:.2} MRays/s kernels; same ids {same}",
            mrays(wall),
            mrays(kernel),
        );
    }
}

/// What the path kernels read per ray on each tree, and how long a launch takes, printed by
/// `cargo test -p raytrace --features gpu --lib gpu::tests::path_node_bytes -- --nocapture`
/// (`COBALT_MEASURE_SCENE` adds a scene, e.g. a path to an OBJ file); the check is the
/// compressed wide tree's promise, at most 0.6 times the binary tree's node bytes per ray
/// in AO and Whitted frames alike. Every
/// path of a 256 × 256 frame is counted (an estimate at rate 1 by the trace walk: `B` nodes
/// fetched, `T` triangles tested, by the closest- and any-hit walks the render runs), and the
/// bytes are `B` times a fetch's (64 for the binary tree's sibling pair, 80 for a compressed
/// wide node); rays are the render's. Wall time is the best of three renders of the frame.
#[test]
fn path_node_bytes() {
    let Some(ctx) = gpu() else { return };
    let mut names = vec![
        "builtin:cornell".to_string(),
        "builtin:forest:0.2".to_string(),
    ];
    names.extend(std::env::var("COBALT_MEASURE_SCENE").ok());
    for name in names {
        let (scene, bvh) = testkit::builtin_with_bvh(&name).expect("scene");
        let camera = Camera::orbit(&scene.bounds(), 0);
        let ao = Shader::Ao(AoSettings {
            samples: 8,
            ..AoSettings::default()
        });
        for shader in [ao, Shader::Whitted(WhittedSettings::default())] {
            let options = RenderOptions::new(256, 256, camera, shader);
            let all = 0..256 * 256;
            let mut per_layout = [0.0; 2];
            for (k, layout) in [crate::Layout::Binary, crate::Layout::Wide]
                .into_iter()
                .enumerate()
            {
                let r =
                    GpuRenderer::with_layout(ctx.clone(), &scene, &bvh, layout).expect("renderer");
                let trace = crate::Walk::Trace { any: false };
                let work = r
                    .sample_paths(&options, &[&all], SampleRate::FULL, trace)
                    .expect("estimate")
                    .work[0];
                let mut wall = f64::INFINITY;
                let mut rays = 0;
                for _ in 0..3 {
                    let t = std::time::Instant::now();
                    rays = r.render(&options, &[&all]).expect("render").rays;
                    wall = wall.min(t.elapsed().as_secs_f64());
                }
                let bytes = match layout {
                    crate::Layout::Binary => 64.0,
                    crate::Layout::Wide => 80.0,
                };
                let per_ray = |x: f64| x / rays as f64;
                per_layout[k] = per_ray(work.nodes * bytes);
                eprintln!(
                    "{name} {} {}: {rays} rays, {:.1} nodes/ray, {:.0} node bytes/ray, \
                     {:.1} tris/ray, {:.0} ms",
                    shader.name(),
                    layout.name(),
                    per_ray(work.nodes),
                    per_ray(work.nodes * bytes),
                    per_ray(work.tris),
                    wall * 1e3,
                );
            }
            let [binary, wide] = per_layout;
            assert!(
                wide > 0.0 && wide <= 0.6 * binary,
                "{name} {}: {wide:.0} node bytes a ray on the wide tree, {binary:.0} on the \
                 binary one",
                shader.name()
            );
        }
    }
}

/// The estimator counted on the GPU counts the CPU's sample exactly: every sampled ray's
/// counts equal the CPU's, and so does the scaled work, bit for bit, for primary and AO rays,
/// several task sizes (a last task shorter than the rest, tasks of one ray) and every thesis
/// rate.
fn check_estimates(name: &str) {
    let Some(ctx) = gpu() else { return };
    let scene = SceneSource::parse(name)
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let dev = GpuDevice::new(ctx, &bvh).expect("upload");
    let primary = workload::orbit_primary(&scene, 64, 64, [1]);
    let ao = workload::orbit_ao(&scene, &bvh, 32, 32, 0, 8).rays;
    for (what, rays) in [("primary", &primary), ("ao", &ao)] {
        assert!(rays.len() > 4000, "{name} {what}: {} rays", rays.len());
        for size in [1, 100, 512, 4096] {
            let tasks = sched::split_ranges(rays.len(), size);
            for rate in [0.125, 0.25, 0.5, 1.0] {
                let rate = SampleRate::new(rate).expect("rate");
                let at = format!("{name} {what}, tasks of {size}, rate {}", rate.get());
                // The CPU's sample: the rays its trace walk traced.
                let trace = crate::Walk::Trace { any: false };
                let cpu = ReducedTraversal::new(&bvh, rays, rate).with_walk(trace);
                let sampled = cpu.try_sample(&tasks).expect("CPU sample").traced;
                let sample = sampled.expect("the sample's hits").index;
                let gpu = dev
                    .count_at(rays, crate::Walk::Reduced, &sample)
                    .expect("GPU counts");
                let cpu = traverse::reduced_counts_at(&bvh, rays, crate::Walk::Reduced, &sample);
                assert_eq!(gpu, (None, cpu), "{at}");
                let cpu_work = ReducedTraversal::new(&bvh, rays, rate)
                    .try_work(&tasks)
                    .expect("CPU estimate");
                let gpu_work = ReducedTraversal::new(&dev, rays, rate)
                    .try_work(&tasks)
                    .expect("GPU estimate");
                assert_eq!(gpu_work, cpu_work, "{at}");
                // The first-leaf walk too (camera rays only: AO rays never use it).
                if what == "primary" {
                    let walk = crate::Walk::FirstLeaf;
                    let cpu = ReducedTraversal::new(&bvh, rays, rate).with_walk(walk);
                    let gpu = ReducedTraversal::new(&dev, rays, rate).with_walk(walk);
                    assert_eq!(gpu.try_work(&tasks).ok(), cpu.try_work(&tasks).ok(), "{at}");
                }
                if rate == SampleRate::FULL {
                    assert_eq!(
                        gpu_work,
                        full_work(&bvh, rays, &tasks, crate::Walk::Reduced).expect("full"),
                        "{at}"
                    );
                }
            }
        }
        // The estimate is not trivial: the rays see the scene.
        let one = 0..rays.len();
        let all = ReducedTraversal::new(&dev, rays, SampleRate::FULL)
            .try_work(std::slice::from_ref(&one))
            .expect("one task");
        assert!(all[0].nodes > all[0].rays, "{name} {what}: {all:?}");
    }
}

#[test]
fn cornell_estimates_equal_cpu() {
    check_estimates("builtin:cornell:0.2");
}

#[test]
fn forest_estimates_equal_cpu() {
    check_estimates("builtin:forest:0.05");
}

/// Bad tasks are refused before anything runs, naming the task, and so is the trace walk; as
/// a `sched` estimator the GPU's costs are the CPU's, and a failure gives NaN costs that
/// `estimate_timed` rejects.
#[test]
fn estimator_refuses_bad_tasks_and_serves_sched() {
    let Some(ctx) = gpu() else { return };
    let scene = SceneSource::parse("builtin:cornell:0.2")
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let dev = GpuDevice::new(ctx, &bvh).expect("upload");
    let rays = workload::orbit_primary(&scene, 32, 32, [0]);
    let n = rays.len();
    let rate = SampleRate::THESIS;
    let gpu = ReducedTraversal::new(&dev, &rays, rate);
    let e = gpu.try_work(&[0..10, 10..10]).expect_err("empty task");
    assert!(e.to_string().contains("task 1 is empty"), "{e}");
    let e = gpu
        .try_work(&[0..10, 5..n + 1])
        .expect_err("beyond the batch");
    assert!(e.to_string().contains("task 1"), "{e}");
    let e = gpu
        .with_walk(crate::Walk::Trace { any: false })
        .try_work(&[0..10, 10..20])
        .expect_err("the trace walk");
    assert!(matches!(e, GpuError::WalkUnsupported { .. }), "{e}");
    // A task beyond the 46 340 rays the device's u32 sample arithmetic once allowed is
    // sampled like any other, exactly as the CPU samples it.
    let long: RayBatch = (0..50_000)
        .map(|i| Ray::new(Vec3::new(0.0, 0.0, i as f32 * 1e-4), Vec3::X))
        .collect();
    let tasks = [0..1, 1..long.len()];
    let gpu_long = ReducedTraversal::new(&dev, &long, rate)
        .try_work(&tasks)
        .expect("a long task");
    let cpu = ReducedTraversal::new(&bvh, &long, rate)
        .try_work(&tasks)
        .expect("a long task");
    assert_eq!(gpu_long, cpu);
    assert!(gpu.try_work(&[]).expect("none").is_empty());
    let tasks = sched::split_ranges(n, 128);
    let gpu_costs = gpu.estimate_timed(&tasks).expect("GPU costs");
    let cpu = ReducedTraversal::new(&bvh, &rays, rate)
        .estimate_timed(&tasks)
        .expect("CPU costs");
    assert_eq!(gpu_costs.costs, cpu.costs);
    let bad = gpu.estimate_timed(&[0..1, 1..1]);
    assert!(
        matches!(bad, Err(sched::SchedError::BadCost { task: 1, .. })),
        "{bad:?}"
    );
}

/// A persistent launch of more rays than one pass covers runs in several passes, of which only
/// the first and the last write a timestamp (wgpu refuses a pass whose writes name neither):
/// three passes here, where an H100's AO launches took 32. Every ray is still traced once.
#[test]
fn a_launch_of_three_passes_is_timed_and_traced_whole() {
    let Some(ctx) = gpu() else { return };
    let (dev, rays) = launch_kit(&ctx, "builtin:cornell:0.2", 15);
    let pass = (MAX_WORKGROUPS * BATCHES * 64) as usize;
    let mut many = RayBatch::with_capacity(2 * pass + 65);
    for i in 0..2 * pass + 65 {
        many.push(&rays.get(i % rays.len()));
    }
    let run = |rays: &RayBatch| {
        let mut staging = None;
        let all = 0..rays.len();
        let mut traffic = crate::Traffic::default();
        staged(
            &mut staging,
            &dev,
            rays,
            &[&all],
            crate::Walk::Reduced,
            &mut traffic,
        )
        .expect("launch")
    };
    let (one, _) = run(&rays);
    let (out, seconds) = run(&many);
    assert_eq!(seconds.is_some(), ctx.timestamps);
    assert_eq!(out.len(), many.len());
    for (i, r) in out.iter().enumerate() {
        assert_eq!(*r, one[i % one.len()], "ray {i}");
    }
}

/// Whether `ctx` must reproduce the CPU's arithmetic bit for bit. Software adapters (lavapipe)
/// do; a hardware driver may fuse `a * b + c` into one rounding (naga marks no operation
/// `NoContraction`), so there results agree only within rounding: about half of a Whitted
/// image's pixels may move by about 1e-7.
fn bit_exact(ctx: &GpuContext) -> bool {
    ctx.info.device_type == wgpu::DeviceType::Cpu
}

/// The GPU's primary rays are the CPU's in the same Morton order, for square, wide and
/// odd-sized images: bit for bit on a software adapter, within a few ulps on hardware.
#[test]
fn raygen_equals_cpu_primary_rays() {
    let Some(ctx) = gpu() else { return };
    let exact = bit_exact(&ctx);
    let scene = SceneSource::parse("builtin:cornell:0.2")
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let renderer = GpuRenderer::new(ctx, &scene, &bvh).expect("renderer");
    for (w, h, cam) in [(64, 64, 0), (128, 32, 1), (37, 23, 2), (1, 5, 3)] {
        let camera = Camera::orbit(&scene.bounds(), cam);
        let cpu = camera.primary_rays(w, h);
        let n = cpu.rays.len();
        // Two tasks, the later one first: a launch's slots follow its task list.
        let (late, early) = (n / 3..n, 0..n / 3);
        let frame = RenderOptions::new(w, h, camera, Shader::Ao(AoSettings::default()));
        let (rays, ranks) = renderer
            .primary_rays(&frame, &[&late, &early])
            .expect("raygen");
        let order: Vec<u32> = late
            .clone()
            .chain(early.clone())
            .map(|r| r as u32)
            .collect();
        assert_eq!(ranks, order, "{w}x{h}: ranks");
        let want: Vec<GpuRay> = late
            .clone()
            .chain(early.clone())
            .map(|i| GpuRay::of(&cpu.rays, i))
            .collect();
        if exact {
            assert_eq!(rays, want, "{w}x{h}: rays");
            continue;
        }
        assert_eq!(rays.len(), want.len());
        // Worst difference of a component, relative to the larger of it and 1.
        let worst = rays
            .iter()
            .zip(&want)
            .flat_map(|(g, c)| g.org.iter().chain(&g.dir).zip(c.org.iter().chain(&c.dir)))
            .map(|(&g, &c)| {
                if g == c {
                    0.0
                } else {
                    (g - c).abs() / c.abs().max(1.0)
                }
            })
            .fold(0.0_f32, f32::max);
        eprintln!("{w}x{h}: worst ray component differs by {worst}");
        assert!(worst <= 1e-5, "{w}x{h}: a ray differs by {worst}");
    }
}

/// Every path of `options`' image rendered on `renderer` in one launch of three tasks of
/// uneven sizes, listed out of order, and placed at their pixels.
fn gpu_film(
    renderer: &GpuRenderer,
    options: &RenderOptions,
) -> Result<(crate::Film, crate::paths::Launch), GpuError> {
    let (w, h) = (options.width, options.height);
    let n = (w * h) as usize;
    let tasks = [n / 2..n, 0..n / 7, n / 7..n / 2];
    let refs: Vec<&std::ops::Range<usize>> = tasks.iter().collect();
    let out = renderer.render(options, &refs)?;
    let order = crate::camera::morton_order(w, h);
    let mut film = crate::Film::new(w, h);
    for (rank, &v) in tasks.iter().flat_map(|t| t.clone()).zip(&out.values) {
        film.set(order[rank] as usize, v);
    }
    Ok((film, out))
}

/// The GPU's AO image against `shade::render` with the same settings. Both compute in f32 with
/// the same operations; they may differ where `cos`/`sin` round differently (a walk direction
/// moves by an ulp) or at an exact-edge tie, and a walk that changes its verdict moves its
/// pixel by 1/samples. Tolerance: at most 1 % of pixels differ at all, none by more than
/// 2/samples, and the mean absolute difference is at most 1e-3. With `split`, the binding
/// limit is lowered to the primary rays' size, so the walks go in several chunks.
fn check_ao_image(name: &str, samples: u32, split: bool) {
    let Some(mut ctx) = gpu() else { return };
    let scene = SceneSource::parse(name)
        .and_then(|s| s.load(SceneNeeds::AO))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    // Large enough that the scene's buffers fit the lowered limit.
    let (w, h) = if split { (96, 64) } else { (64, 48) };
    if split {
        ctx.limits.max_storage_buffer_binding_size = u64::from(w * h) * size_of::<GpuRay>() as u64;
    }
    let renderer = GpuRenderer::new(ctx, &scene, &bvh).expect("renderer");
    let camera = Camera::orbit(&scene.bounds(), 1);
    let settings = AoSettings {
        samples,
        seed: 7,
        ..AoSettings::default()
    };
    let options = RenderOptions::new(w, h, camera, Shader::Ao(settings));
    let cpu = render(&scene, &mut CpuTracer::new(&bvh), &options).film;
    let (gpu, _) = gpu_film(&renderer, &options).expect("GPU render");
    let diffs: Vec<f32> = cpu
        .pixels()
        .iter()
        .zip(gpu.pixels())
        .map(|(c, g)| (c.x - g.x).abs())
        .collect();
    let differ = diffs.iter().filter(|&&d| d > 0.0).count();
    let worst = diffs.iter().copied().fold(0.0, f32::max);
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    eprintln!(
        "{name}, {samples} probes: {differ} of {} pixels differ, worst {worst}, mean {mean}",
        diffs.len()
    );
    assert!(
        differ * 100 <= diffs.len(),
        "{name}: {differ} pixels differ"
    );
    assert!(
        worst <= 2.0 / samples as f32 + 1e-6,
        "{name}: worst {worst}"
    );
    assert!(mean <= 1e-3, "{name}: mean {mean}");
    // The image is not trivial: some pixels are occluded, some open.
    let grey: Vec<f32> = gpu.pixels().iter().map(|p| p.x).collect();
    assert!(grey.iter().any(|&v| v < 0.9) && grey.contains(&1.0));
    if split {
        // Under the lowered limit the materials and normals do not fit: AO renders without
        // them, Whitted is refused naming them.
        let whitted = RenderOptions::new(w, h, camera, Shader::Whitted(WhittedSettings::default()));
        let e = gpu_film(&renderer, &whitted).expect_err("materials beyond the limit");
        assert!(e.to_string().contains("materials and normals"), "{e}");
    }
}

#[test]
fn cornell_ao_image_matches_cpu() {
    check_ao_image("builtin:cornell:0.2", 8, false);
    check_ao_image("builtin:cornell:0.2", 5, true);
}

#[test]
fn forest_ao_image_matches_cpu() {
    check_ao_image("builtin:forest:0.05", 8, false);
}

/// The GPU's Whitted image against `shade::render` with the same settings (two bounces):
/// both compute in f32 with the same operations and the same order of additions per pixel, so
/// they differ only at an exact-edge tie (a different triangle, or a shadow or mirror ray
/// spawned from it), and on hardware by rounding (see `bit_exact`). Tolerance: at most 1 % of
/// pixels differ by more than rounding, and the mean absolute difference per channel is at
/// most 1e-3. With `bent`, the scene gets vertex normals and a
/// second light.
fn check_whitted_image(name: &str, bent: bool) {
    let Some(ctx) = gpu() else { return };
    let shader = Shader::Whitted(WhittedSettings::default());
    let mut scene = SceneSource::parse(name)
        .and_then(|s| s.load(shader.needs()))
        .expect("built-in scene");
    if bent {
        // Vertex normals leaning off the faces (so shading normals are interpolated, some past
        // the surface) and a second, coloured light.
        let mut rng = Rng::new(testkit::seed(21));
        let normals = (0..scene.positions.len())
            .map(|_| (Vec3::Y + 0.6 * Vec3::from(rng.unit_vector())).normalize_or(Vec3::Y))
            .collect();
        scene.normals = Some(normals);
        let b = scene.bounds();
        scene.lights.push(crate::Light::Point {
            position: b.center() + Vec3::new(0.3, 0.45, -0.2) * b.extent(),
            intensity: Vec3::new(0.8, 0.5, 0.3) * b.extent().length_squared(),
        });
    }
    let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
    let renderer = GpuRenderer::new(ctx, &scene, &bvh).expect("renderer");
    let (w, h) = (64, 48);
    let camera = Camera::orbit(&scene.bounds(), 2);
    let options = RenderOptions::new(w, h, camera, shader);
    let cpu = render(&scene, &mut CpuTracer::new(&bvh), &options);
    let (gpu, _) = gpu_film(&renderer, &options).expect("GPU render");
    let diffs: Vec<f32> = cpu
        .film
        .pixels()
        .iter()
        .zip(gpu.pixels())
        .map(|(c, g)| (*c - *g).abs().max_element())
        .collect();
    // Rounding (see `bit_exact`) moves a pixel by far less than this; a tie that picks
    // another triangle or flips a shadow moves it by far more.
    let rounding = if bit_exact(&renderer.dev.ctx) {
        0.0
    } else {
        1e-4
    };
    let differ = diffs.iter().filter(|&&d| d > rounding).count();
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let worst = diffs.iter().copied().fold(0.0, f32::max);
    eprintln!(
        "{name} Whitted: {differ} of {} pixels differ by more than {rounding} (worst {worst}), \
         mean {mean}; {} lights, CPU {} rays",
        diffs.len(),
        scene.lights.len(),
        cpu.total_rays()
    );
    assert!(
        differ * 100 <= diffs.len(),
        "{name}: {differ} pixels differ"
    );
    assert!(mean <= 1e-3, "{name}: mean {mean}");
    // The image is not trivial: shadow rays and mirror rays were traced, and lit.
    assert!(cpu.generations.len() >= 3, "{:?}", cpu.generations);
    let distinct: std::collections::BTreeSet<u32> =
        gpu.pixels().iter().map(|p| p.x.to_bits()).collect();
    assert!(
        distinct.len() > 50,
        "{name}: {} distinct values",
        distinct.len()
    );
}

#[test]
fn cornell_whitted_image_matches_cpu() {
    check_whitted_image("builtin:cornell:0.2", false);
    check_whitted_image("builtin:cornell:0.2", true);
}

#[test]
fn forest_whitted_image_matches_cpu() {
    check_whitted_image("builtin:forest:0.05", false);
}

/// One GPU through `sched`'s path renderer: the image is the one the device's kernels give
/// (the CPU's, within the tolerances of `check_ao_image`), and what crosses the bus grows
/// with the tasks, not with the rays: at most 64 bytes a task for a static plan (one launch),
/// the same for 8 and 16 AO probes a path, and 4 bytes of film a path.
#[test]
fn a_scheduled_gpu_frame_moves_bytes_by_task_not_by_ray() {
    use crate::paths::{GpuPaths, PathDevice, PathRenderer};
    use crate::paths::{Mode, Settings};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
    let (w, h) = (96, 80);
    let camera = Camera::orbit(&scene.bounds(), 0);
    let mut seen = Vec::new();
    for samples in [8, 16] {
        let settings = AoSettings {
            samples,
            ..AoSettings::default()
        };
        let options = RenderOptions::new(w, h, camera, Shader::Ao(settings));
        let device: Box<dyn PathDevice> =
            Box::new(GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device"));
        let mut r = PathRenderer::new(
            vec![device],
            Settings {
                policy: sched::Policy::StaticLpt,
                mode: Mode::Cost,
                task_size: std::num::NonZeroUsize::new(256).expect("positive"),
                ..Settings::default()
            },
        )
        .expect("renderer");
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        let stats = &frame.stats;
        let traffic = stats.traffic();
        eprintln!(
            "{samples} probes: {} tasks, {} launches, {traffic:?}, film {} bytes",
            stats.tasks,
            stats.launches(),
            stats.film_bytes()
        );
        assert_eq!(stats.launches(), 1);
        assert!(traffic.bytes() <= 64 * stats.tasks as u64, "{traffic:?}");
        // One submission per launch: the host waits once. One device needs no estimate.
        assert!(!stats.estimated);
        assert_eq!(traffic.host_waits, stats.launches(), "{traffic:?}");
        assert_eq!(stats.film_bytes(), u64::from(w * h) * 4);
        let cpu = render(&scene, &mut CpuTracer::new(&bvh), &options).film;
        let (kernels, _) = gpu_film(
            &GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer"),
            &options,
        )
        .expect("kernels");
        assert_eq!(
            frame.film, kernels,
            "the launch's tasks do not change a path"
        );
        let differ = cpu
            .pixels()
            .iter()
            .zip(frame.film.pixels())
            .filter(|(c, g)| c != g)
            .count();
        eprintln!(
            "{samples} probes: {differ} of {} pixels differ from the CPU's",
            w * h
        );
        assert!(differ * 100 <= (w * h) as usize, "{differ} pixels differ");
        seen.push(traffic);
    }
    assert_eq!(seen[0], seen[1], "traffic does not grow with the probes");
}

/// A GPU whose device is lost (destroyed under the renderer) fails like any executor: its
/// tasks are rendered on the CPU, the failure is reported, and the image is the CPU's.
#[test]
fn a_lost_gpu_has_its_paths_rendered_elsewhere() {
    use crate::paths::{CpuPaths, GpuPaths, PathDevice, PathRenderer, Settings};
    if gpu().is_none() {
        return;
    }
    let options = GpuOptions {
        allow_software: true,
    };
    let ctx = GpuContext::open_anew(GpuSelect::All, options)
        .expect("an adapter")
        .swap_remove(0);
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
    let shader = Shader::Ao(AoSettings {
        samples: 4,
        ..AoSettings::default()
    });
    let options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 1), shader);
    let want = render(&scene, &mut CpuTracer::new(&bvh), &options).film;
    let gpu = GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device");
    ctx.device.destroy();
    let cpu = CpuPaths::new(0, 1).expect("cpu");
    let devices: Vec<Box<dyn PathDevice>> = vec![Box::new(cpu), Box::new(gpu)];
    let settings = Settings {
        policy: sched::Policy::StaticLpt,
        task_size: std::num::NonZeroUsize::new(64).expect("positive"),
        ..Settings::default()
    };
    let mut r = PathRenderer::new(devices, settings).expect("renderer");
    let frame = r
        .render(&scene, &bvh, &options)
        .expect("the CPU finishes the frame");
    assert_eq!(frame.film, want, "lost device");
    let lost: Vec<_> = frame
        .stats
        .failures
        .iter()
        .filter(|f| f.name == "gpu0")
        .collect();
    assert!(
        !lost.is_empty(),
        "the lost GPU never failed: {:?}",
        frame.stats
    );
}

/// One GPU device keeps its launch buffers across launches and frames: launches of one task
/// each (a queue policy), frames of different sizes and shaders one after another, the
/// small after the large, each equal to the kernels' image of that frame alone and read back
/// at 4 B a path (AO) or 12 (Whitted).
#[test]
fn launches_and_frames_of_every_size_share_one_device() {
    use crate::paths::{GpuPaths, PathDevice, PathRenderer};
    use crate::paths::{Mode, Settings};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
    let camera = Camera::orbit(&scene.bounds(), 1);
    let ao = Shader::Ao(AoSettings {
        samples: 4,
        ..AoSettings::default()
    });
    let whitted = Shader::Whitted(WhittedSettings::default());
    let device: Box<dyn PathDevice> =
        Box::new(GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device"));
    let mut r = PathRenderer::new(
        vec![device],
        Settings {
            policy: sched::Policy::QueueFifo,
            mode: Mode::Cost,
            task_size: std::num::NonZeroUsize::new(100).expect("positive"),
            ..Settings::default()
        },
    )
    .expect("renderer");
    for (w, h, shader) in [
        (48, 40, ao),
        (20, 12, whitted),
        (48, 40, whitted),
        (30, 14, ao),
    ] {
        let options = RenderOptions::new(w, h, camera, shader);
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        assert!(frame.stats.launches() > 1, "{w}x{h}: one task a launch");
        // A path's value comes back as one word of grey (AO) or three of colour (Whitted).
        let words = if shader.name() == "ao" { 1 } else { 3 };
        assert_eq!(frame.stats.film_bytes(), u64::from(w * h) * 4 * words);
        let alone = GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer");
        let (kernels, _) = gpu_film(&alone, &options).expect("kernels");
        assert_eq!(frame.film, kernels, "{w}x{h} {}", shader.name());
    }
}

/// A launch sends its counts and its task list; the frame's parameters cross once, with its
/// first launch, and only when they change. With one task a launch (a queue policy), a second
/// frame of the same camera and shader moves exactly 16 bytes a task (a 4-byte number of
/// tasks, an 8-byte task, a 4-byte verdict; 16 bytes of timestamps more where the adapter
/// has them),
/// and the first frame at most the blocks of parameters more. (One device renders without
/// an estimate: see `a_gpu_estimates_its_paths_as_the_host_does` for an estimate's bytes.)
#[test]
fn one_task_launches_move_their_counts_only() {
    use crate::paths::{GpuPaths, PathDevice, PathRenderer};
    use crate::paths::{Mode, Settings};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
    let camera = Camera::orbit(&scene.bounds(), 1);
    let whitted = WhittedSettings::default();
    let shaders = [
        Shader::Ao(AoSettings {
            samples: 4,
            ..AoSettings::default()
        }),
        Shader::Whitted(whitted),
    ];
    let per_launch = 16 + if ctx.timestamps { 16 } else { 0 };
    // The path kernels' block and the header kernel's, and for Whitted one more block per
    // bounce.
    let blocks = 128 + 16 + 48 * u64::from(whitted.bounces + 1);
    for shader in shaders {
        let device: Box<dyn PathDevice> =
            Box::new(GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device"));
        let mut r = PathRenderer::new(
            vec![device],
            Settings {
                policy: sched::Policy::QueueFifo,
                mode: Mode::Cost,
                task_size: std::num::NonZeroUsize::new(64).expect("positive"),
                ..Settings::default()
            },
        )
        .expect("renderer");
        let options = RenderOptions::new(64, 48, camera, shader);
        let first = r.render(&scene, &bvh, &options).expect("frame").stats;
        let second = r.render(&scene, &bvh, &options).expect("frame");
        let stats = &second.stats;
        let (traffic, launches) = (stats.traffic(), stats.launches());
        eprintln!(
            "{}: {} tasks, {launches} launches; first frame {:?}, second {traffic:?}",
            shader.name(),
            stats.tasks,
            first.traffic()
        );
        assert_eq!(launches, stats.tasks as u64, "one task a launch");
        assert_eq!(traffic.bytes(), per_launch * launches, "{traffic:?}");
        assert_eq!(traffic.host_waits, launches, "{traffic:?}");
        let once = first.traffic().bytes();
        assert!(once <= per_launch * first.launches() + blocks, "{once}");
        assert!(once <= 64 * first.tasks as u64, "{once} bytes");
        let (kernels, _) = gpu_film(
            &GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer"),
            &options,
        )
        .expect("kernels");
        assert_eq!(second.film, kernels, "{}", shader.name());
    }
}

/// The header kernel makes a launch's counts and its tasks' first slots as the host's
/// [`Header::of`](super::header::Header::of) does, which sized the launch's buffers: random
/// task lists (empty tasks among them), strides from 1 to 4 and several shadow rays a path.
#[test]
fn the_header_kernel_counts_as_the_host_does() {
    use super::buffers::fetch;
    use super::header::{Header, Setup};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
    let r = GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer");
    let camera = Camera::orbit(&scene.bounds(), 0);
    let (w, h) = (40u32, 30u32);
    let frame = RenderOptions::new(w, h, camera, Shader::Ao(AoSettings::default()));
    let mut rng = Rng::new(11);
    for case in 0..16 {
        let mut cuts: Vec<usize> = (0..1 + rng.below(9))
            .map(|_| rng.below(w * h + 1) as usize)
            .collect();
        cuts.sort_unstable();
        let tasks: Vec<std::ops::Range<usize>> = cuts.windows(2).map(|c| c[0]..c[1]).collect();
        let refs: Vec<&std::ops::Range<usize>> = tasks.iter().collect();
        let (stride, lights) = (1 + rng.below(4), rng.below(3));
        let mut traffic = crate::Traffic::default();
        let (stage, _) = r
            .begin(
                &frame,
                &refs,
                &AoSettings {
                    samples: 0,
                    ..AoSettings::default()
                },
                lights,
                stride,
                &mut traffic,
            )
            .expect("launch");
        let launch = r.recorder(&stage, false);
        let done = launch
            .finish(&stage.header, 16, &mut traffic)
            .expect("header");
        let on_device: Header = bytemuck::pod_read_unaligned(&done.values);
        let host = Header::of(&refs, &Setup::new(stride, u32::MAX, lights)).expect("header");
        assert_eq!(on_device, host, "case {case}: {tasks:?}, stride {stride}");
        let want: Vec<[u32; 2]> = tasks
            .iter()
            .scan(0u32, |slot, t| {
                let first = *slot;
                *slot += t.len().div_ceil(stride as usize) as u32;
                Some([t.start as u32, first])
            })
            .collect();
        if !tasks.is_empty() {
            let table = fetch(&ctx, &stage.tasks, 8 * tasks.len() as u64).expect("tasks");
            let table: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&table);
            assert_eq!(table, want, "case {case}: {tasks:?}, stride {stride}");
        }
        // What crossed: the number of tasks and the list; the setup block at most once.
        assert!(
            traffic.host_to_device_bytes <= 4 + 8 * tasks.len() as u64 + 16 + 128,
            "{traffic:?}"
        );
    }
}

/// Two GPUs that estimate and render a frame between them, one task a launch: a task's
/// estimate (8 bytes of its list, 16 of sums) and its launch (4 + 8 bytes in, a 4-byte
/// verdict and timestamps out) stay within 64 bytes, for 8 and 16 AO probes a path alike and
/// for Whitted, and the image is the device kernels' own.
#[test]
fn estimating_gpus_move_at_most_64_bytes_a_task() {
    use crate::paths::{GpuPaths, PathDevice, PathRenderer};
    use crate::paths::{Mode, Settings};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
    let camera = Camera::orbit(&scene.bounds(), 0);
    let ao = |samples| {
        Shader::Ao(AoSettings {
            samples,
            ..AoSettings::default()
        })
    };
    let mut seen = Vec::new();
    for shader in [ao(8), ao(16), Shader::Whitted(WhittedSettings::default())] {
        let options = RenderOptions::new(64, 48, camera, shader);
        let devices: Vec<Box<dyn PathDevice>> = (0..2)
            .map(|_| {
                Box::new(GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device"))
                    as Box<dyn PathDevice>
            })
            .collect();
        let mut r = PathRenderer::new(
            devices,
            Settings {
                policy: sched::Policy::QueueFifo,
                mode: Mode::Cost,
                task_size: std::num::NonZeroUsize::new(32).expect("positive"),
                // Counted per launch of the plan: no backup copies.
                backups: false,
                ..Settings::default()
            },
        )
        .expect("renderer");
        // The first frame (from another camera, so that the next one estimates afresh)
        // uploads the frame's blocks; the second shows what a frame costs.
        let turned = RenderOptions::new(64, 48, Camera::orbit(&scene.bounds(), 1), shader);
        r.render(&scene, &bvh, &turned).expect("frame");
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        assert!(!frame.stats.estimate_reused);
        let stats = &frame.stats;
        let traffic = stats.traffic();
        eprintln!(
            "{}: {} tasks, {} launches, {traffic:?}",
            shader.name(),
            stats.tasks,
            stats.launches()
        );
        assert!(stats.estimated, "two devices estimate");
        assert_eq!(stats.launches(), stats.tasks as u64, "a launch a task");
        assert_eq!(
            traffic.host_waits,
            stats.tasks as u64 + 2,
            "a wait a launch and one a device's estimate"
        );
        assert!(traffic.bytes() <= 64 * stats.tasks as u64, "{traffic:?}");
        let (kernels, _) = gpu_film(
            &GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer"),
            &options,
        )
        .expect("kernels");
        assert_eq!(frame.film, kernels, "{}", shader.name());
        seen.push(traffic.bytes());
        // The same frame again takes the estimate at no cost: a wait a launch alone.
        let again = r.render(&scene, &bvh, &options).expect("frame").stats;
        assert!(again.estimate_reused);
        assert_eq!(again.traffic().host_waits, again.launches());
    }
    assert_eq!(seen[0], seen[1], "traffic does not grow with the probes");
}

/// A launch whose traces leave their queues undrained (here: recorded with no dispatch) is
/// caught by its verdict and run again with the host checking every trace: the values are
/// those of a launch that drained, for both shaders. An estimate's launch, whose counting
/// traces cannot be checked, fails instead (its caller estimates on the host).
#[test]
fn an_undrained_launch_is_run_again_checked() {
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
    let camera = Camera::orbit(&scene.bounds(), 2);
    for shader in [
        Shader::Ao(AoSettings {
            samples: 3,
            ..AoSettings::default()
        }),
        Shader::Whitted(WhittedSettings::default()),
    ] {
        let options = RenderOptions::new(40, 24, camera, shader);
        let whole = GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer");
        let (film, out) = gpu_film(&whole, &options).expect("drained");
        assert_eq!(out.traffic.host_waits, 1, "one wait: {:?}", out.traffic);
        let mut starved = GpuRenderer::new(ctx.clone(), &scene, &bvh).expect("renderer");
        starved.starved = true;
        let (again, out) = gpu_film(&starved, &options).expect("checked");
        assert_eq!(again, film, "{}", shader.name());
        assert!(
            out.traffic.host_waits > 2,
            "checked traces: {:?}",
            out.traffic
        );
        // An estimate's traces would not count when checked: it says so instead.
        let all = 0..40 * 24;
        let walk = crate::Walk::Trace { any: false };
        let sampled = starved.sample_paths(&options, &[&all], SampleRate::new(0.25).unwrap(), walk);
        assert!(
            matches!(sampled, Err(GpuError::LoopCut { .. })),
            "{sampled:?}"
        );
    }
}

/// A GPU estimates the tasks it holds with its own kernels: every sampled path made, traced
/// and shaded there, its rays' counts summed per task on the device. On the binary tree the
/// work equals the host's estimate of the same sample on it bit for bit (the kernels walk it
/// as the CPU does and find the CPU's hits), for both shaders, several rates and tasks of
/// every size, and only the task lists and the sums cross: 24 bytes a task beyond a launch's
/// fixed bytes. A path device's renderer traces the compressed wide tree: the same sample
/// there fetches fewer nodes and crosses the same bytes.
#[test]
fn a_gpu_estimates_its_paths_as_the_host_does() {
    use crate::paths::{GpuPaths, PathDevice, sample_paths};
    let Some(ctx) = gpu() else { return };
    for name in ["builtin:cornell:0.2", "builtin:forest:0.05"] {
        let (scene, bvh) = testkit::builtin_with_bvh(name).expect("scene");
        let mut device = GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device");
        let binary = GpuRenderer::with_layout(ctx.clone(), &scene, &bvh, crate::Layout::Binary)
            .expect("renderer");
        let camera = Camera::orbit(&scene.bounds(), 1);
        let shaders = [
            Shader::Ao(AoSettings {
                samples: 6,
                ..AoSettings::default()
            }),
            Shader::Whitted(WhittedSettings::default()),
        ];
        for shader in shaders {
            let options = RenderOptions::new(48, 40, camera, shader);
            let frame = crate::paths::Frame {
                scene: &scene,
                bvh: &bvh,
                options: &options,
            };
            let tasks = [0..1, 1..1, 1..700, 700..1300, 1300..1920];
            let refs: Vec<&std::ops::Range<usize>> = tasks.iter().collect();
            for rate in [1.0, 0.125, 0.01] {
                let rate = sched::SampleRate::new(rate).expect("rate");
                let trace = crate::Walk::Trace { any: false };
                let on_gpu = binary
                    .sample_paths(&options, &refs, rate, trace)
                    .expect("estimate");
                let on_host = sample_paths(&frame, &tasks, rate, crate::Layout::Binary);
                let on_host: Vec<_> = on_host.into_iter().map(|s| s.work).collect();
                let at = format!("{name} {} {rate:?}", shader.name());
                assert_eq!(on_gpu.work, on_host, "{at}");
                assert!(on_gpu.work[2].nodes > 0.0, "{at}: {:?}", on_gpu.work);
                let wide = device
                    .estimate(&frame, &refs, rate, trace)
                    .expect("wide estimate");
                for (w, b) in wide.work.iter().zip(&on_gpu.work) {
                    assert!(w.nodes <= b.nodes, "{at}: wide {w:?}, binary {b:?}");
                    assert_eq!(
                        w.nodes == 0.0,
                        b.nodes == 0.0,
                        "{at}: wide {w:?}, binary {b:?}"
                    );
                }
                for t in [&on_gpu.traffic, &wide.traffic] {
                    assert_eq!(t.host_waits, 1, "{t:?}");
                    // A task list and the sums; then the fixed part: the number of tasks, the
                    // verdict, timestamps, the traces' parameters, and the first time the
                    // frame's blocks.
                    assert!(t.bytes() <= 24 * tasks.len() as u64 + 400, "{t:?}");
                }
            }
        }
    }
}

/// The thesis's walks on a GPU: every sampled path's camera ray made on the device and walked
/// by the trace kernels' counting modes, summed per task there. The work equals the host's
/// walk of the same sample bit for bit, for both walks, shaders and several rates, and only
/// the task lists and the sums cross.
#[test]
fn a_gpu_walks_its_paths_camera_rays_as_the_host_does() {
    use crate::paths::{GpuPaths, PathDevice, walk_paths};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
    let mut device = GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device");
    let camera = Camera::orbit(&scene.bounds(), 1);
    let ao = Shader::Ao(AoSettings {
        samples: 6,
        ..AoSettings::default()
    });
    for shader in [ao, Shader::Whitted(WhittedSettings::default())] {
        let options = RenderOptions::new(48, 40, camera, shader);
        let frame = crate::paths::Frame {
            scene: &scene,
            bvh: &bvh,
            options: &options,
        };
        let tasks = [0..1, 1..1, 1..700, 700..1300, 1300..1920];
        let refs: Vec<&std::ops::Range<usize>> = tasks.iter().collect();
        for walk in crate::Walk::ALL {
            for rate in [1.0, 0.125] {
                let rate = sched::SampleRate::new(rate).expect("rate");
                let on_gpu = device
                    .estimate(&frame, &refs, rate, walk)
                    .expect("estimate");
                let on_host = walk_paths(&frame, &tasks, rate, walk);
                assert_eq!(on_gpu.work, on_host, "{} {walk:?} {rate:?}", shader.name());
                assert!(on_gpu.work[2].nodes > 0.0, "{:?}", on_gpu.work);
                let t = &on_gpu.traffic;
                assert!(t.bytes() <= 24 * tasks.len() as u64 + 400, "{t:?}");
            }
        }
    }
}

/// In a frame of CPU and GPU devices, the first device's kind estimates every task (the two
/// kinds count on different trees): a GPU listed first estimates on the device, in one more
/// launch; listed after a CPU, it only renders. The image is the CPU's either way.
#[test]
fn the_first_devices_kind_estimates_a_mixed_frame() {
    use crate::paths::{CpuPaths, GpuPaths, PathDevice, PathRenderer};
    use crate::paths::{Mode, Settings};
    let Some(ctx) = gpu() else { return };
    let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
    let options = RenderOptions::new(
        40,
        32,
        Camera::orbit(&scene.bounds(), 0),
        Shader::Ao(AoSettings {
            samples: 4,
            ..AoSettings::default()
        }),
    );
    let cpu = render(&scene, &mut CpuTracer::new(&bvh), &options).film;
    for gpu_first in [true, false] {
        let g: Box<dyn PathDevice> =
            Box::new(GpuPaths::new(ctx.clone(), &scene, &bvh).expect("device"));
        let c: Box<dyn PathDevice> = Box::new(CpuPaths::new(0, 1).expect("cpu"));
        let devices = if gpu_first { vec![g, c] } else { vec![c, g] };
        let settings = Settings {
            policy: sched::Policy::StaticLpt,
            mode: Mode::Cost,
            task_size: std::num::NonZeroUsize::new(128).expect("positive"),
            // Counted per launch of the plan: no backup copies.
            backups: false,
            ..Settings::default()
        };
        let mut r = PathRenderer::new(devices, settings).expect("renderer");
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        let on_gpu = &frame.stats.devices[usize::from(!gpu_first)];
        let waits = on_gpu.traffic.host_waits;
        assert_eq!(
            waits,
            on_gpu.launches + u64::from(gpu_first),
            "gpu first: {gpu_first}, {on_gpu:?}"
        );
        assert_eq!(frame.film, cpu, "gpu first: {gpu_first}");
    }
}
