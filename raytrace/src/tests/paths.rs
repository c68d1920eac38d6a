//! Path-resident rendering: the image of every policy, mode, task size and device mix is the
//! CPU reference's, a device lost mid-frame changes nothing, and on a GPU what crosses the
//! bus grows with the tasks, not with the rays.

use sched::Policy;

use crate::paths::{CpuPaths, InjectedPaths, PathDevice, PathRenderer};
use crate::paths::{Mode, Settings};
use crate::shade::{AoSettings, CpuTracer, RenderOptions, Shader, WhittedSettings, render};
use crate::{Bvh, Camera, Film, Scene, Walk};

fn scene(name: &str, shader: &Shader) -> (Scene, Bvh) {
    let scene = crate::SceneSource::parse(name)
        .and_then(|s| s.load(shader.needs()))
        .expect("built-in scene");
    let bvh = Bvh::build(&scene, crate::BuildPreset::Medium).expect("BVH");
    (scene, bvh)
}

fn bits(film: &Film) -> Vec<[u32; 3]> {
    film.pixels()
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Held by every test here: most of their outcomes depend on device speeds measured on the
/// wall clock, which two of them rendering at once on the same cores would each distort (one
/// lock for the file, rather than a list of the tests that need it to keep up to date).
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static CORES: std::sync::Mutex<()> = std::sync::Mutex::new(());
    CORES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn cpus(n: usize) -> Vec<Box<dyn PathDevice>> {
    CpuPaths::many(0, n, 1)
        .expect("threads")
        .into_iter()
        .map(|d| Box::new(d) as Box<dyn PathDevice>)
        .collect()
}

fn settings(policy: Policy, mode: Mode, task_size: usize) -> Settings {
    Settings {
        policy,
        mode,
        task_size: std::num::NonZeroUsize::new(task_size).expect("positive"),
        ..Settings::default()
    }
}

const SHADERS: [Shader; 2] = [
    Shader::Ao(AoSettings {
        samples: 6,
        max_distance: None,
        seed: 3,
    }),
    Shader::Whitted(WhittedSettings { bounces: 2 }),
];

/// Every policy, both modes and three task sizes give the reference image bit for bit, on
/// two CPU devices, frame after frame (the second frame plans with measured speeds).
#[test]
fn every_plan_renders_the_reference_image() {
    let _cores = one_at_a_time();
    for shader in SHADERS {
        let (scene, bvh) = scene("builtin:cornell:0.2", &shader);
        let options = RenderOptions::new(37, 29, Camera::orbit(&scene.bounds(), 1), shader);
        let reference = bits(&render(&scene, &mut CpuTracer::new(&bvh), &options).film);
        for policy in Policy::ALL {
            for mode in Mode::ALL {
                for task_size in [64, 200, 4096] {
                    let mut r =
                        PathRenderer::new(cpus(2), settings(policy, mode, task_size)).expect("r");
                    for frame in 0..2 {
                        let out = r.render(&scene, &bvh, &options).expect("frame");
                        assert_eq!(
                            bits(&out.film),
                            reference,
                            "{} {policy:?} {mode:?} {task_size} frame {frame}",
                            shader.name()
                        );
                        assert_eq!(out.stats.traffic().bytes(), 0);
                        assert_eq!(out.stats.film_bytes(), 0);
                        assert!(out.stats.rays >= out.stats.paths);
                    }
                }
            }
        }
    }
}

/// A device that waits before each launch, of its own class where `class` names one.
struct Delayed {
    inner: Box<dyn PathDevice>,
    millis: u64,
    class: Option<&'static str>,
}

impl PathDevice for Delayed {
    fn render(
        &mut self,
        frame: &crate::paths::Frame<'_>,
        tasks: &[&std::ops::Range<usize>],
    ) -> Result<crate::paths::Launch, sched::DeviceError> {
        std::thread::sleep(std::time::Duration::from_millis(self.millis));
        self.inner.render(frame, tasks)
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        self.class.map_or_else(|| self.inner.class(), str::to_owned)
    }
}

/// A device of its own class that renders at a third of its inner device's speed and waits
/// `millis` before each estimate: its speed is measured on its renders, so no plan sees what
/// its estimates cost.
struct SlowEstimates {
    inner: Box<dyn PathDevice>,
    millis: u64,
}

impl PathDevice for SlowEstimates {
    fn render(
        &mut self,
        frame: &crate::paths::Frame<'_>,
        tasks: &[&std::ops::Range<usize>],
    ) -> Result<crate::paths::Launch, sched::DeviceError> {
        // Three times as long, so that the other class is the fastest even where other
        // threads share the cores unevenly between the two devices.
        let started = std::time::Instant::now();
        let launch = self.inner.render(frame, tasks);
        std::thread::sleep(started.elapsed() * 2);
        launch
    }

    fn estimate(
        &mut self,
        frame: &crate::paths::Frame<'_>,
        tasks: &[&std::ops::Range<usize>],
        rate: sched::SampleRate,
        walk: Walk,
    ) -> Result<crate::paths::Estimate, sched::DeviceError> {
        std::thread::sleep(std::time::Duration::from_millis(self.millis));
        self.inner.estimate(frame, tasks, rate, walk)
    }

    fn estimate_kind(&self) -> &'static str {
        self.inner.estimate_kind()
    }

    /// Dealt its share of an estimate at once, as a GPU is, so that its lag holds every
    /// estimate it takes part in.
    fn cheap_launches(&self) -> bool {
        false
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        "laggard".to_owned()
    }
}

