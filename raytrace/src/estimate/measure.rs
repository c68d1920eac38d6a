//! The measurement: the rays cut into tasks, each task's single-thread trace time measured,
//! the estimates and the full trace timed (every walk in the same rounds on the CPU), and the
//! figures that judge the estimates against the times (thesis Table 4.1, judged by time).

use std::num::NonZeroUsize;
use std::ops::Range;

use super::error::EstimateError;
use super::rays::Generations;
use super::report::{Calibration, Report, WalkFigures, WalkFit, WalkTrade};
use crate::bvh::Bvh;
use crate::cost::judge::{self, Judged, judge};
use crate::cost::{
    Budget, CostError, CostModel, CountRays, ReducedTraversal, Rounds, SampleRate, SampleRun,
    SlicedTraces, Work, full_work, measure_seconds,
};
use crate::ray::{RayBatch, RayKind};
use crate::scene::Scene;
use crate::traverse::Walk;

/// Where the estimate and the full trace run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// All CPU cores.
    Cpu,
    /// The first usable GPU adapter.
    Gpu,
}

/// The walk the estimate takes: one, or the one whose full counts fit the times best.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WalkChoice {
    /// This walk.
    Fixed(Walk),
    /// The walk whose full counts, calibrated, err least against the measured task times.
    Auto,
}

impl std::str::FromStr for WalkChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s.trim() == "auto" {
            return Ok(Self::Auto);
        }
        s.parse().map(Self::Fixed).map_err(|_| {
            format!("unknown walk `{s}` (expected reduced, first-leaf, trace or auto)")
        })
    }
}

/// How the estimate is taken and timed.
#[derive(Clone, Copy, Debug)]
pub struct Settings<'a> {
    /// The scene as the report names it.
    pub scene: &'a str,
    /// Rays per task.
    pub task_size: NonZeroUsize,
    /// Adjacent rays the sample keeps together (CPU only).
    pub sample_run: SampleRun,
    /// What times are taken on.
    pub clock: sched::Clock,
    /// Every timing's repeats: each task's measured time, and on the GPU the estimate's and
    /// the trace's.
    pub repeats: usize,
    /// How long the CPU's rounds go on ([`Budget::estimate`] of `repeats` for `cobalt
    /// estimate`, [`Budget::trade`] for the bench's trade).
    pub budget: Budget,
    /// Where the estimate and the full trace run. The GPU's walk is never `trace`, its clock
    /// is wall time and its sample run the default: the caller checks.
    pub device: Device,
    /// The walk of the estimate.
    pub walk: WalkChoice,
}

/// Measures the estimates of `rays` (at least one ray) against their tasks' times at each of
/// `samples`: the share of each task's rays the estimate samples (at most, where it refines)
/// and how far the CPU's sample refines ([`ReducedTraversal::with_sample_error`]). The tasks'
/// times are measured once; one report a sample, in order (`cobalt estimate` takes one, the
/// bench's sampling trade several).
pub fn measure(
    s: &Settings<'_>,
    (scene, bvh): (&Scene, &Bvh),
    rays: &Generations,
    samples: &[(SampleRate, Option<f64>)],
) -> Result<Vec<Report>, EstimateError> {
    let cut = Cut::new(bvh, &rays.segments, s)?;
    samples
        .iter()
        .map(|&at| {
            let chosen = cut.choose(s.walk)?;
            let timed = match s.device {
                Device::Cpu => time_on_cpu(&cut, s, at, chosen.walk, &chosen.full)?,
                Device::Gpu => time_on_gpu(&cut, s, at.0, chosen.walk)?,
            };
            Ok(report(&cut, (s, at), (scene, rays), chosen, timed))
        })
        .collect()
}

/// The walk the estimate takes, its full counts, and with [`WalkChoice::Auto`] how each walk
/// fitted the times.
struct Chosen {
    walk: Walk,
    full: Vec<Work>,
    fits: Option<Vec<WalkFit>>,
}

