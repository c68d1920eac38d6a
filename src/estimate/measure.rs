//! The run of `cobalt estimate`: the rays cut into tasks, each task's single-thread trace time
//! measured, the estimates and the full trace timed (every walk in the same rounds on the CPU),
//! and the figures that judge the estimates against the times.

use std::time::Instant;

use raytrace::cost::{
    CostModel, ReducedTraversal, SampleRate, SampleRun, Work, full_work, measure_seconds,
    prediction_error,
};
use raytrace::{Bvh, RayBatch, RayKind, Scene, Walk, traverse};

use super::args::{Args, DeviceArg, WalkArg};
use super::rays::Generations;
use super::report::{Calibration, Model, Report, WalkFigures, WalkFit};
use crate::error::CliError;
use raytrace::cost::{Budget, Rounds, SlicedTraces};

/// Measures the estimates of `rays` against their tasks' times, as `args` asks.
pub(super) fn measure(
    args: &Args,
    scene: &Scene,
    bvh: &Bvh,
    rays: Generations,
) -> Result<Report, CliError> {
    let Generations {
        segments,
        kind_name,
        coherent,
    } = rays;
    let preset = args.scene.preset;
    let (task_size, rate) = (args.task_size.get(), args.sample_rate);
    let mut rays = RayBatch::default();
    let mut tasks = Vec::new();
    // Per generation, its tasks (indices into `tasks`) and kind: the first-leaf walk models
    // a closest hit, not an any-hit query (`Walk::for_kind`).
    let mut parts = Vec::new();
    for (batch, kind) in &segments {
        let base = rays.len();
        let first = tasks.len();
        tasks.extend(
            sched::split_ranges(batch.len(), task_size)
                .into_iter()
                .map(|t| base + t.start..base + t.end),
        );
        parts.push((first..tasks.len(), *kind));
        rays.extend(batch);
    }
    if rays.is_empty() {
        return Err(CliError::Arg {
            flag: "rays",
            value: args.rays.clone(),
            message: "there are no rays to estimate (no primary ray hit the scene?)".into(),
        });
    }

    let mut measured = Vec::with_capacity(tasks.len());
    for (batch, kind) in &segments {
        let own = sched::split_ranges(batch.len(), task_size);
        measured.extend(measure_seconds(
            bvh,
            batch,
            &own,
            *kind,
            args.repeats,
            args.clock,
        )?);
    }
    let judge = |work: &[Work]| raytrace::cost::judge::judge(work, &measured);
    let full_of = |walk: Walk| -> Result<Vec<Work>, CliError> {
        let mut full = Vec::with_capacity(tasks.len());
        for (range, kind) in &parts {
            let own = &tasks[range.clone()];
            full.extend(full_work(bvh, &rays, own, walk.for_kind(*kind))?);
        }
        Ok(full)
    };
    // The real trace where it can run: its hits are the render's, so it costs little more
    // than counting, and it stops where the trace stops, which the reduced traversals do not.
    let asked = args.walk.unwrap_or(match args.device {
        DeviceArg::Cpu => WalkArg::Fixed(Walk::Trace { any: false }),
        DeviceArg::Gpu => WalkArg::Fixed(Walk::Reduced),
    });
    if let (WalkArg::Fixed(Walk::Trace { .. }), DeviceArg::Gpu) = (asked, args.device) {
        return Err(CliError::Arg {
            flag: "walk",
            value: "trace".into(),
            message:
                "the `trace` walk runs on the CPU only; use reduced or first-leaf with --device gpu"
                    .into(),
        });
    }
    if args.clock != sched::Clock::Wall && matches!(args.device, DeviceArg::Gpu) {
        return Err(CliError::Arg {
            flag: "clock",
            value: args.clock.to_string(),
            message: "a GPU's work is not the host's CPU time; use --clock wall with --device gpu"
                .into(),
        });
    }
    if !args.clock.is_available() {
        return Err(CliError::Arg {
            flag: "clock",
            value: args.clock.to_string(),
            message: "this system has no process CPU clock; use --clock wall".into(),
        });
    }
    if args.sample_run != SampleRun::DEFAULT && matches!(args.device, DeviceArg::Gpu) {
        return Err(CliError::Arg {
            flag: "sample-run",
            value: args.sample_run.to_string(),
            message: format!(
                "the GPU estimator samples in runs of {}; other runs are measured on the CPU",
                SampleRun::DEFAULT
            ),
        });
    }
    let (walk, full, walk_fits) = match asked {
        WalkArg::Fixed(p) => (p, full_of(p)?, None),
        WalkArg::Auto => {
            let mut fits = Vec::new();
            let mut best = (f64::INFINITY, Walk::Reduced, Vec::new());
            for p in Walk::ALL {
                let full = full_of(p)?;
                let j = judge(&full);
                let (error, spearman_vs_time) = (j.error_vs_time, j.spearman_vs_time);
                fits.push(WalkFit {
                    walk: p.name(),
                    error_vs_time: error,
                    spearman_vs_time,
                });
                // Ties and failed fits keep the reduced walk, tried first.
                if best.2.is_empty() || error.is_some_and(|e| e < best.0) {
                    best = (error.unwrap_or(f64::INFINITY), p, full);
                }
            }
            (best.1, best.2, Some(fits))
        }
    };

    // Each generation's tasks and the walk that estimates them.
    let jobs_of = |walk: Walk| -> Vec<(&[std::ops::Range<usize>], Walk)> {
        parts
            .iter()
            .map(|(range, kind)| (&tasks[range.clone()], walk.for_kind(*kind)))
            .collect()
    };
    let jobs = jobs_of(walk);
    // Rounds the CPU's steps were timed in (see `raytrace::cost::Rounds`); the GPU's, `repeats`.
    let mut rounds = args.repeats;
    // Slices the CPU's trace and rest were timed in.
    let mut slices = None;
    // On the CPU, the asked walk's overhead and net overhead from the pairs' shares; on the
    // GPU, from the least times (its estimate is not timed in the trace's rounds).
    let (estimate_seconds, est, trace_seconds, rest_seconds, adapter, walks, sampled_rays, shares) =
        match args.device {
            DeviceArg::Cpu => {
                // Every walk is timed, the asked one among them, so that the trade is one table.
                let mut candidates =
                    vec![Walk::Trace { any: false }, Walk::Reduced, Walk::FirstLeaf];
                let chosen = candidates
                    .iter()
                    .position(|p| p.name() == walk.name())
                    .unwrap_or_else(|| {
                        candidates.push(walk);
                        candidates.len() - 1
                    });
                let estimator = ReducedTraversal::new(bvh, &rays, rate)
                    .with_run(args.sample_run)
                    .with_sample_error(args.sample_error.0);
                // A render does not trace the trace walk's sampled rays again (their hits are
                // the estimate's), so what is left of the trace is timed too: per generation, its
                // sample, as indices into the generation's own batch.
                let known: Vec<Vec<usize>> = parts
                    .iter()
                    .map(|(range, kind)| {
                        let own = &tasks[range.clone()];
                        let base = own.first().map_or(0, |t| t.start);
                        let walk = Walk::Trace { any: false }.for_kind(*kind);
                        let traced = estimator.with_walk(walk).try_sample(own)?.traced;
                        Ok(traced.map_or_else(Vec::new, |t| {
                            t.index.into_iter().map(|i| i - base).collect()
                        }))
                    })
                    .collect::<Result<_, CliError>>()?;
                // Each walk's estimates and the rays its samples traced.
                let mut ests: Vec<(Vec<Work>, usize)> = vec![(Vec::new(), 0); candidates.len()];
                let mut estimates: Vec<Box<dyn FnMut() -> Result<(), CliError> + '_>> = ests
                    .iter_mut()
                    .zip(&candidates)
                    .map(|((est, sampled), &p)| {
                        let jobs = jobs_of(p);
                        Box::new(move || -> Result<(), CliError> {
                            est.clear();
                            *sampled = 0;
                            for &(own, p) in &jobs {
                                let s = estimator.with_walk(p).try_sample(own)?;
                                est.extend(s.work);
                                *sampled += s.sampled;
                            }
                            Ok(())
                        }) as Box<dyn FnMut() -> Result<(), CliError> + '_>
                    })
                    .collect();
                // The trace and the rest in slices (see `raytrace::cost::Rounds`), every generation.
                let traces = SlicedTraces::new(
                    bvh,
                    segments
                        .iter()
                        .zip(&known)
                        .map(|((batch, kind), known)| (batch, kind.is_occlusion(), &known[..])),
                );
                let mut trace = |s: usize| {
                    traces.run(s, false);
                    Ok(())
                };
                let mut rest = |s: usize| {
                    traces.run(s, true);
                    Ok(())
                };
                let mut whole: Vec<&mut dyn FnMut() -> Result<(), CliError>> =
                    estimates.iter_mut().map(|e| e.as_mut() as _).collect();
                let timed = Rounds::time(
                    Budget::estimate(args.repeats),
                    args.clock,
                    traces.count(),
                    &mut [&mut trace, &mut rest],
                    &mut whole,
                )?;
                drop(whole);
                drop(estimates);
                rounds = timed.len();
                slices = Some(traces.count());
                let best: Vec<f64> = (0..2 + candidates.len()).map(|i| timed.least(i)).collect();
                let (trace_seconds, rest_seconds) = (best[0], best[1]);
                // Walk `i`'s overhead and net overhead, each a median over the pairs of rounds
                // of each pair's shares of the trace (see `raytrace::cost::Rounds`).
                let shares = |i: usize, reused: bool| {
                    let own = timed.quartile_shares(|r| r[2 + i]);
                    let [q1, net, q3] = if reused {
                        timed.quartile_shares(|r| r[2 + i] + r[1] - r[0])
                    } else {
                        own
                    };
                    (own[1], net, [q1, q3])
                };
                let model = CostModel::default();
                let figures: Vec<WalkFigures> = candidates
                    .iter()
                    .zip(&ests)
                    .zip(&best[2..])
                    .enumerate()
                    .map(|(i, ((&p, (est, _)), &seconds))| {
                        let (overhead, net_overhead, _) =
                            shares(i, matches!(p, Walk::Trace { .. }));
                        let judged = judge(est);
                        // The asked walk's full counts are at hand: each is a traversal of
                        // every ray.
                        let full = if i == chosen {
                            Some(full.clone())
                        } else {
                            full_of(p).ok()
                        };
                        WalkFigures {
                            walk: p.name(),
                            lpt_balance: judged.lpt_balance,
                            error_vs_time: judged.error_vs_time,
                            spearman_vs_time: judged.spearman_vs_time,
                            prediction_error: full.and_then(|f| {
                                prediction_error(&model.costs(est), &model.costs(&f)).ok()
                            }),
                            estimate_seconds: seconds,
                            overhead,
                            net_overhead,
                        }
                    })
                    .collect();
                let (est, sampled) = std::mem::take(&mut ests[chosen]);
                let rest = matches!(walk, Walk::Trace { .. }).then_some(rest_seconds);
                let asked = shares(chosen, rest.is_some());
                (
                    best[2 + chosen],
                    est,
                    trace_seconds,
                    rest,
                    None,
                    figures,
                    sampled,
                    Some(asked),
                )
            }
            DeviceArg::Gpu => {
                let (e, est, t, name) =
                    gpu_estimate(bvh, &rays, &segments, &jobs, rate, args.repeats)?;
                let sampled = tasks.iter().map(|t| rate.samples(t.len())).sum();
                (e, est, t, None, Some(name), Vec::new(), sampled, None)
            }
        };

    let per_ray = |total: f64| total / rays.len() as f64;
    // Each task's counts of the real trace, traced as the generation is (closest or any hit).
    let mut trace_work = Vec::with_capacity(tasks.len());
    for (batch, kind) in &segments {
        let counts = if kind.is_occlusion() {
            traverse::any_hits_counted(bvh, batch).1
        } else {
            traverse::closest_hits_counted(bvh, batch).1
        };
        let own = sched::split_ranges(batch.len(), task_size);
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
    let judged = judge(&est);
    let fit = judged.fit;
    let (error_vs_time, spearman_vs_time) = (judged.error_vs_time, judged.spearman_vs_time);
    let full_judged = judge(&full);
    let (error_vs_time_full, spearman_full_vs_time) =
        (full_judged.error_vs_time, full_judged.spearman_vs_time);
    let trace_judged = judge(&trace_work);
    let (error_vs_time_trace, spearman_trace_vs_time) =
        (trace_judged.error_vs_time, trace_judged.spearman_vs_time);

    Ok(Report {
        scene: args.scene.scene.clone(),
        triangles: scene.len(),
        preset: preset.name().to_string(),
        ray_kind: kind_name,
        coherent,
        rays: rays.len(),
        task_size,
        tasks: tasks.len(),
        sample_rate: rate.get(),
        sample_run: args.sample_run.get(),
        sample_error: match args.device {
            DeviceArg::Cpu => args.sample_error.0,
            DeviceArg::Gpu => None,
        },
        walk: walk.name(),
        walk_fits,
        walks,
        balance_devices: raytrace::cost::judge::DEVICES,
        balance_measured: raytrace::cost::judge::lpt(&measured, &measured),
        balance_uniform: raytrace::cost::judge::uniform(&measured),
        sampled_rays,
        threads: rayon::current_num_threads(),
        repeats: args.repeats,
        rounds,
        slices,
        clock: args.clock.name(),
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
        overhead: shares.map_or(estimate_seconds / trace_seconds.max(1e-12), |s| s.0),
        rest_seconds,
        // A reduced walk's sample is wasted: its net overhead is its overhead, exactly.
        net_overhead: shares.map_or(estimate_seconds / trace_seconds.max(1e-12), |s| s.1),
        net_overhead_quartiles: shares.map(|s| s.2),
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
            kr: model.kr,
            kb: model.kb,
            kt: model.kt,
        },
        calibration: fit.map(Calibration::from),
        build_seconds: bvh.report().build_seconds,
    })
}

/// The estimate and the full trace on the first usable GPU adapter: the best of `repeats`
/// times of each, the estimates, and the adapter's name.
#[cfg(feature = "gpu")]
fn gpu_estimate(
    bvh: &Bvh,
    rays: &RayBatch,
    segments: &[(RayBatch, RayKind)],
    jobs: &[(&[std::ops::Range<usize>], Walk)],
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
            work.extend(estimator.with_walk(p).try_work(own).map_err(gpu_err)?);
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
    _: &[(&[std::ops::Range<usize>], Walk)],
    _: SampleRate,
    _: usize,
) -> Result<(f64, Vec<Work>, f64, String), CliError> {
    Err(CliError::Arg {
        flag: "device",
        value: "gpu".into(),
        message: "this cobalt was built without the `gpu` feature".into(),
    })
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