/// `inner`, failing once it has completed `tasks` tasks (`--fail`).
fn failing(inner: Box<dyn PathDevice>, tasks: u64) -> Box<dyn PathDevice> {
    let fault = crate::paths::FailAfter { device: 0, tasks };
    InjectedPaths::wrap(vec![inner], &[fault], &[]).remove(0)
}

/// `inner` as a device of its own class that waits 40 ms before each launch: every frame it
/// takes part in is slower than one without it, whatever the plan.
fn laggard(inner: Box<dyn PathDevice>) -> Box<dyn PathDevice> {
    Box::new(Delayed {
        inner,
        millis: 40,
        class: Some("laggard"),
    })
}

/// A small forest frame of `shader` (48x40): the scene, its BVH, the options and the CPU
/// reference image's bits.
fn small_forest(shader: Shader) -> (Scene, Bvh, RenderOptions, Vec<[u32; 3]>) {
    let (scene, bvh) = scene("builtin:forest:0.05", &shader);
    let options = RenderOptions::new(48, 40, Camera::orbit(&scene.bounds(), 0), shader);
    let reference = bits(&render(&scene, &mut CpuTracer::new(&bvh), &options).film);
    (scene, bvh, options, reference)
}

/// A device whose presence slows frames whatever the plan (here, its estimates lag: a plan
/// cannot see that; each frame is of its own image, so that no frame takes an earlier one's
/// estimate) is left idle once both ways were measured, in this renderer and in one that
/// takes over its devices (a bench's next cell), and the image does not change.
#[test]
fn a_device_that_slows_frames_is_left_idle() {
    let _cores = one_at_a_time();
    let (scene, bvh, options, reference) = small_forest(SHADERS[0]);
    let frame_of = |k: usize| {
        let camera = Camera::orbit(&scene.bounds(), k);
        let options = RenderOptions::new(128 + k as u32, 96, camera, SHADERS[0]);
        let image = render(&scene, &mut CpuTracer::new(&bvh), &options).film;
        (options, bits(&image))
    };
    let laggard = vec!["cpu1".to_string()];
    // Speeds unknown: every device first, which measures them (again, where a loaded
    // machine woke the laggard too late to run a task); then the fastest class alone; then
    // every device as planned at those speeds, the frame the choice weighs against the one
    // alone; then the faster way, for good.
    let attempt = || -> Result<PathRenderer, String> {
        let mut devices = cpus(2);
        let lagging = devices.remove(1);
        devices.push(Box::new(SlowEstimates {
            inner: lagging,
            millis: 400,
        }));
        let mut r = PathRenderer::new(devices, settings(Policy::Hybrid, Mode::Cost, 64)).unwrap();
        let idle: Vec<Vec<String>> = (0..8)
            .map(|k| {
                let (options, reference) = frame_of(k);
                let frame = r.render(&scene, &bvh, &options).expect("frame");
                assert_eq!(bits(&frame.film), reference);
                frame.stats.left_idle
            })
            .collect();
        let frames = r.stats();
        let timed: Vec<_> = (frames.iter().zip(&idle))
            .map(|(f, i)| (i.clone(), f.seconds, f.estimate_seconds))
            .collect();
        let seconds = |alone: bool| {
            (frames.iter().zip(&idle))
                .filter(move |(_, i)| i.is_empty() != alone)
                .map(|(f, _)| f.seconds)
        };
        let slowest_alone = seconds(true).fold(0.0, f64::max);
        let settled = idle[0].is_empty() && idle[5..].iter().all(|i| *i == laggard);
        if settled && seconds(false).all(|s| s > slowest_alone) {
            Ok(r)
        } else {
            Err(format!("{timed:?}"))
        }
    };
    // The choice follows wall-clock times, which other processes on a loaded machine can
    // invert for a frame or two (a class measured slower than it is): three renderers, and
    // one must settle as stated.
    let mut failed = Vec::new();
    let r = loop {
        match attempt() {
            Ok(r) => break r,
            Err(e) if failed.len() < 2 => failed.push(e),
            Err(e) => panic!("{failed:?} {e}"),
        }
    };

    let kept = r.into_kept().expect("no device failed");
    let mut next = PathRenderer::from_kept(kept, settings(Policy::StaticLpt, Mode::Cost, 128));
    let frame = next
        .as_mut()
        .unwrap()
        .render(&scene, &bvh, &options)
        .unwrap();
    assert_eq!(
        frame.stats.left_idle, laggard,
        "the choice is kept with the devices"
    );
    assert_eq!(bits(&frame.film), reference);
    // Another mode's frames cost otherwise and are measured afresh: the fastest class alone
    // first, as the other mode found it, then every device (regular mode estimates nothing,
    // and the laggard, planned at its speed, holds no frame).
    let mut regular = PathRenderer::from_kept(
        next.unwrap().into_kept().unwrap(),
        settings(Policy::Hybrid, Mode::Regular, 64),
    )
    .unwrap();
    let frame = regular.render(&scene, &bvh, &options).unwrap();
    assert_eq!(frame.stats.left_idle, laggard);
    let frame = regular.render(&scene, &bvh, &options).unwrap();
    assert!(frame.stats.left_idle.is_empty());
    assert_eq!(bits(&frame.film), reference);
}

