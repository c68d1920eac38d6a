// Rendering through sched: the image never depends on the schedule, failures are absorbed,
// launches follow the policy, and speeds and kB, kT get measured.

use std::num::NonZeroUsize;

use sched::Policy;

use crate::devices::parse_devices;
#[cfg(feature = "gpu")]
use crate::scheduled::RayDevice;
use crate::scheduled::{
    FailAfter, GenerationStats, Mode, ScheduledTracer, Settings, build_devices,
};
use crate::shade::{
    AoSettings, CpuTracer, RenderOptions, Rendering, Shader, WhittedSettings, render,
};
use crate::{BuildPreset, Bvh, Camera, RayKind, Scene, SceneSource, Walk};

const N: u32 = 32;

fn load(source: &str, shader: Shader) -> (Scene, Bvh) {
    let scene = SceneSource::parse(source)
        .unwrap()
        .load(shader.needs())
        .unwrap();
    let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    (scene, bvh)
}

fn whitted() -> Shader {
    Shader::Whitted(WhittedSettings::default())
}

fn ao() -> Shader {
    Shader::Ao(AoSettings {
        samples: 8,
        ..Default::default()
    })
}

fn settings(policy: Policy, mode: Mode, task_size: usize) -> Settings {
    Settings {
        policy,
        mode,
        task_size: NonZeroUsize::new(task_size).unwrap(),
        ..Settings::default()
    }
}

/// Renders through a scheduled tracer; returns the rendering and its per-generation stats.
fn scheduled(
    scene: &Scene,
    bvh: &Bvh,
    shader: Shader,
    devices: &str,
    faults: &[FailAfter],
    s: Settings,
) -> (Rendering, Vec<GenerationStats>) {
    let devices = build_devices(bvh, &parse_devices(devices).unwrap(), faults).unwrap();
    let mut tracer = ScheduledTracer::new(bvh, devices, s).unwrap();
    let options = RenderOptions::new(N, N, Camera::orbit(&scene.bounds(), 1), shader);
    let r = render(scene, &mut tracer, &options);
    (r, tracer.stats().to_vec())
}

fn reference(scene: &Scene, bvh: &Bvh, shader: Shader) -> Rendering {
    let options = RenderOptions::new(N, N, Camera::orbit(&scene.bounds(), 1), shader);
    render(scene, &mut CpuTracer::new(bvh), &options)
}

#[test]
fn images_are_identical_whatever_the_policy_mode_and_devices() {
    for (source, shader) in [
        ("builtin:cornell", whitted()),
        ("builtin:cornell", ao()),
        ("builtin:forest:0.05", ao()),
    ] {
        let (scene, bvh) = load(source, shader);
        let want = reference(&scene, &bvh, shader);
        for policy in Policy::ALL {
            for mode in Mode::ALL {
                for (devices, count) in [
                    ("cpu:1", 1),
                    ("cpu:2", 2),
                    ("cpu:3", 3),
                    ("cpu:1/2,cpu:1", 2),
                ] {
                    let settings = settings(policy, mode, 96);
                    let (got, stats) = scheduled(&scene, &bvh, shader, devices, &[], settings);
                    let what = format!("{source} {} {policy} {mode} {devices}", shader.name());
                    assert_eq!(got.film, want.film, "{what}");
                    assert_eq!(stats.len(), want.generations.len(), "{what}");
                    for (s, g) in stats.iter().zip(&want.generations) {
                        assert_eq!((s.kind, s.rays), (g.kind, g.rays), "{what}");
                        // 96 rays per task, or fewer in generations too small for every
                        // device to get several tasks.
                        let size = settings.task_size_for(g.rays, count);
                        assert!(size <= 96, "{what}");
                        assert_eq!(
                            (s.task_size, s.tasks),
                            (size.min(g.rays), g.rays.div_ceil(size)),
                            "{what}"
                        );
                        let delivered: usize = s.devices.iter().map(|d| d.tasks).sum();
                        assert_eq!(delivered, s.tasks, "{what}");
                        assert!(s.balance_efficiency > 0.0 && s.balance_efficiency <= 1.0 + 1e-9);
                        assert_eq!(s.reruns, 0, "{what}");
                    }
                }
            }
        }
    }
}

