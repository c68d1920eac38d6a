//! `cobalt estimate`: how well an estimate of each task's cost predicts its measured time,
//! and what estimating costs a render (see `raytrace::cost::metrics`).
//!
//! For one generation of rays cut into tasks it leads with the error and rank correlation of
//! the calibrated estimates against each task's measured single-thread trace time, beside
//! their bound (the real trace's own counts) and the net overhead; the thesis's prediction
//! error (against the probe's full count) and overhead (estimation time over the full trace
//! time, both on all cores) follow. On the CPU every probe is timed in the same rounds, so the
//! report holds the whole trade.

use std::path::Path;
use std::time::Instant;

use raytrace::cost::{
    Compacted, CostModel, Fit, ReducedTraversal, SampleRate, Work, calibrate, error_vs_time,
    full_work, measure_seconds, prediction_error, spearman,
};
use raytrace::shade::{CpuTracer, Recorder, RenderOptions, Shader, WhittedSettings, render};
use raytrace::{Bvh, Camera, Probe, RayBatch, RayKind, SceneNeeds, SceneSource, traverse};
use serde::Serialize;

use crate::error::CliError;

/// Seed of the AO rays' per-pixel scrambling: fixed, so runs are comparable.
const AO_SEED: u64 = 1;

/// The device name calibrations are recorded under: one CPU thread, as measured.
const DEVICE: &str = "cpu-thread";

/// Arguments of `cobalt estimate`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: crate::args::SceneArgs,
    /// `primary` (camera rays), `ao` (32 Halton AO rays per primary hit), `whitted` (every
    /// generation of a Whitted render: primary, shadow and two bounces of reflection rays,
    /// each cut into its own tasks) or a binary ray file (`f32 × 8` per ray, see
    /// `cobalt trace`).
    #[arg(long)]
    rays: String,
    /// Rays per task.
    #[arg(long, default_value_t = 4096)]
    task_size: usize,
    /// Fraction of each task's rays traced by the estimator, in (0, 1].
    #[arg(long, default_value_t = 0.125)]
    sample_rate: f64,
    /// Image size `WxH` of the camera rays.
    #[arg(long, default_value = "512x512")]
    size: crate::args::Size,
    /// Orbit camera 0..3: above one quadrant of the scene, looking at its centre.
    #[arg(long, default_value = "0", value_parser = crate::args::camera_index)]
    camera: usize,
    /// AO rays per primary hit.
    #[arg(long, default_value_t = 32)]
    ao_samples: u32,
    /// Length of AO rays as a fraction of the scene's bounding-box diagonal.
    #[arg(long, default_value_t = 0.05)]
    ao_distance: f32,
    /// Kind of the rays of a ray file (primary, shadow, reflection, ao): decides closest- or
    /// any-hit tracing.
    #[arg(long, default_value = "primary")]
    ray_kind: String,
    /// Every timing is repeated this many times and the least kept.
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Where the estimator and the full trace run: `cpu` (all cores) or `gpu` (the first
    /// usable adapter; software ones only with `COBALT_GPU_SOFTWARE=1`): sampling,
    /// compaction, reduced traversal and per-task sums on the device, the same estimates as
    /// the CPU's. Measured task times (the calibration) stay single-thread CPU times.
    #[arg(long, value_enum, default_value = "cpu")]
    device: DeviceArg,
    /// How the sample is traced: `trace` (the real trace, closest or any hit, counted as
    /// traced, its hits kept for the render; the default on the CPU), `thesis` (the reduced
    /// traversal of the whole range of every ray; the default, and the only one, on the
    /// GPU), `first-leaf` (closest-hit rays end at the exit of the first leaf they reach;
    /// shadow and AO rays keep the thesis's probe), or `auto`: the reduced traversal whose
    /// full counts, calibrated, err least against the measured task times.
    #[arg(long)]
    probe: Option<ProbeArg>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// `--probe`: one reduced traversal, or the better fit of both.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ProbeArg {
    Fixed(Probe),
    Auto,
}