/// When every device of the class rendering alone fails, the devices it left idle render the
/// frame: the same image, and the failure reported under the renderer's index.
#[test]
fn the_idle_devices_take_over_when_the_fastest_fail() {
    let _cores = one_at_a_time();
    let (scene, bvh, options, reference) = small_forest(SHADERS[0]);
    let mut devices = cpus(2);
    let lagging = devices.remove(1);
    // 30 tasks a frame: the fast device renders most of the first (the laggard holds its
    // launch 40 ms) and fails during the second, which it renders alone.
    let fast = failing(devices.remove(0), 30);
    let devices: Vec<Box<dyn PathDevice>> = vec![fast, laggard(lagging)];
    // As planned: with backups the fastest device would take over the laggard's tasks.
    let s = Settings {
        backups: false,
        ..settings(Policy::Hybrid, Mode::Regular, 64)
    };
    let mut r = PathRenderer::new(devices, s).unwrap();
    let first = r.render(&scene, &bvh, &options).expect("first frame");
    assert!(
        first.stats.failures.is_empty(),
        "{:?}",
        first.stats.failures
    );
    let second = r
        .render(&scene, &bvh, &options)
        .expect("the laggard takes over");
    assert_eq!(bits(&second.film), reference);
    assert_eq!(
        second.stats.failures.len(),
        1,
        "{:?}",
        second.stats.failures
    );
    assert_eq!(second.stats.failures[0].device, 0);
    assert_eq!(second.stats.devices.len(), 1);
    assert_eq!(second.stats.devices[0].name, "cpu1");
}