/// The first-leaf walk changes the plan of closest-hit generations only, never the image.
#[test]
fn the_first_leaf_walk_costs_closest_hit_rays_and_leaves_the_image_alone() {
    let shader = whitted();
    let (scene, bvh) = load("builtin:cornell", shader);
    let want = reference(&scene, &bvh, shader);
    let run = |walk| {
        let settings = Settings {
            walk,
            ..settings(Policy::StaticLpt, Mode::Cost, 96)
        };
        scheduled(&scene, &bvh, shader, "cpu:2", &[], settings)
    };
    let (reduced, reduced_stats) = run(Walk::Reduced);
    let (first, first_stats) = run(Walk::FirstLeaf);
    assert_eq!(reduced.film, want.film);
    assert_eq!(first.film, want.film);
    // The first generation (camera rays) is planned with the default model in both runs:
    // the closed box ends every ray at its first leaf, so it costs less.
    let total = |s: &GenerationStats| s.task_stats.iter().map(|t| t.cost).sum::<f64>();
    assert_eq!(first_stats[0].kind, RayKind::Primary);
    assert!(
        total(&first_stats[0]) < 0.9 * total(&reduced_stats[0]),
        "{} vs {}",
        total(&first_stats[0]),
        total(&reduced_stats[0])
    );
}

/// A device that notes how many known rays each launch was told of, and may refuse to skip.
struct Spy<'a> {
    inner: Box<dyn crate::scheduled::RayDevice + 'a>,
    skips: bool,
    told: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl crate::scheduled::RayDevice for Spy<'_> {
    fn trace_range(
        &mut self,
        kind: RayKind,
        rays: &crate::RayBatch,
        range: &std::ops::Range<usize>,
    ) -> Result<crate::HitBatch, sched::DeviceError> {
        self.inner.trace_range(kind, rays, range)
    }

    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &crate::RayBatch,
        ranges: &[&std::ops::Range<usize>],
        known: &[usize],
        sink: &mut sched::Sink<crate::HitBatch>,
    ) -> Result<(), sched::DeviceError> {
        let inside = |i: &usize| ranges.iter().any(|r| r.contains(i));
        self.told.fetch_add(
            known.iter().filter(|i| inside(i)).count(),
            std::sync::atomic::Ordering::Relaxed,
        );
        self.inner.trace_ranges(kind, rays, ranges, known, sink)
    }

    fn skips_known(&self) -> bool {
        self.skips && self.inner.skips_known()
    }

    fn name(&self) -> String {
        self.inner.name()
    }
}

/// The trace walk traces each task's sample for real; where every device skips known rays,
/// the sample's hits stand in for their trace (and the devices are told of every sampled ray
/// of their tasks), else they trace everything. The image is the same either way, through
/// failures too.
#[test]
fn the_trace_walk_hands_its_samples_hits_down_and_leaves_the_image_alone() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    for (source, shader) in [
        ("builtin:cornell", whitted()),
        ("builtin:forest:0.05", ao()),
    ] {
        let (scene, bvh) = load(source, shader);
        let want = reference(&scene, &bvh, shader);
        for (walk, second_skips, faults) in [
            (Walk::Trace { any: false }, true, vec![]),
            (Walk::Trace { any: false }, false, vec![]),
            (Walk::Reduced, true, vec![]),
            (
                Walk::Trace { any: false },
                true,
                vec![FailAfter {
                    device: 1,
                    tasks: 3,
                }],
            ),
        ] {
            let told = Arc::new(AtomicUsize::new(0));
            let devices = build_devices(&bvh, &parse_devices("cpu:2").unwrap(), &faults)
                .unwrap()
                .into_iter()
                .enumerate()
                .map(|(d, inner)| {
                    Box::new(Spy {
                        inner,
                        skips: d == 0 || second_skips,
                        told: told.clone(),
                    }) as Box<dyn crate::scheduled::RayDevice>
                })
                .collect();
            let settings = Settings {
                walk,
                ..settings(Policy::Hybrid, Mode::Cost, 64)
            };
            let mut tracer = ScheduledTracer::new(&bvh, devices, settings).unwrap();
            let options = RenderOptions::new(N, N, Camera::orbit(&scene.bounds(), 1), shader);
            let got = render(&scene, &mut tracer, &options);
            let case = format!("{source} {walk:?} second skips {second_skips} {faults:?}");
            assert_eq!(got.film, want.film, "{case}");
            let told = told.load(Ordering::Relaxed);
            if walk == Walk::Reduced || !second_skips {
                assert_eq!(told, 0, "{case}");
            } else {
                // Every generation's sample, 1/8 of its rays, at least once (reruns again).
                let rays: usize = tracer.stats().iter().map(|g| g.rays).sum();
                assert!(told >= rays / 8, "{case}: told of {told} of {rays} rays");
            }
        }
    }
}