impl std::str::FromStr for ProbeArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim() == "auto" {
            return Ok(Self::Auto);
        }
        s.parse().map(Self::Fixed).map_err(|_| {
            format!("unknown probe `{s}` (expected thesis, first-leaf, trace or auto)")
        })
    }
}

impl std::fmt::Display for ProbeArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Fixed(p) => p.name(),
            Self::Auto => "auto",
        })
    }
}

/// How well one probe's full reduced traversal, calibrated, explains the measured times.
#[derive(Debug, Serialize)]
struct ProbeFit {
    probe: &'static str,
    error_vs_time: Option<f64>,
    spearman_vs_time: Option<f64>,
}

/// One estimator's trade on the CPU: what its sample predicts of the measured times, and what
/// it costs a render.
#[derive(Debug, Serialize)]
struct ProbeFigures {
    probe: &'static str,
    /// Its sampled estimates, calibrated, against the measured task times.
    error_vs_time: Option<f64>,
    spearman_vs_time: Option<f64>,
    /// The thesis's, against the probe's own full count.
    prediction_error: Option<f64>,
    estimate_seconds: f64,
    overhead: f64,
    /// Overhead less the sample's trace where the render reuses its hits (the trace probe).
    net_overhead: f64,
}

/// Where the estimate runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum DeviceArg {
    /// All CPU cores.
    Cpu,
    /// The first usable GPU adapter.
    Gpu,
}

/// A calibrated model, for the report.
#[derive(Debug, Serialize)]
struct Calibration {
    device: &'static str,
    kb: f64,
    kt: f64,
    r2: f64,
    rms_residual: f64,
    n: usize,
    form: &'static str,
}

impl From<Fit> for Calibration {
    fn from(f: Fit) -> Self {
        Self {
            device: DEVICE,
            kb: f.model.kb,
            kt: f.model.kt,
            r2: f.r2,
            rms_residual: f.rms_residual,
            n: f.n,
            form: f.form.name(),
        }
    }
}

/// Everything is a fraction (not a percentage); a metric that is undefined for the input
/// (one task, all rays missing the scene) is `null`.
#[derive(Debug, Serialize)]
struct Report {
    /// The estimator judged by time: its calibrated estimates against each task's measured
    /// single-thread trace time.
    error_vs_time: Option<f64>,
    spearman_vs_time: Option<f64>,
    /// The same with each task's exact counts of the real trace (closest or any hit, as
    /// traced): what no estimate of `B` and `T` can beat, whatever its probe and rate. What
    /// is left is time the counts do not see (caches, branches, the machine).
    error_vs_time_trace: Option<f64>,
    spearman_trace_vs_time: Option<f64>,
    /// `(estimate + rest − full trace) / full trace`, where `rest` is the full trace less
    /// the sampled rays when the probe traces them for real (a render takes their hits from
    /// the estimate), else the full trace: what estimating costs a render.
    net_overhead: f64,
    scene: String,
    triangles: usize,
    preset: String,
    ray_kind: &'static str,
    coherent: bool,
    rays: usize,
    task_size: usize,
    tasks: usize,
    sample_rate: f64,
    /// `trace`, `thesis` or `first-leaf` (applied to closest-hit generations only): the one
    /// asked for, or the better fit with `--probe auto`.
    probe: &'static str,
    /// With `--probe auto`: how each probe fitted the measured times.
    probe_fits: Option<Vec<ProbeFit>>,
    /// On the CPU: every probe's trade at this sample rate, timed in the same rounds.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    probes: Vec<ProbeFigures>,
    sampled_rays: usize,
    threads: usize,
    repeats: usize,
    /// Where the estimate and the full trace ran: `cpu` or `gpu`.
    device: &'static str,
    /// The GPU adapter's name with `--device gpu`.
    #[serde(skip_serializing_if = "Option::is_none")]
    adapter: Option<String>,
    /// The thesis's (secondary: it judges the sample against its own probe's full count, not
    /// against time): Σ|est − full| / Σ full of `C` under the default model.
    prediction_error: Option<f64>,
    /// The same for `B` and for `T` alone.
    prediction_error_nodes: Option<f64>,
    prediction_error_tris: Option<f64>,
    /// Reduced traversal of the sample, gather included, on all cores (or on the GPU, the
    /// rays' upload included).
    estimate_seconds: f64,
    /// Full trace (closest or any hit, with triangle tests) of all rays, on all cores (or on
    /// the GPU, upload and read-back included).
    trace_seconds: f64,
    overhead: f64,
    /// With `--probe trace` on the CPU: the full trace less the sampled rays, which a render
    /// takes from the estimate instead of tracing them again.
    #[serde(skip_serializing_if = "Option::is_none")]
    rest_seconds: Option<f64>,
    /// The error against time with full counts: the best any sample rate could do.
    error_vs_time_full: Option<f64>,
    spearman_full_vs_time: Option<f64>,
    /// Σ measured task times (one thread).
    measured_seconds: f64,
    /// Mean `B`, `T` per ray of the reduced traversal and of the real trace (an any-hit
    /// trace counts up to its first hit): the reduced traversal never shortens a ray, so it
    /// enters more nodes than the trace does, which bounds how cheap a sample can be.
    reduced_nodes_per_ray: f64,
    reduced_tris_per_ray: f64,
    trace_nodes_per_ray: f64,
    trace_tris_per_ray: f64,
    default_model: Model,
    calibration: Option<Calibration>,
    build_seconds: f64,
}