/// A device that fails mid-frame has its paths rendered by the other: the same image, the
/// failure and the re-runs reported, and the device left out of the next frame.
#[test]
fn a_device_lost_mid_frame_changes_nothing() {
    let _cores = one_at_a_time();
    for shader in SHADERS {
        let (scene, bvh, options, reference) = small_forest(shader);
        for policy in [Policy::StaticLpt, Policy::QueueFifo, Policy::Hybrid] {
            let renderer = || {
                let mut devices = cpus(2);
                let failing = devices.remove(1);
                let healthy = devices.remove(0);
                // A millisecond more per launch: under a queue policy the other device then
                // gets tasks of its own, however the threads are scheduled.
                devices.push(Box::new(Delayed {
                    inner: healthy,
                    millis: 1,
                    class: None,
                }));
                devices.push(self::failing(failing, 2));
                PathRenderer::new(devices, settings(policy, Mode::Cost, 64)).expect("r")
            };
            // On a loaded machine the failing device's thread may wake only once the other
            // has rendered (or copied) every task: that frame has nothing failed, and the
            // test takes another renderer, three at most.
            let (mut r, out) = (0..3)
                .map(|_| {
                    let mut r = renderer();
                    let out = r.render(&scene, &bvh, &options).expect("frame");
                    assert_eq!(bits(&out.film), reference, "{policy:?}");
                    (r, out)
                })
                .find(|(_, out)| !out.stats.failures.is_empty())
                .expect("the device failed in one of three frames");
            assert_eq!(out.stats.failures.len(), 1, "{policy:?}");
            assert_eq!(out.stats.failures[0].device, 1);
            let next = r.render(&scene, &bvh, &options).expect("next frame");
            assert_eq!(bits(&next.film), reference);
            assert_eq!(next.stats.devices.len(), 1, "the failed device is retired");
        }
    }
}

/// When every device fails, the frame is an error naming them, never a partial image.
#[test]
fn a_frame_without_devices_left_is_an_error() {
    let _cores = one_at_a_time();
    let shader = SHADERS[0];
    let (scene, bvh) = scene("builtin:cornell:0.2", &shader);
    let options = RenderOptions::new(16, 16, Camera::orbit(&scene.bounds(), 0), shader);
    let devices: Vec<Box<dyn PathDevice>> = cpus(2).into_iter().map(|d| failing(d, 0)).collect();
    let mut r = PathRenderer::new(devices, Settings::default()).expect("r");
    let e = r
        .render(&scene, &bvh, &options)
        .expect_err("no device works");
    assert!(e.to_string().contains("injected fault"), "{e}");
}

/// A device list that names an adapter that does not exist, or a fault on a device that is
/// not in it, is an error naming the entry; so is a renderer without devices.
#[test]
fn bad_device_lists_and_faults_are_named() {
    let _cores = one_at_a_time();
    use crate::devices::parse_devices;
    use crate::paths::{FailAfter, build_path_devices};
    let shader = SHADERS[0];
    let (scene, bvh) = scene("builtin:cornell:0.2", &shader);
    let specs = parse_devices("cpu:1,gpu:99").expect("a valid list");
    let e = build_path_devices(&scene, &bvh, &specs, &[], &[])
        .err()
        .expect("no adapter 99")
        .to_string();
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
    let specs = parse_devices("cpu:2").expect("a valid list");
    let e = build_path_devices(&scene, &bvh, &specs, &fault, &[])
        .err()
        .expect("no device 2");
    assert!(e.to_string().contains("2@1"), "{e}");
    assert!(PathRenderer::new(Vec::new(), Settings::default()).is_err());
}