/// A refined sample (`Settings::sample_error`) hands its hits down as the whole sample does:
/// the image is the reference's, and where the tasks are large enough to refine (the camera
/// rays of a 128 × 128 frame in tasks of 2048) and the target is met at once, the devices are
/// told of a quarter of the rays they would have been.
#[test]
fn a_refined_sample_hands_down_fewer_hits_and_leaves_the_image_alone() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    const SIZE: u32 = 128;
    let shader = Shader::Whitted(WhittedSettings { bounces: 0 });
    let (scene, bvh) = load("builtin:forest:0.05", shader);
    let options = RenderOptions::new(SIZE, SIZE, Camera::orbit(&scene.bounds(), 1), shader);
    let want = render(&scene, &mut CpuTracer::new(&bvh), &options);
    let told_of = |sample_error: Option<f64>| {
        let told = Arc::new(AtomicUsize::new(0));
        let devices = build_devices(&bvh, &parse_devices("cpu:2").unwrap(), &[])
            .unwrap()
            .into_iter()
            .map(|inner| {
                Box::new(Spy {
                    inner,
                    skips: true,
                    told: told.clone(),
                }) as Box<dyn crate::scheduled::RayDevice>
            })
            .collect();
        let settings = Settings {
            walk: Walk::Trace { any: false },
            sample_error,
            ..settings(Policy::StaticLpt, Mode::Cost, 2048)
        };
        let mut tracer = ScheduledTracer::new(&bvh, devices, settings).unwrap();
        let got = render(&scene, &mut tracer, &options);
        assert_eq!(got.film, want.film, "{sample_error:?}");
        let primary = tracer.stats().first().map(|g| g.rays);
        assert_eq!(primary, Some((SIZE * SIZE) as usize));
        told.load(Ordering::Relaxed)
    };
    let (whole, refined) = (told_of(None), told_of(Some(0.99)));
    // The camera rays' sample: 1/8 of them whole, 1/32 refined; the shadow rays' tasks are
    // cut too small to refine and are sampled whole in both.
    let camera = (SIZE * SIZE) as usize;
    assert_eq!(
        whole - refined,
        camera / 8 - camera / 32,
        "{whole} {refined}"
    );
}

#[test]
fn a_device_that_fails_mid_render_leaves_the_image_complete() {
    let shader = whitted();
    let (scene, bvh) = load("builtin:cornell", shader);
    let want = reference(&scene, &bvh, shader);
    for policy in Policy::ALL {
        let fail = [FailAfter {
            device: 1,
            tasks: 3,
        }];
        let (got, stats) = scheduled(
            &scene,
            &bvh,
            shader,
            "cpu:3",
            &fail,
            settings(policy, Mode::Cost, 64),
        );
        assert_eq!(got.film, want.film, "{policy}");
        // A plan gives device 1 about a third of the first generation's 16 tasks, so it
        // fails there; a queue hands tasks to whichever thread asks first, and on a busy
        // machine device 1 may never get to its fourth.
        let Some(failed_in) = stats.iter().position(|s| !s.failures.is_empty()) else {
            assert!(
                !policy.is_static() && policy != Policy::Hybrid,
                "{policy}: never failed"
            );
            continue;
        };
        let s = &stats[failed_in];
        assert_eq!(s.failures[0].device, 1, "{policy}");
        assert!(s.failures[0].reason.contains("injected fault"), "{policy}");
        assert!(!s.host_fallback);
        // Later generations plan without it.
        for later in &stats[failed_in + 1..] {
            assert!(later.devices.iter().all(|d| d.index != 1), "{policy}");
            assert!(later.failures.is_empty());
        }
        let reruns: u64 = stats.iter().map(|s| s.reruns).sum();
        if policy.is_static() {
            assert!(reruns > 0, "{policy}: its planned tasks are re-run");
        }
    }
    // Every device fails: the caller's thread traces, and the image is still complete.
    let fail = [
        FailAfter {
            device: 0,
            tasks: 2,
        },
        FailAfter {
            device: 1,
            tasks: 0,
        },
    ];
    let (got, stats) = scheduled(
        &scene,
        &bvh,
        shader,
        "cpu:2",
        &fail,
        settings(Policy::Hybrid, Mode::Cost, 64),
    );
    assert_eq!(got.film, want.film);
    assert!(stats[0].host_fallback && stats[0].reruns > 0 && stats[0].failures.len() == 2);
    assert!(stats.iter().all(|s| s.host_fallback));
}