#[derive(Debug, Serialize)]
struct Model {
    kb: f64,
    kt: f64,
}

/// Runs the command: all arguments are checked before the scene is loaded.
pub fn run(args: Args) -> Result<(), CliError> {
    let arg = |flag: &'static str, value: &dyn ToString, message: String| CliError::Arg {
        flag,
        value: value.to_string(),
        message,
    };
    let preset = args.scene.preset;
    let rate = SampleRate::new(args.sample_rate)
        .map_err(|e| arg("sample-rate", &args.sample_rate, e.to_string()))?;
    if args.task_size == 0 {
        return Err(arg("task-size", &0, "must be at least 1".into()));
    }
    if args.repeats == 0 {
        return Err(arg("repeats", &0, "must be at least 1".into()));
    }
    if !(args.ao_distance.is_finite() && args.ao_distance > 0.0) {
        return Err(arg(
            "ao-distance",
            &args.ao_distance,
            "must be positive".into(),
        ));
    }
    let crate::args::Size { width, height } = args.size;
    let source = RaySource::parse(&args.rays, &args.ray_kind)?;

    let needs = if matches!(source, RaySource::Whitted) {
        SceneNeeds::WHITTED
    } else {
        SceneNeeds::AO
    };
    let scene = SceneSource::parse(&args.scene.scene)?.load(needs)?;
    let bvh = Bvh::build(&scene, preset)?;
    let camera = Camera::orbit(&scene.bounds(), args.camera);
    // One segment per generation: tasks never straddle two generations, and each is traced
    // with its own query (closest or any hit).
    let (segments, kind_name, coherent): (Vec<(RayBatch, RayKind)>, &'static str, bool) =
        match source {
            RaySource::Primary => (
                vec![(camera.primary_rays(width, height).rays, RayKind::Primary)],
                RayKind::Primary.name(),
                true,
            ),
            RaySource::Ao => {
                let primary = camera.primary_rays(width, height).rays;
                let hits = traverse::closest_hits(&bvh, &primary);
                let length = args.ao_distance * scene.bounds().extent().length();
                let ao = raytrace::ao::ao_rays(
                    &scene,
                    &primary,
                    &hits,
                    args.ao_samples,
                    length,
                    AO_SEED,
                );
                (vec![(ao.rays, RayKind::Ao)], RayKind::Ao.name(), false)
            }
            RaySource::Whitted => {
                let mut rec = Recorder::new(CpuTracer::new(&bvh));
                let options = RenderOptions::new(
                    width,
                    height,
                    camera,
                    Shader::Whitted(WhittedSettings::default()),
                );
                render(&scene, &mut rec, &options);
                let gens = rec.generations.into_iter().map(|(k, r)| (r, k)).collect();
                (gens, "whitted", true)
            }
            RaySource::File(path, kind) => (
                vec![(crate::trace::read_rays(Path::new(&path))?, kind)],
                kind.name(),
                kind.is_coherent(),
            ),
        };
    let mut rays = RayBatch::default();
    let mut tasks = Vec::new();
    // Per generation, its tasks (indices into `tasks`) and kind: the first-leaf probe models
    // a closest hit, not an any-hit query (`Probe::for_kind`).
    let mut parts = Vec::new();
    for (batch, kind) in &segments {
        let base = rays.len();
        let first = tasks.len();
        tasks.extend(
            sched::split_ranges(batch.len(), args.task_size)
                .into_iter()
                .map(|t| base + t.start..base + t.end),
        );
        parts.push((first..tasks.len(), *kind));
        rays.extend(batch);
    }
    if rays.is_empty() {
        return Err(arg(
            "rays",
            &args.rays,
            "there are no rays to estimate (no primary ray hit the scene?)".into(),
        ));
    }

    let mut measured = Vec::with_capacity(tasks.len());
    for (batch, kind) in &segments {
        let own = sched::split_ranges(batch.len(), args.task_size);
        measured.extend(measure_seconds(&bvh, batch, &own, *kind, args.repeats)?);
    }
    // `work` weighed by `fit` against the measured times: error and Spearman correlation.
    let vs_time = |fit: Option<Fit>, work: &[Work]| {
        let predicted = fit.map(|f| f.model.costs(work));
        (
            predicted
                .as_ref()
                .and_then(|p| error_vs_time(p, &measured).ok()),
            predicted.as_ref().and_then(|p| spearman(p, &measured).ok()),
        )
    };
    let full_of = |probe: Probe| -> Result<Vec<Work>, CliError> {
        let mut full = Vec::with_capacity(tasks.len());
        for (range, kind) in &parts {
            let own = &tasks[range.clone()];
            full.extend(full_work(&bvh, &rays, own, probe.for_kind(*kind))?);
        }
        Ok(full)
    };
    // The real trace where it can run: its hits are the render's, so it costs little more
    // than counting, and it stops where the trace stops, which the reduced traversals do not.
    let asked = args.probe.unwrap_or(match args.device {
        DeviceArg::Cpu => ProbeArg::Fixed(Probe::Trace { any: false }),
        DeviceArg::Gpu => ProbeArg::Fixed(Probe::Thesis),
    });
    if let (ProbeArg::Fixed(Probe::Trace { .. }), DeviceArg::Gpu) = (asked, args.device) {
        return Err(arg(
            "probe",
            &"trace",
            "the `trace` probe runs on the CPU only; use thesis or first-leaf with --device gpu"
                .into(),
        ));
    }
    let (probe, full, probe_fits) = match asked {
        ProbeArg::Fixed(p) => (p, full_of(p)?, None),
        ProbeArg::Auto => {
            let mut fits = Vec::new();
            let mut best = (f64::INFINITY, Probe::Thesis, Vec::new());
            for p in Probe::ALL {
                let full = full_of(p)?;
                let (error, spearman_vs_time) = vs_time(calibrate(&full, &measured).ok(), &full);
                fits.push(ProbeFit {
                    probe: p.name(),
                    error_vs_time: error,
                    spearman_vs_time,
                });
                // Ties and failed fits keep the thesis's probe, tried first.
                if best.2.is_empty() || error.is_some_and(|e| e < best.0) {
                    best = (error.unwrap_or(f64::INFINITY), p, full);
                }
            }
            (best.1, best.2, Some(fits))
        }
    };

    // Each generation's tasks and the probe that estimates them.
    let jobs_of = |probe: Probe| -> Vec<(&[std::ops::Range<usize>], Probe)> {
        parts
            .iter()
            .map(|(range, kind)| (&tasks[range.clone()], probe.for_kind(*kind)))
            .collect()
    };
    let jobs = jobs_of(probe);
    let (estimate_seconds, est, trace_seconds, rest_seconds, adapter, probes) = match args.device {
        DeviceArg::Cpu => {
            // Every probe is timed, the asked one among them, so that the trade is one table.
            let mut candidates = vec![Probe::Trace { any: false }, Probe::Thesis, Probe::FirstLeaf];
            let chosen = candidates
                .iter()
                .position(|p| p.name() == probe.name())
                .unwrap_or_else(|| {
                    candidates.push(probe);
                    candidates.len() - 1
                });
            // A render does not trace the trace probe's sampled rays again (their hits are
            // the estimate's), so what is left of the trace is timed too: per generation, its
            // sample.
            let known: Vec<Vec<usize>> = segments
                .iter()
                .map(|(batch, _)| {
                    let own = sched::split_ranges(batch.len(), args.task_size);
                    Compacted::gather(batch, &own, rate).map(|c| c.index)
                })
                .collect::<Result<_, _>>()?;
            let estimator = ReducedTraversal::new(&bvh, &rays, rate);
            let mut ests: Vec<Vec<Work>> = vec![Vec::new(); candidates.len()];
            let mut estimates: Vec<Box<dyn FnMut() -> Result<(), CliError> + '_>> = ests
                .iter_mut()
                .zip(&candidates)
                .map(|(est, &p)| {
                    let jobs = jobs_of(p);
                    Box::new(move || -> Result<(), CliError> {
                        est.clear();
                        for &(own, p) in &jobs {
                            est.extend(estimator.with_probe(p).try_work(own)?);
                        }
                        Ok(())
                    }) as Box<dyn FnMut() -> Result<(), CliError> + '_>
                })
                .collect();
            let mut trace = || -> Result<(), CliError> {
                for (batch, kind) in &segments {
                    let hits = if kind.is_occlusion() {
                        traverse::any_hits(&bvh, batch)
                    } else {
                        traverse::closest_hits(&bvh, batch)
                    };
                    std::hint::black_box(hits);
                }
                Ok(())
            };
            let mut rest = || -> Result<(), CliError> {
                for ((batch, kind), known) in segments.iter().zip(&known) {
                    let any = kind.is_occlusion();
                    std::hint::black_box(traverse::hits_skipping(&bvh, batch, any, known));
                }
                Ok(())
            };
            // Taken in turns, so that a noisy moment of this shared machine falls on all of
            // them alike rather than on one.
            let mut steps: Vec<&mut dyn FnMut() -> Result<(), CliError>> =
                vec![&mut trace, &mut rest];
            for e in &mut estimates {
                steps.push(e.as_mut());
            }
            let best = min_times(args.repeats, &mut steps)?;
            drop(steps);
            drop(estimates);
            let (trace_seconds, rest_seconds) = (best[0], best[1]);
            let figures: Vec<ProbeFigures> = candidates
                .iter()
                .zip(&ests)
                .zip(&best[2..])
                .map(|((&p, est), &seconds)| {
                    let reused = matches!(p, Probe::Trace { .. });
                    let rest = if reused { rest_seconds } else { trace_seconds };
                    let (error, rho) = vs_time(calibrate(est, &measured).ok(), est);
                    let full = full_of(p).ok();
                    let model = CostModel::default();
                    ProbeFigures {
                        probe: p.name(),
                        error_vs_time: error,
                        spearman_vs_time: rho,
                        prediction_error: full.and_then(|f| {
                            prediction_error(&model.costs(est), &model.costs(&f)).ok()
                        }),
                        estimate_seconds: seconds,
                        overhead: seconds / trace_seconds.max(1e-12),
                        net_overhead: (seconds + rest - trace_seconds) / trace_seconds.max(1e-12),
                    }
                })
                .collect();
            let est = std::mem::take(&mut ests[chosen]);
            let rest = matches!(probe, Probe::Trace { .. }).then_some(rest_seconds);
            (best[2 + chosen], est, trace_seconds, rest, None, figures)
        }
        DeviceArg::Gpu => {
            let (e, est, t, name) =
                gpu_estimate(&bvh, &rays, &segments, &jobs, rate, args.repeats)?;
            (e, est, t, None, Some(name), Vec::new())
        }
    };

    let per_ray = |total: f64| total / rays.len() as f64;
    // Each task's counts of the real trace, traced as the generation is (closest or any hit).
    let mut trace_work = Vec::with_capacity(tasks.len());
    for (batch, kind) in &segments {
        let counts = if kind.is_occlusion() {
            traverse::any_hits_counted(&bvh, batch).1
        } else {
            traverse::closest_hits_counted(&bvh, batch).1
        };
        let own = sched::split_ranges(batch.len(), args.task_size);
        trace_work.extend(own.into_iter().map(|r| Work::sum(&counts[r])));
    }
    let (trace_nodes, trace_tris) = trace_work
        .iter()
        .fold((0.0, 0.0), |(b, t), w| (b + w.nodes, t + w.tris));

    let model = CostModel::default();
    let part = |f: fn(&Work) -> f64| -> (Vec<f64>, Vec<f64>) {
        (est.iter().map(f).collect(), full.iter().map(f).collect())
    };
    let (est_b, full_b) = part(|w| w.nodes);
    let (est_t, full_t) = part(|w| w.tris);
    let fit = calibrate(&est, &measured).ok();
    let fit_full = calibrate(&full, &measured).ok();
    let (error_vs_time, spearman_vs_time) = vs_time(fit, &est);
    let (error_vs_time_full, spearman_full_vs_time) = vs_time(fit_full, &full);
    let (error_vs_time_trace, spearman_trace_vs_time) =
        vs_time(calibrate(&trace_work, &measured).ok(), &trace_work);

    let report = Report {
        scene: args.scene.scene.clone(),
        triangles: scene.len(),
        preset: preset.name().to_string(),
        ray_kind: kind_name,
        coherent,
        rays: rays.len(),
        task_size: args.task_size,
        tasks: tasks.len(),
        sample_rate: rate.get(),
        probe: probe.name(),
        probe_fits,
        probes,
        sampled_rays: tasks.iter().map(|t| rate.samples(t.len())).sum(),
        threads: rayon::current_num_threads(),
        repeats: args.repeats,
        device: match args.device {
            DeviceArg::Cpu => "cpu",
            DeviceArg::Gpu => "gpu",
        },
        adapter,
        prediction_error: prediction_error(&model.costs(&est), &model.costs(&full)).ok(),
        prediction_error_nodes: prediction_error(&est_b, &full_b).ok(),
        prediction_error_tris: prediction_error(&est_t, &full_t).ok(),
        estimate_seconds,
        trace_seconds,
        overhead: estimate_seconds / trace_seconds.max(1e-12),
        rest_seconds,
        // A reduced probe's sample is wasted: its net overhead is its overhead, exactly.
        net_overhead: match rest_seconds {
            Some(rest) => (estimate_seconds + rest - trace_seconds) / trace_seconds.max(1e-12),
            None => estimate_seconds / trace_seconds.max(1e-12),
        },
        error_vs_time,
        spearman_vs_time,
        error_vs_time_full,
        spearman_full_vs_time,
        error_vs_time_trace,
        spearman_trace_vs_time,
        measured_seconds: measured.iter().sum(),
        reduced_nodes_per_ray: per_ray(full_b.iter().sum()),
        reduced_tris_per_ray: per_ray(full_t.iter().sum()),
        trace_nodes_per_ray: per_ray(trace_nodes),
        trace_tris_per_ray: per_ray(trace_tris),
        default_model: Model {
            kb: model.kb,
            kt: model.kt,
        },
        calibration: fit.map(Calibration::from),
        build_seconds: bvh.report().build_seconds,
    };
    if args.json {
        crate::print_json(&report)
    } else {
        crate::print_text(&table(&report))
    }
}