/// The rays cut into tasks, and each task's measured time.
struct Cut<'a> {
    bvh: &'a Bvh,
    segments: &'a [(RayBatch, RayKind)],
    task_size: usize,
    /// Every generation's rays, one after another.
    rays: RayBatch,
    tasks: Vec<Range<usize>>,
    /// Per generation, its tasks (indices into `tasks`) and kind: the first-leaf walk models
    /// a closest hit, not an any-hit query (`Walk::for_kind`).
    parts: Vec<(Range<usize>, RayKind)>,
    /// Each task's single-thread trace time.
    measured: Vec<f64>,
    /// Each task's counts of the real trace, traced as its generation is (closest or any
    /// hit).
    trace_work: Vec<Work>,
}

impl<'a> Cut<'a> {
    fn new(
        bvh: &'a Bvh,
        segments: &'a [(RayBatch, RayKind)],
        s: &Settings<'_>,
    ) -> Result<Self, CostError> {
        let task_size = s.task_size.get();
        let mut rays = RayBatch::default();
        let mut tasks = Vec::new();
        let mut parts = Vec::new();
        let mut measured = Vec::new();
        for (batch, kind) in segments {
            let (base, first) = (rays.len(), tasks.len());
            let own = sched::split_ranges(batch.len(), task_size);
            tasks.extend(own.iter().map(|t| base + t.start..base + t.end));
            parts.push((first..tasks.len(), *kind));
            rays.extend(batch);
            measured.extend(measure_seconds(
                bvh, batch, &own, *kind, s.repeats, s.clock,
            )?);
        }
        let mut cut = Self {
            bvh,
            segments,
            task_size,
            rays,
            tasks,
            parts,
            measured,
            trace_work: Vec::new(),
        };
        // The trace walk's full count is the real trace's, each generation's query its own.
        cut.trace_work = cut.full(Walk::Trace { any: false })?;
        Ok(cut)
    }

    /// `work` calibrated against the measured times and judged by them.
    fn judge(&self, work: &[Work]) -> Judged {
        judge(work, &self.measured)
    }

    /// Every task's full count by `walk`.
    fn full(&self, walk: Walk) -> Result<Vec<Work>, CostError> {
        let mut full = Vec::with_capacity(self.tasks.len());
        for (range, kind) in &self.parts {
            let own = &self.tasks[range.clone()];
            full.extend(full_work(self.bvh, &self.rays, own, walk.for_kind(*kind))?);
        }
        Ok(full)
    }

    /// `estimator`'s sample of every task, each generation's walked by `walk` for its kind:
    /// the tasks' estimated work and the rays sampled.
    fn sample<C: CountRays>(
        &self,
        estimator: &ReducedTraversal<'_, C>,
        walk: Walk,
    ) -> Result<(Vec<Work>, usize), C::Error> {
        let (mut work, mut sampled) = (Vec::with_capacity(self.tasks.len()), 0);
        for (range, kind) in &self.parts {
            let own = &self.tasks[range.clone()];
            let s = estimator.with_walk(walk.for_kind(*kind)).try_sample(own)?;
            work.extend(s.work);
            sampled += s.sampled;
        }
        Ok((work, sampled))
    }

    /// The walk asked for with its full counts, or with [`WalkChoice::Auto`] the best fit and
    /// how each walk fitted.
    fn choose(&self, choice: WalkChoice) -> Result<Chosen, CostError> {
        let WalkChoice::Fixed(walk) = choice else {
            let mut fits = Vec::new();
            let mut best = (f64::INFINITY, Walk::Reduced, Vec::new());
            for p in Walk::ALL {
                let full = self.full(p)?;
                let j = self.judge(&full);
                fits.push(WalkFit {
                    walk: p.name(),
                    error_vs_time: j.error_vs_time,
                    spearman_vs_time: j.spearman_vs_time,
                });
                // Ties and failed fits keep the reduced walk, tried first.
                if best.2.is_empty() || j.error_vs_time.is_some_and(|e| e < best.0) {
                    best = (j.error_vs_time.unwrap_or(f64::INFINITY), p, full);
                }
            }
            return Ok(Chosen {
                walk: best.1,
                full: best.2,
                fits: Some(fits),
            });
        };
        Ok(Chosen {
            walk,
            full: self.full(walk)?,
            fits: None,
        })
    }