#[test]
fn static_plans_launch_once_per_device_and_queues_once_per_task() {
    let shader = ao();
    let (scene, bvh) = load("builtin:cornell", shader);
    for policy in Policy::ALL {
        for mode in Mode::ALL {
            let (_, stats) = scheduled(
                &scene,
                &bvh,
                shader,
                "cpu:2",
                &[],
                settings(policy, mode, 128),
            );
            for s in &stats {
                let launches: Vec<u64> = s.devices.iter().map(|d| d.launches).collect();
                match policy {
                    Policy::StaticEqual | Policy::StaticLpt => {
                        assert_eq!(launches, vec![1, 1], "{policy} {mode} {:?}", s.kind)
                    }
                    Policy::QueueFifo | Policy::QueueSorted => {
                        assert_eq!(s.launches(), s.tasks as u64, "{policy} {mode}")
                    }
                    // Halves of each device's queue, plus steals: between the two.
                    Policy::Hybrid => {
                        assert!(launches.iter().all(|&l| l >= 1), "{policy} {mode}");
                        assert!(s.launches() <= s.tasks as u64, "{policy} {mode}");
                    }
                }
            }
        }
    }
}

#[test]
fn speeds_and_calibrations_are_measured_and_used() {
    let shader = whitted();
    let (scene, bvh) = load("builtin:forest:0.05", shader);
    let (_, stats) = scheduled(
        &scene,
        &bvh,
        shader,
        "cpu:1/2,cpu:1",
        &[],
        settings(Policy::StaticLpt, Mode::Cost, 64),
    );
    assert!(stats.len() >= 2);
    assert!(stats[0].devices.iter().all(|d| d.speed == 1.0));
    // The first generation's measurement is the second's plan.
    for (d0, d1) in stats[0].devices.iter().zip(&stats[1].devices) {
        let m = d0.measured_speed.expect("both devices ran tasks");
        assert!(m.is_finite() && m > 0.0);
        assert_eq!(d1.speed, m);
    }
    assert!(stats[1].devices.iter().any(|d| d.speed != 1.0));
    // Later measurements are blended in by busy time: the third plan lies between the second's
    // speed and the second's measurement.
    if stats.len() >= 3 {
        for (d1, d2) in stats[1].devices.iter().zip(&stats[2].devices) {
            if let Some(m) = d1.measured_speed {
                let (lo, hi) = (d1.speed.min(m), d1.speed.max(m));
                assert!(
                    d2.speed >= lo - 1e-12 && d2.speed <= hi + 1e-12,
                    "{d1:?} {d2:?}"
                );
            }
        }
    }
    for s in &stats {
        assert!(s.estimate_error.is_none());
        assert!(s.estimate_seconds > 0.0);
        let ran = s.devices.iter().filter(|d| d.tasks > 0).count();
        assert_eq!(s.calibrations.len(), ran, "{:?}", s.kind);
        for f in &s.calibrations {
            assert!(f.fit.model.can_plan(), "{f:?}");
            assert_eq!(f.kind, s.kind);
        }
        for t in &s.task_stats {
            assert!(t.cost > 0.0 && t.seconds >= 0.0 && t.device < 2);
        }
    }
    // Regular mode: uniform costs, no estimate and no calibration.
    let (_, stats) = scheduled(
        &scene,
        &bvh,
        shader,
        "cpu:2",
        &[],
        settings(Policy::StaticLpt, Mode::Regular, 64),
    );
    for s in &stats {
        assert!(s.calibrations.is_empty() && s.estimate_seconds == 0.0);
        assert!(s.task_stats.iter().all(|t| t.cost == 1.0));
    }
}

#[test]
fn bad_device_lists_and_faults_are_named() {
    let (_, bvh) = load("builtin:cornell", whitted());
    // An adapter that does not exist is named (with the `gpu` feature); without the feature
    // every GPU entry is refused.
    let gpu = build_devices(&bvh, &parse_devices("cpu:1,gpu:99").unwrap(), &[]);
    let e = gpu.err().unwrap().to_string();
    if cfg!(feature = "gpu") {
        assert!(
            e.contains("gpu:99") && e.contains("no GPU adapter 99"),
            "{e}"
        );
    } else {
        assert!(e.contains("gpu:99") && e.contains("`gpu` feature"), "{e}");
    }
    let fault = [FailAfter {
        device: 2,
        tasks: 1,
    }];
    let e = build_devices(&bvh, &parse_devices("cpu:2").unwrap(), &fault)
        .err()
        .unwrap();
    assert!(e.to_string().contains("2@1"), "{e}");
    assert!(ScheduledTracer::new(&bvh, Vec::new(), Settings::default()).is_err());
}