/// The estimate and the full trace on the first usable GPU adapter: the best of `repeats`
/// times of each, the estimates, and the adapter's name.
#[cfg(feature = "gpu")]
fn gpu_estimate(
    bvh: &Bvh,
    rays: &RayBatch,
    segments: &[(RayBatch, RayKind)],
    jobs: &[(&[std::ops::Range<usize>], Probe)],
    rate: SampleRate,
    repeats: usize,
) -> Result<(f64, Vec<Work>, f64, String), CliError> {
    use raytrace::gpu::{GpuDevice, GpuReducedTraversal};
    let gpu_err = crate::render_gpu::gpu_err("device");
    let ctx = crate::render_gpu::first_gpu("device")?;
    let name = ctx.info.name.clone();
    let dev = GpuDevice::new(ctx, bvh).map_err(gpu_err)?;
    let estimator = GpuReducedTraversal::new(&dev, rays, rate);
    let (estimate_seconds, est) = min_time(repeats, || {
        let mut work = Vec::new();
        for &(own, p) in jobs {
            work.extend(estimator.with_probe(p).try_work(own).map_err(gpu_err)?);
        }
        Ok::<_, CliError>(work)
    })?;
    let (trace_seconds, ()) = min_time(repeats, || {
        for (batch, kind) in segments {
            let all = 0..batch.len();
            let hits = dev
                .hits(kind.is_occlusion(), batch, &[&all])
                .map_err(gpu_err)?;
            std::hint::black_box(hits);
        }
        Ok::<_, CliError>(())
    })?;
    Ok((estimate_seconds, est, trace_seconds, name))
}