/// A 64 × 64 AO frame of a small forest from orbit camera 0.
fn forest_64() -> (Scene, Bvh, RenderOptions) {
    let shader = SHADERS[0];
    let (scene, bvh) = scene("builtin:forest:0.05", &shader);
    let options = RenderOptions::new(64, 64, Camera::orbit(&scene.bounds(), 0), shader);
    (scene, bvh, options)
}

/// Each task's cost in the default model.
fn costs(work: Vec<crate::cost::Work>) -> Vec<f64> {
    let model = crate::cost::CostModel::default();
    work.into_iter().map(|w| model.cost(w)).collect()
}

/// The costs of `tasks` of `frame` from a sample of their paths traced for real at `rate`.
fn sampled_costs(
    frame: &crate::paths::Frame<'_>,
    tasks: &[std::ops::Range<usize>],
    rate: sched::SampleRate,
) -> Vec<f64> {
    let sampled = crate::paths::sample_paths(frame, tasks, rate, crate::Layout::Wide);
    costs(sampled.into_iter().map(|s| s.work).collect())
}

/// The cost of a task, estimated from a sample of its paths traced for real, ranks tasks as
/// their measured work does: a task of sky costs less than a task of forest.
#[test]
fn sampled_paths_rank_tasks_by_their_work() {
    let _cores = one_at_a_time();
    use crate::paths::Frame;
    let (scene, bvh, options) = forest_64();
    let frame = Frame {
        scene: &scene,
        bvh: &bvh,
        options: &options,
    };
    let tasks = sched::split_ranges(64 * 64, 256);
    let full = sampled_costs(&frame, &tasks, sched::SampleRate::FULL);
    let sampled = sampled_costs(&frame, &tasks, sched::SampleRate::THESIS);
    let error = sched::prediction_error(&sampled, &full).expect("tasks");
    assert!(error < 0.25, "error {error}");
    let (lo, hi) = full
        .iter()
        .fold((f64::MAX, 0.0f64), |(lo, hi), &c| (lo.min(c), hi.max(c)));
    assert!(hi > 2.0 * lo, "tasks differ in work: {lo}..{hi}");
}

/// The thesis's walks of the sampled paths' camera rays: at the full rate they are exactly the
/// walk of every camera ray of the task, they rank the tasks as the rendered sample does
/// (Spearman's rank correlation), and a frame planned by them is the reference image.
#[test]
fn the_thesis_walks_estimate_camera_rays_and_leave_the_image_alone() {
    let _cores = one_at_a_time();
    use crate::Walk;
    use crate::cost::Work;
    use crate::paths::{Frame, walk_paths};
    let (scene, bvh, options) = forest_64();
    let frame = Frame {
        scene: &scene,
        bvh: &bvh,
        options: &options,
    };
    let tasks = sched::split_ranges(64 * 64, 256);
    let traced = sampled_costs(&frame, &tasks, sched::SampleRate::FULL);
    for walk in Walk::ALL {
        let full = walk_paths(&frame, &tasks, sched::SampleRate::FULL, walk);
        let rays = options.camera.primary_rays_of(64, 64, 0..256).rays;
        let first = crate::traverse::reduced_counts(&bvh, &rays, walk, 0..256);
        assert_eq!(full[0], Work::sum(&first).scaled(256, 256), "{walk:?}");
        let sampled = costs(walk_paths(&frame, &tasks, sched::SampleRate::THESIS, walk));
        let rank = sched::rank_correlation(&sampled, &traced).expect("tasks");
        assert!(rank > 0.5, "{walk:?}: rank correlation {rank}");
    }
    let reference = bits(&render(&scene, &mut CpuTracer::new(&bvh), &options).film);
    for walk in Walk::ALL {
        let s = Settings {
            walk,
            ..settings(Policy::StaticLpt, Mode::Cost, 128)
        };
        let mut r = PathRenderer::new(cpus(2), s).expect("renderer");
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        assert!(frame.stats.estimated, "{walk:?}");
        assert_eq!(bits(&frame.film), reference, "{walk:?}");
    }
}