/// CPU and GPU render one image together, equal to the CPU's, whatever the policy. Skipped (with a note) without an adapter, except under CI.
#[cfg(feature = "gpu")]
#[test]
fn cpu_and_gpu_render_the_cpu_image() {
    if !gpu0_usable() {
        return;
    }
    for (source, shader) in [
        ("builtin:cornell", whitted()),
        ("builtin:forest:0.05", ao()),
    ] {
        let (scene, bvh) = load(source, shader);
        let want = reference(&scene, &bvh, shader);
        for policy in [Policy::StaticLpt, Policy::QueueSorted] {
            let (got, stats) = scheduled(
                &scene,
                &bvh,
                shader,
                "cpu:1,gpu:0",
                &[],
                settings(policy, Mode::Cost, 96),
            );
            let what = format!("{source} {} {policy}", shader.name());
            assert_eq!(got.film, want.film, "{what}");
            let gpu_tasks: usize = stats
                .iter()
                .flat_map(|s| &s.devices)
                .filter(|d| d.name == "gpu0")
                .map(|d| d.tasks)
                .sum();
            // A static plan gives the GPU tasks from the first generation on (speeds start
            // equal); a queue may be drained by the CPU before a slow GPU starts.
            assert!(
                gpu_tasks > 0 || policy != Policy::StaticLpt,
                "{what}: the GPU traced nothing"
            );
            // The GPU's own kernel time (timestamp queries, lavapipe has them) is reported for
            // every generation it ran in, and is at most its busy time on the host; a CPU
            // device measures none.
            let timestamps = crate::gpu::tests::gpu().is_some_and(|c| c.timestamps);
            for d in stats.iter().flat_map(|s| &s.devices) {
                if d.name == "gpu0" && d.tasks > 0 && timestamps {
                    let k = d.device_seconds.expect("GPU kernel time");
                    assert!(k > 0.0 && k <= d.busy, "{what}: {k} of {} busy", d.busy);
                } else if d.name != "gpu0" {
                    assert_eq!(d.device_seconds, None, "{what}");
                }
            }
            // A queue launches each task alone: every GPU task then has its own kernel time,
            // at most the task's host time; CPU tasks have none.
            let gpu_index = stats[0]
                .devices
                .iter()
                .find(|d| d.name == "gpu0")
                .map(|d| d.index);
            for t in stats.iter().flat_map(|s| &s.task_stats) {
                if Some(t.device) != gpu_index {
                    assert_eq!(t.device_seconds, None, "{what}");
                } else if policy == Policy::QueueSorted && timestamps {
                    let k = t.device_seconds.expect("per-task GPU time");
                    assert!(k > 0.0 && k <= t.seconds, "{what}: {k} of {}", t.seconds);
                }
            }
        }
    }
}