/// Without the `gpu` feature, `--device gpu` is refused.
#[cfg(not(feature = "gpu"))]
fn gpu_estimate(
    _: &Bvh,
    _: &RayBatch,
    _: &[(RayBatch, RayKind)],
    _: &[(&[std::ops::Range<usize>], Probe)],
    _: SampleRate,
    _: usize,
) -> Result<(f64, Vec<Work>, f64, String), CliError> {
    Err(CliError::Arg {
        flag: "device",
        value: "gpu".into(),
        message: "this cobalt was built without the `gpu` feature".into(),
    })
}

/// Where the rays come from.
enum RaySource {
    Primary,
    Ao,
    /// Every generation of a Whitted render: primary, shadow and reflection rays.
    Whitted,
    File(String, RayKind),
}

impl RaySource {
    fn parse(rays: &str, kind: &str) -> Result<Self, CliError> {
        match rays {
            "primary" => Ok(Self::Primary),
            "ao" => Ok(Self::Ao),
            "whitted" => Ok(Self::Whitted),
            path => {
                let kind = kind.parse().map_err(|message| CliError::Arg {
                    flag: "ray-kind",
                    value: kind.into(),
                    message,
                })?;
                Ok(Self::File(path.into(), kind))
            }
        }
    }
}

/// `WxH`, both sides in 1..=65536 (the Morton order's limit).
/// The least time of each step over `repeats` rounds, the steps taken in turn each round.
fn min_times(
    repeats: usize,
    steps: &mut [&mut dyn FnMut() -> Result<(), CliError>],
) -> Result<Vec<f64>, CliError> {
    let mut best = vec![f64::INFINITY; steps.len()];
    for _ in 0..repeats.max(1) {
        for (step, best) in steps.iter_mut().zip(&mut best) {
            let start = Instant::now();
            step()?;
            *best = best.min(start.elapsed().as_secs_f64());
        }
    }
    Ok(best)
}