/// A frame is predicted once an earlier frame of its shader measured every device class, in
/// this renderer or the one its devices were kept from; the prediction is a makespan a
/// frame could take (positive, finite, within a wide factor of the measured one: timings on a
/// shared machine move).
#[test]
fn frames_are_predicted_once_their_classes_were_measured() {
    let _cores = one_at_a_time();
    let shader = SHADERS[0];
    let (scene, bvh, options, _) = small_forest(shader);
    let mut r = PathRenderer::new(cpus(2), settings(Policy::StaticLpt, Mode::Cost, 64)).unwrap();
    let first = r.render(&scene, &bvh, &options).expect("frame").stats;
    assert_eq!(first.predicted_makespan, None);
    let second = r.render(&scene, &bvh, &options).expect("frame").stats;
    let p = second.predicted_makespan.expect("predicted");
    assert!(
        p.is_finite() && p > 0.0 && p < 100.0 * second.makespan,
        "{p}"
    );
    // The next renderer over the same devices predicts its first frame of the shader, and
    // not a frame of another one.
    let kept = r.into_kept().expect("no device failed");
    let mut next = PathRenderer::from_kept(kept, settings(Policy::QueueFifo, Mode::Regular, 64));
    let next = next.as_mut().expect("renderer");
    let frame = next.render(&scene, &bvh, &options).expect("frame").stats;
    assert!(frame.predicted_makespan.is_some());
    let whitted = RenderOptions::new(48, 40, options.camera, SHADERS[1]);
    let other = next.render(&scene, &bvh, &whitted).expect("frame").stats;
    assert_eq!(other.predicted_makespan, None);
}

/// A device of its own class and estimate kind, counting the estimates it is asked for.
struct Kinded {
    inner: Box<dyn PathDevice>,
    kind: &'static str,
    estimates: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl PathDevice for Kinded {
    fn render(
        &mut self,
        frame: &crate::paths::Frame<'_>,
        tasks: &[&std::ops::Range<usize>],
    ) -> Result<crate::paths::Launch, sched::DeviceError> {
        self.inner.render(frame, tasks)
    }

    fn estimate(
        &mut self,
        frame: &crate::paths::Frame<'_>,
        tasks: &[&std::ops::Range<usize>],
        rate: sched::SampleRate,
        walk: crate::traverse::Walk,
    ) -> Result<crate::paths::Estimate, sched::DeviceError> {
        self.estimates
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        self.inner.estimate(frame, tasks, rate, walk)
    }

    fn estimate_kind(&self) -> &'static str {
        self.kind
    }

    fn name(&self) -> String {
        self.inner.name()
    }

    fn class(&self) -> String {
        self.kind.to_owned()
    }
}