/// A GPU that fails mid-render, by an injected fault (`--fail 1@2`) or because its device is
/// lost (destroyed under the renderer), is handled like any failed executor: its tasks are
/// re-run on the CPU and the image is the CPU's. Skipped (with a note) without an adapter,
/// except under CI.
#[cfg(feature = "gpu")]
#[test]
fn a_failing_or_lost_gpu_has_its_tasks_rerun_elsewhere() {
    if !gpu0_usable() {
        return;
    }
    let shader = ao();
    let (scene, bvh) = load("builtin:cornell", shader);
    let want = reference(&scene, &bvh, shader);
    // Static plans: the GPU gets tasks from the first generation on, so it must fail.
    let s = settings(Policy::StaticLpt, Mode::Cost, 96);
    let fault = [FailAfter {
        device: 1,
        tasks: 2,
    }];
    let (got, stats) = scheduled(&scene, &bvh, shader, "cpu:1,gpu:0", &fault, s);
    assert_eq!(got.film, want.film, "injected fault");
    let failures: Vec<_> = stats.iter().flat_map(|g| &g.failures).collect();
    assert!(
        failures
            .iter()
            .any(|f| f.name == "gpu0" && f.reason.contains("injected fault after 2 tasks")),
        "{failures:?}"
    );
    assert!(stats.iter().map(|g| g.reruns).sum::<u64>() > 0);

    // A lost device: wgpu reports errors (or panics) on every later use of it.
    let ctx = crate::gpu::tests::gpu().expect("adapter");
    let gpu = crate::gpu::GpuDevice::new(ctx, &bvh).expect("upload");
    gpu.context().device.destroy();
    let cpu = crate::cpu::CpuDevice::new(&bvh, 0, 1).expect("cpu");
    let devices: Vec<Box<dyn RayDevice + '_>> = vec![Box::new(cpu), Box::new(gpu)];
    let mut tracer = ScheduledTracer::new(&bvh, devices, s).expect("tracer");
    let options = RenderOptions::new(N, N, Camera::orbit(&scene.bounds(), 1), shader);
    let got = render(&scene, &mut tracer, &options);
    assert_eq!(got.film, want.film, "lost device");
    let lost: Vec<_> = tracer
        .stats()
        .iter()
        .flat_map(|g| &g.failures)
        .filter(|f| f.name == "gpu0")
        .collect();
    assert!(!lost.is_empty(), "the lost GPU never failed");
    eprintln!("lost GPU: {}", lost[0].reason);
}

/// `EstimateOn::Gpu` estimates every generation on the GPU, with exactly the host's costs (so
/// the same plans) and the same image; without a GPU among the devices the host estimates
/// and the stats say why. Skipped (with a note) without an adapter, except under CI.
#[cfg(feature = "gpu")]
#[test]
fn estimates_on_the_gpu_equal_the_hosts() {
    use crate::scheduled::EstimateOn;
    if !gpu0_usable() {
        return;
    }
    let shader = whitted();
    let (scene, bvh) = load("builtin:cornell", shader);
    let want = reference(&scene, &bvh, shader);
    let on = |estimate_on, devices, walk| {
        let settings = Settings {
            estimate_on,
            walk,
            ..settings(Policy::StaticLpt, Mode::Cost, 96)
        };
        scheduled(&scene, &bvh, shader, devices, &[], settings)
    };
    let (host, host_stats) = on(EstimateOn::Cpu, "cpu:1,gpu:0", Walk::Reduced);
    let (gpu, gpu_stats) = on(EstimateOn::Gpu, "cpu:1,gpu:0", Walk::Reduced);
    assert_eq!(host.film, want.film);
    assert_eq!(gpu.film, want.film);
    // The first generation is planned with the default model on both: equal work, equal
    // costs, to the bit.
    let costs = |s: &GenerationStats| s.task_stats.iter().map(|t| t.cost).collect::<Vec<_>>();
    assert_eq!(costs(&gpu_stats[0]), costs(&host_stats[0]));
    for s in &gpu_stats {
        assert_eq!(s.estimated_on.as_deref(), Some("gpu0"), "{:?}", s.kind);
    }
    assert!(
        host_stats
            .iter()
            .all(|s| s.estimated_on.as_deref() == Some("host"))
    );
    let (_, cpu_only) = on(EstimateOn::Gpu, "cpu:2", Walk::Reduced);
    assert_eq!(
        cpu_only[0].estimated_on.as_deref(),
        Some("host (no GPU among the devices)")
    );
    // The first-leaf walk runs on the GPU too, with the host's costs.
    let (host, host_stats) = on(EstimateOn::Cpu, "cpu:1,gpu:0", Walk::FirstLeaf);
    let (gpu, gpu_stats) = on(EstimateOn::Gpu, "cpu:1,gpu:0", Walk::FirstLeaf);
    assert_eq!(host.film, want.film);
    assert_eq!(gpu.film, want.film);
    assert_eq!(costs(&gpu_stats[0]), costs(&host_stats[0]));
    assert!(
        gpu_stats
            .iter()
            .all(|s| s.estimated_on.as_deref() == Some("gpu0"))
    );
}

/// Whether `gpu:0` opens: there is an adapter, and it is hardware or software adapters are
/// allowed (`COBALT_GPU_SOFTWARE=1`, as `scripts/test-all` sets).
#[cfg(feature = "gpu")]
fn gpu0_usable() -> bool {
    crate::gpu::tests::gpu().is_some_and(|c| {
        c.info.device_type != wgpu::DeviceType::Cpu
            || crate::gpu::GpuOptions::from_env().allow_software
    })
}