/// Runs `f` `repeats` times; the least wall time and the last result. The first run warms
/// caches and the thread pool, the minimum drops interruptions by other processes.
fn min_time<T, E>(repeats: usize, mut f: impl FnMut() -> Result<T, E>) -> Result<(f64, T), CliError>
where
    CliError: From<E>,
{
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        let out = f()?;
        best = best.min(start.elapsed().as_secs_f64());
        last = Some(out);
    }
    last.map(|out| (best, out))
        .ok_or_else(|| CliError::Write("no timing was taken".into()))
}

/// Where the estimate and the full trace ran, for the table.
fn ran_on(r: &Report) -> String {
    match &r.adapter {
        Some(name) => format!("the GPU ({name})"),
        None => format!("{} threads", r.threads),
    }
}

fn table(r: &Report) -> String {
    let pct = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{:.2} %", 100.0 * v));
    let num = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
    let cal = r.calibration.as_ref().map_or("n/a".to_string(), |c| {
        format!(
            "kB = {:.3e} s, kT = {:.3e} s ({}), R² = {:.3}",
            c.kb, c.kt, c.form, c.r2
        )
    });
    let rows = [
        (
            "error vs time",
            format!(
                "{} (bound, the trace's own counts: {}; full counts of this probe: {})",
                pct(r.error_vs_time),
                pct(r.error_vs_time_trace),
                pct(r.error_vs_time_full)
            ),
        ),
        (
            "spearman vs time",
            format!(
                "{} (bound: {}; full counts: {})",
                num(r.spearman_vs_time),
                num(r.spearman_trace_vs_time),
                num(r.spearman_full_vs_time)
            ),
        ),
        (
            "net overhead",
            match r.rest_seconds {
                Some(_) => format!(
                    "{} (the sampled rays' hits are reused; {} counting their trace as waste)",
                    pct(Some(r.net_overhead)),
                    pct(Some(r.overhead))
                ),
                None => pct(Some(r.net_overhead)),
            },
        ),
        (
            "scene",
            format!("{} ({} triangles, BVH {})", r.scene, r.triangles, r.preset),
        ),
        (
            "rays",
            format!(
                "{} {} ({})",
                r.rays,
                r.ray_kind,
                if r.coherent { "coherent" } else { "diffuse" }
            ),
        ),
        ("tasks", format!("{} of {} rays", r.tasks, r.task_size)),
        (
            "sampled",
            format!(
                "{:.1} % ({} rays), {} probe",
                100.0 * r.sample_rate,
                r.sampled_rays,
                r.probe
            ),
        ),
        (
            "estimate",
            format!("{:.4} s on {}", r.estimate_seconds, ran_on(r)),
        ),
        (
            "full trace",
            format!("{:.4} s on {}", r.trace_seconds, ran_on(r)),
        ),
        (
            "prediction error",
            format!(
                "{} against the probe's full count (B {}, T {})",
                pct(r.prediction_error),
                pct(r.prediction_error_nodes),
                pct(r.prediction_error_tris)
            ),
        ),
        (
            "nodes per ray",
            format!(
                "reduced {:.1}, trace {:.1} (triangles: reduced {:.1}, trace {:.1})",
                r.reduced_nodes_per_ray,
                r.trace_nodes_per_ray,
                r.reduced_tris_per_ray,
                r.trace_tris_per_ray,
            ),
        ),
        ("calibration", cal),
    ];
    let mut text: String = rows.iter().map(|(k, v)| format!("{k:<17} {v}\n")).collect();
    for f in r.probe_fits.iter().flatten() {
        text += &format!(
            "{:<17} error vs time {}, spearman {} (full counts)\n",
            format!("probe {}", f.probe),
            pct(f.error_vs_time),
            num(f.spearman_vs_time)
        );
    }
    if !r.probes.is_empty() {
        text += "\n| probe | error vs time | spearman | net overhead | overhead | prediction error |\n|---|---:|---:|---:|---:|---:|\n";
        for f in &r.probes {
            text += &format!(
                "| {} | {} | {} | {} | {} | {} |\n",
                f.probe,
                pct(f.error_vs_time),
                num(f.spearman_vs_time),
                pct(Some(f.net_overhead)),
                pct(Some(f.overhead)),
                pct(f.prediction_error)
            );
        }
    }
    text
}