    /// Per generation, the trace walk's sample of `estimator` as indices into the
    /// generation's own batch: the rays a render does not trace again (their hits are the
    /// estimate's).
    fn known(&self, estimator: &ReducedTraversal<'_>) -> Result<Vec<Vec<usize>>, CostError> {
        self.parts
            .iter()
            .map(|(range, kind)| {
                let own = &self.tasks[range.clone()];
                let base = own.first().map_or(0, |t| t.start);
                let walk = Walk::Trace { any: false }.for_kind(*kind);
                let traced = estimator.with_walk(walk).try_sample(own)?.traced;
                Ok(traced.map_or_else(Vec::new, |t| {
                    t.index.into_iter().map(|i| i - base).collect()
                }))
            })
            .collect()
    }
}

/// What timing the asked walk gave.
struct Timed {
    estimate_seconds: f64,
    /// The asked walk's estimates.
    est: Vec<Work>,
    trace_seconds: f64,
    /// The trace less the sample, where the trace walk's hits are reused (CPU).
    rest_seconds: Option<f64>,
    /// The GPU's name.
    adapter: Option<String>,
    /// Every walk's figures (CPU).
    walks: Vec<WalkTrade>,
    sampled_rays: usize,
    /// The overhead, net overhead and the net overhead's quartiles from the pairs of rounds
    /// (CPU); on the GPU they come from the least times.
    shares: Option<(f64, f64, [f64; 2])>,
    /// Rounds the CPU's steps were timed in; the GPU's, `repeats`.
    rounds: usize,
    /// Slices the CPU's trace and rest were timed in.
    slices: Option<usize>,
}

/// Walk `i`'s overhead and net overhead (where the render reuses its sample's hits), each a
/// median over the pairs of rounds of each pair's shares of the trace, and the quartiles of
/// the net overhead.
fn shares(timed: &Rounds, i: usize, reused: bool) -> (f64, f64, [f64; 2]) {
    let own = timed.quartile_shares(|r| r[2 + i]);
    let [q1, net, q3] = if reused {
        timed.quartile_shares(|r| r[2 + i] + r[1] - r[0])
    } else {
        own
    };
    (own[1], net, [q1, q3])
}