/// Devices of two kinds, the one listed first the slower: the frame's tasks are estimated by
/// the faster one's kind, never at the slower one's pace, and the image does not change.
#[test]
fn the_fastest_devices_kind_estimates_the_frame() {
    let _cores = one_at_a_time();
    use crate::calibration::{Calibration, Entry, Key};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};

    let (scene, bvh, options, reference) = small_forest(SHADERS[1]);
    let counts = [Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0))];
    let devices: Vec<Box<dyn PathDevice>> = cpus(2)
        .into_iter()
        .zip(["slow", "fast"])
        .zip(&counts)
        .map(|((inner, kind), c)| {
            Box::new(Kinded {
                inner,
                kind,
                estimates: Arc::clone(c),
            }) as Box<dyn PathDevice>
        })
        .collect();
    let mut r = PathRenderer::new(devices, Settings::default()).expect("renderer");
    // Speeds known before the first frame, as a calibration file gives them.
    let mut calibration = Calibration::new();
    for (class, rate) in [("slow", 1e5), ("fast", 1e6)] {
        let entry = Entry {
            speed: 1.0,
            paths_per_second: Some(rate),
            samples: 8,
            ..Entry::default()
        };
        calibration.insert(Key::new("host", class, "w"), entry);
    }
    assert_eq!(r.recall(&calibration, "host", "w"), 2);
    // The first two frames run each way once: on both devices, and on the faster alone.
    let mut estimated = 0;
    for _ in 0..2 {
        let out = r.render(&scene, &bvh, &options).expect("frame");
        assert_eq!(bits(&out.film), reference);
        estimated += usize::from(out.stats.estimated);
    }
    assert_eq!(estimated, 1, "one frame on both devices, estimated");
    assert_eq!(
        counts[0].load(Ordering::SeqCst),
        0,
        "the slower kind estimated"
    );
    assert!(counts[1].load(Ordering::SeqCst) > 0);
}

/// A frame of the same scene, camera, tasks and sampling as the last one estimated takes that
/// estimate at no cost, in this renderer and in one that takes over its devices (a bench's
/// next cell); another camera or other tasks are estimated anew, and the image never changes.
#[test]
fn an_unchanged_frame_reuses_the_last_estimate() {
    let _cores = one_at_a_time();
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};

    let (scene, bvh, options, reference) = small_forest(SHADERS[1]);
    let count = Arc::new(AtomicUsize::new(0));
    let devices: Vec<Box<dyn PathDevice>> = (cpus(2).into_iter())
        .map(|inner| {
            Box::new(Kinded {
                inner,
                kind: "host",
                estimates: Arc::clone(&count),
            }) as Box<dyn PathDevice>
        })
        .collect();
    let lpt = settings(Policy::StaticLpt, Mode::Cost, 64);
    let mut r = PathRenderer::new(devices, lpt).expect("renderer");
    let frame = |r: &mut PathRenderer<'_>, options: &RenderOptions| {
        let before = count.load(Ordering::SeqCst);
        let out = r.render(&scene, &bvh, options).expect("frame");
        let asked = count.load(Ordering::SeqCst) - before;
        let stats = out.stats;
        assert!(stats.estimated);
        assert_eq!(stats.estimate_reused, asked == 0, "{asked} estimates asked");
        (bits(&out.film), stats)
    };
    let (image, first) = frame(&mut r, &options);
    assert_eq!(image, reference);
    assert!(!first.estimate_reused);
    let (image, second) = frame(&mut r, &options);
    assert_eq!(image, reference);
    assert!(second.estimate_reused);
    let costs = |s: &crate::paths::FrameStats| -> Vec<u64> {
        s.task_stats.iter().map(|t| t.cost.to_bits()).collect()
    };
    assert_eq!(
        costs(&second),
        costs(&first),
        "the same work, in the same model"
    );
    let moved = RenderOptions::new(48, 40, Camera::orbit(&scene.bounds(), 1), SHADERS[1]);
    assert!(!frame(&mut r, &moved).1.estimate_reused);
    assert!(frame(&mut r, &moved).1.estimate_reused);
    // The next cell: the same frame and tasks under another policy reuse; other tasks do not.
    let kept = r.into_kept().expect("no device failed");
    let sorted = settings(Policy::QueueSorted, Mode::Cost, 64);
    let mut next = PathRenderer::from_kept(kept, sorted).expect("renderer");
    assert!(frame(&mut next, &moved).1.estimate_reused);
    let kept = next.into_kept().expect("no device failed");
    let smaller = settings(Policy::QueueSorted, Mode::Cost, 32);
    let mut next = PathRenderer::from_kept(kept, smaller).expect("renderer");
    assert!(!frame(&mut next, &moved).1.estimate_reused);
}