/// On the CPU: every walk's estimate, the asked one among them, timed in the same rounds as
/// the trace and the rest (the trace less the trace walk's sample), so that the trade is one
/// table.
fn time_on_cpu(
    cut: &Cut<'_>,
    s: &Settings<'_>,
    (rate, sample_error): (SampleRate, Option<f64>),
    walk: Walk,
    full: &[Work],
) -> Result<Timed, CostError> {
    let candidates = [Walk::Trace { any: false }, Walk::Reduced, Walk::FirstLeaf];
    let chosen = match walk {
        Walk::Trace { .. } => 0,
        Walk::Reduced => 1,
        Walk::FirstLeaf => 2,
    };
    let estimator = ReducedTraversal::new(cut.bvh, &cut.rays, rate)
        .with_run(s.sample_run)
        .with_sample_error(sample_error);
    let known = cut.known(&estimator)?;
    // Each walk's estimates and the rays its samples traced.
    let mut ests: Vec<(Vec<Work>, usize)> = vec![(Vec::new(), 0); candidates.len()];
    let traces = SlicedTraces::new(
        cut.bvh,
        cut.segments
            .iter()
            .zip(&known)
            .map(|((batch, kind), known)| (batch, kind.is_occlusion(), &known[..])),
    );
    // The trace and the rest in slices, every candidate walk's estimate whole, each estimate
    // and the rays its sample traced left in `ests` once the steps are done with.
    let timed = {
        let mut estimates: Vec<Box<dyn FnMut() -> Result<(), CostError> + '_>> = ests
            .iter_mut()
            .zip(&candidates)
            .map(|(slot, &p)| {
                Box::new(move || -> Result<(), CostError> {
                    *slot = cut.sample(&estimator, p)?;
                    Ok(())
                }) as Box<dyn FnMut() -> Result<(), CostError> + '_>
            })
            .collect();
        let mut trace = |slice: usize| {
            traces.run(slice, false);
            Ok(())
        };
        let mut rest = |slice: usize| {
            traces.run(slice, true);
            Ok(())
        };
        let mut whole: Vec<&mut dyn FnMut() -> Result<(), CostError>> =
            estimates.iter_mut().map(|e| e.as_mut() as _).collect();
        Rounds::time(
            s.budget,
            s.clock,
            traces.count(),
            &mut [&mut trace, &mut rest],
            &mut whole,
        )?
    };
    let best: Vec<f64> = (0..2 + candidates.len()).map(|i| timed.least(i)).collect();
    let model = CostModel::default();
    let figures: Vec<WalkTrade> = candidates
        .iter()
        .zip(&ests)
        .zip(&best[2..])
        .enumerate()
        .map(|(i, ((&p, (est, _)), &seconds))| {
            let (overhead, net_overhead, _) = shares(&timed, i, matches!(p, Walk::Trace { .. }));
            let judged = cut.judge(est);
            // The asked walk's full counts are at hand: each is a traversal of every ray.
            let full = if i == chosen {
                Some(full.to_vec())
            } else {
                cut.full(p).ok()
            };
            WalkTrade {
                figures: WalkFigures {
                    walk: p.name(),
                    error_vs_time: judged.error_vs_time,
                    spearman_vs_time: judged.spearman_vs_time,
                    prediction_error: full
                        .and_then(|f| sched::prediction_error(&model.costs(est), &model.costs(&f))),
                    overhead,
                    net_overhead,
                },
                estimate_seconds: seconds,
                lpt_balance: judged.lpt_balance,
            }
        })
        .collect();
    let (est, sampled_rays) = std::mem::take(&mut ests[chosen]);
    let rest_seconds = matches!(walk, Walk::Trace { .. }).then_some(best[1]);
    Ok(Timed {
        estimate_seconds: best[2 + chosen],
        est,
        trace_seconds: best[0],
        rest_seconds,
        adapter: None,
        walks: figures,
        sampled_rays,
        shares: Some(shares(&timed, chosen, rest_seconds.is_some())),
        rounds: timed.len(),
        slices: Some(traces.count()),
    })
}

/// On the first usable GPU adapter: the best of `repeats` times of the estimate and of the
/// full trace.
#[cfg(feature = "gpu")]
fn time_on_gpu(
    cut: &Cut<'_>,
    s: &Settings<'_>,
    rate: SampleRate,
    walk: Walk,
) -> Result<Timed, EstimateError> {
    use crate::devices::GpuSelect;
    use crate::gpu::{GpuContext, GpuDevice, GpuOptions};
    let ctx = GpuContext::open(GpuSelect::All, GpuOptions::from_env())?.swap_remove(0);
    let name = ctx.info.name.clone();
    let dev = GpuDevice::new(ctx, cut.bvh)?;
    let estimator = ReducedTraversal::new(&dev, &cut.rays, rate);
    let (estimate_seconds, (est, sampled_rays)) =
        min_time(s.repeats, || cut.sample(&estimator, walk))?;
    let (trace_seconds, ()) = min_time(s.repeats, || {
        for (batch, kind) in cut.segments {
            let all = 0..batch.len();
            std::hint::black_box(dev.hits(kind.is_occlusion(), batch, &[&all])?);
        }
        Ok::<_, EstimateError>(())
    })?;
    Ok(Timed {
        estimate_seconds,
        est,
        trace_seconds,
        rest_seconds: None,
        adapter: Some(name),
        walks: Vec::new(),
        sampled_rays,
        shares: None,
        rounds: s.repeats,
        slices: None,
    })
}

/// Without the `gpu` feature there is no GPU to time on.
#[cfg(not(feature = "gpu"))]
fn time_on_gpu(
    _: &Cut<'_>,
    _: &Settings<'_>,
    _: SampleRate,
    _: Walk,
) -> Result<Timed, EstimateError> {
    Err(EstimateError::NoGpu)
}

/// Runs `f` `repeats` times (once at least); the least wall time and the last result. The
/// first run warms caches and the thread pool, the minimum drops interruptions by other
/// processes.
#[cfg(feature = "gpu")]
fn min_time<T, E>(repeats: usize, mut f: impl FnMut() -> Result<T, E>) -> Result<(f64, T), E> {
    let start = std::time::Instant::now();
    let mut last = f()?;
    let mut best = start.elapsed().as_secs_f64();
    for _ in 1..repeats {
        let start = std::time::Instant::now();
        last = f()?;
        best = best.min(start.elapsed().as_secs_f64());
    }
    Ok((best, last))
}

/// The report of what was measured.
fn report(
    cut: &Cut<'_>,
    (s, (rate, sample_error)): (&Settings<'_>, (SampleRate, Option<f64>)),
    (scene, rays): (&Scene, &Generations),
    Chosen { walk, full, fits }: Chosen,
    t: Timed,
) -> Report {
    let per_ray = |total: f64| total / cut.rays.len() as f64;
    let (trace_nodes, trace_tris) = cut
        .trace_work
        .iter()
        .fold((0.0, 0.0), |(b, t), w| (b + w.nodes, t + w.tris));
    let model = CostModel::default();
    let est = &t.est;
    let part = |f: fn(&Work) -> f64| -> (Vec<f64>, Vec<f64>) {
        (est.iter().map(f).collect(), full.iter().map(f).collect())
    };
    let (est_b, full_b) = part(|w| w.nodes);
    let (est_t, full_t) = part(|w| w.tris);
    let (judged, full_judged) = (cut.judge(est), cut.judge(&full));
    let trace_judged = cut.judge(&cut.trace_work);
    // On the GPU, the overheads from the least times; a reduced walk's sample is wasted: its
    // net overhead is its overhead, exactly.
    let least = t.estimate_seconds / t.trace_seconds.max(1e-12);
    Report {
        scene: s.scene.to_string(),
        triangles: scene.len(),
        preset: cut.bvh.report().preset.name().to_string(),
        ray_kind: rays.kind_name,
        coherent: rays.coherent,
        rays: cut.rays.len(),
        task_size: cut.task_size,
        tasks: cut.tasks.len(),
        sample_rate: rate.get(),
        sample_run: s.sample_run.get(),
        sample_error: sample_error.filter(|_| s.device == Device::Cpu),
        walk: walk.name(),
        walk_fits: fits,
        walks: t.walks,
        balance_devices: judge::DEVICES,
        balance_measured: judge::lpt(&cut.measured, &cut.measured),
        balance_uniform: judge::uniform(&cut.measured),
        sampled_rays: t.sampled_rays,
        threads: rayon::current_num_threads(),
        repeats: s.repeats,
        rounds: t.rounds,
        slices: t.slices,
        clock: s.clock.name(),
        device: match s.device {
            Device::Cpu => "cpu",
            Device::Gpu => "gpu",
        },
        adapter: t.adapter,
        prediction_error: sched::prediction_error(&model.costs(est), &model.costs(&full)),
        prediction_error_nodes: sched::prediction_error(&est_b, &full_b),
        prediction_error_tris: sched::prediction_error(&est_t, &full_t),
        estimate_seconds: t.estimate_seconds,
        trace_seconds: t.trace_seconds,
        overhead: t.shares.map_or(least, |s| s.0),
        rest_seconds: t.rest_seconds,
        net_overhead: t.shares.map_or(least, |s| s.1),
        net_overhead_quartiles: t.shares.map(|s| s.2),
        error_vs_time: judged.error_vs_time,
        spearman_vs_time: judged.spearman_vs_time,
        error_vs_time_full: full_judged.error_vs_time,
        spearman_full_vs_time: full_judged.spearman_vs_time,
        error_vs_time_trace: trace_judged.error_vs_time,
        spearman_trace_vs_time: trace_judged.spearman_vs_time,
        measured_seconds: cut.measured.iter().sum(),
        reduced_nodes_per_ray: per_ray(full_b.iter().sum()),
        reduced_tris_per_ray: per_ray(full_t.iter().sum()),
        trace_nodes_per_ray: per_ray(trace_nodes),
        trace_tris_per_ray: per_ray(trace_tris),
        default_model: model,
        calibration: judged.fit.map(|fit| Calibration {
            device: "cpu-thread",
            fit,
        }),
        build_seconds: cut.bvh.report().build_seconds,
    }
}