/// Beside a device five times slower, once both classes' speeds are measured, a frame on
/// both is cut into tasks the slow one renders within 2 % of the frame's expected time (at
/// most 2 % of the paths over two): its last task cannot hold the frame. The image does not
/// change; the devices' paths add up to the frame's.
#[test]
fn tasks_are_cut_small_for_the_slowest_device() {
    let _cores = one_at_a_time();
    let shader = SHADERS[0];
    let (scene, bvh) = scene("builtin:forest:0.05", &shader);
    let options = RenderOptions::new(256, 192, Camera::orbit(&scene.bounds(), 0), shader);
    let reference = bits(&render(&scene, &mut CpuTracer::new(&bvh), &options).film);
    let slow = crate::paths::SlowBy {
        device: 1,
        factor: 5.0,
    };
    let devices = InjectedPaths::wrap(cpus(2), &[], &[slow]);
    let lpt = settings(Policy::StaticLpt, Mode::Cost, 4096);
    let mut r = PathRenderer::new(devices, lpt).expect("renderer");
    // Ten frames: on a loaded machine the slow device may deliver nothing (the other copies
    // its tasks first) for a few before one measures both.
    let frames: Vec<_> = (0..10)
        .map(|_| {
            let frame = r.render(&scene, &bvh, &options).expect("frame");
            assert_eq!(bits(&frame.film), reference);
            frame.stats
        })
        .collect();
    let paths = 256 * 192;
    for f in &frames {
        let rendered: usize = f.devices.iter().map(|d| d.paths).sum();
        assert_eq!(rendered, paths);
    }
    // Speeds unknown: the size asked for.
    assert_eq!(frames[0].task_size, 4096);
    // Every frame on both devices after one that measured both (the choice weighs one at
    // least, against a frame on the faster alone).
    let measured = (frames.iter())
        .position(|f| f.devices.len() == 2 && f.devices.iter().all(|d| d.paths > 0))
        .expect("a frame measured both devices");
    // 2 % of the paths over two, rounded up to a whole path as the planner rounds a task: on
    // a loaded machine the slow device may be measured as fast as the other, which gives
    // exactly that.
    let most = (paths as f64 / 100.0).ceil() as usize;
    let most = most.max(crate::paths::Settings::MIN_TASK_RAYS);
    let planned: Vec<usize> = (frames[measured + 1..].iter())
        .filter(|f| f.left_idle.is_empty())
        .map(|f| f.task_size)
        .collect();
    assert!(!planned.is_empty(), "{frames:?}");
    assert!(
        planned.iter().all(|&size| size <= most),
        "{planned:?} paths"
    );
}

/// A device two hundred times slower, whose every task a faster device's copy beats, delivers
/// nothing, yet is not planned at its old speed again: the renderer holds its speed to what
/// it could have rendered (less than a task in the frame). The image does not change.
#[test]
fn a_device_that_never_delivers_is_planned_slower() {
    let _cores = one_at_a_time();
    let shader = SHADERS[0];
    let (scene, bvh, options, reference) = small_forest(shader);
    let slow = crate::paths::SlowBy {
        device: 1,
        factor: 200.0,
    };
    let devices = InjectedPaths::wrap(cpus(2), &[], &[slow]);
    let lpt = settings(Policy::StaticLpt, Mode::Cost, 64);
    let mut r = PathRenderer::new(devices, lpt).expect("renderer");
    // On a loaded machine the slow device's thread may wake only once the other has copied
    // every task, and launch nothing: such a frame says nothing of it, and the next is taken
    // (three at most).
    let launched = (0..3).any(|_| {
        let frame = r.render(&scene, &bvh, &options).expect("frame");
        assert_eq!(bits(&frame.film), reference);
        frame
            .stats
            .devices
            .iter()
            .any(|d| d.index == 1 && d.launches > 0)
    });
    assert!(launched, "the slow device launched in one of three frames");
    assert!(
        r.speed(1) < 0.2 * r.speed(0),
        "{} {}",
        r.speed(0),
        r.speed(1)
    );
}
