//! The report of `cobalt estimate`: the estimator's error and overhead, every walk's trade on
//! the CPU and the calibrated model, as one JSON object (its field names are read by users and
//! tests, so they stay as they are) or a table.

use raytrace::cost::Fit;
use serde::Serialize;

/// The device name calibrations are recorded under: one CPU thread, as measured.
const DEVICE: &str = "cpu-thread";

/// How well one walk's full reduced traversal, calibrated, explains the measured times.
#[derive(Debug, Serialize)]
pub(super) struct WalkFit {
    pub(super) walk: &'static str,
    pub(super) error_vs_time: Option<f64>,
    pub(super) spearman_vs_time: Option<f64>,
}

/// One estimator's trade on the CPU: what its sample predicts of the measured times, and what
/// it costs a render.
#[derive(Debug, Serialize)]
pub(super) struct WalkFigures {
    pub(super) walk: &'static str,
    /// Its sampled estimates, calibrated, against the measured task times.
    pub(super) error_vs_time: Option<f64>,
    pub(super) spearman_vs_time: Option<f64>,
    /// The thesis's, against the walk's own full count.
    pub(super) prediction_error: Option<f64>,
    pub(super) estimate_seconds: f64,
    pub(super) overhead: f64,
    /// Overhead less the sample's trace where the render reuses its hits (the trace walk).
    pub(super) net_overhead: f64,
    /// What the estimates buy a plan: the balance of an LPT plan by them on
    /// `balance_devices` equal devices, judged by the measured task times.
    pub(super) lpt_balance: Option<f64>,
}

/// A calibrated model, for the report.
#[derive(Debug, Serialize)]
pub(super) struct Calibration {
    pub(super) device: &'static str,
    pub(super) kr: f64,
    pub(super) kb: f64,
    pub(super) kt: f64,
    pub(super) r2: f64,
    pub(super) rms_residual: f64,
    pub(super) n: usize,
    pub(super) form: &'static str,
}

impl From<Fit> for Calibration {
    fn from(f: Fit) -> Self {
        Self {
            device: DEVICE,
            kr: f.model.kr,
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
pub(super) struct Report {
    /// The estimator judged by time: its calibrated estimates against each task's measured
    /// single-thread trace time.
    pub(super) error_vs_time: Option<f64>,
    pub(super) spearman_vs_time: Option<f64>,
    /// The same with each task's exact counts of the real trace (closest or any hit, as
    /// traced): what no estimate of `B` and `T` can beat, whatever its walk and rate. What
    /// is left is time the counts do not see (caches, branches, the machine).
    pub(super) error_vs_time_trace: Option<f64>,
    pub(super) spearman_trace_vs_time: Option<f64>,
    /// `(estimate + rest − full trace) / full trace`, where `rest` is the full trace less
    /// the sampled rays when the walk traces them for real (a render takes their hits from
    /// the estimate), else the full trace: what estimating costs a render. On the CPU, the
    /// median over the pairs of rounds of each pair's own (see `raytrace::cost::Rounds`).
    pub(super) net_overhead: f64,
    /// On the CPU, the first and third quartile of the pairs' own net overheads: how far
    /// the machine moved them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) net_overhead_quartiles: Option<[f64; 2]>,
    pub(super) scene: String,
    pub(super) triangles: usize,
    pub(super) preset: String,
    pub(super) ray_kind: &'static str,
    pub(super) coherent: bool,
    pub(super) rays: usize,
    pub(super) task_size: usize,
    pub(super) tasks: usize,
    pub(super) sample_rate: f64,
    /// Adjacent rays the sample keeps together.
    pub(super) sample_run: usize,
    /// The halves' disagreement the sample refined to; `None` where it was taken whole at
    /// `sample_rate` (`--sample-error off`, or the GPU estimator).
    pub(super) sample_error: Option<f64>,
    /// `trace`, `reduced` or `first-leaf` (applied to closest-hit generations only): the one
    /// asked for, or the better fit with `--walk auto`.
    pub(super) walk: &'static str,
    /// With `--walk auto`: how each walk fitted the measured times.
    pub(super) walk_fits: Option<Vec<WalkFit>>,
    /// On the CPU: every walk's trade at this sample rate, timed in the same rounds.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub(super) walks: Vec<WalkFigures>,
    /// Equal devices each walk's `lpt_balance` plans for.
    pub(super) balance_devices: usize,
    /// The balance of LPT by the measured times themselves (the best an estimate can buy),
    /// and of the tasks dealt out in order without an estimate.
    pub(super) balance_measured: Option<f64>,
    pub(super) balance_uniform: Option<f64>,
    pub(super) sampled_rays: usize,
    pub(super) threads: usize,
    pub(super) repeats: usize,
    /// Rounds the estimates, the full trace and the rest were timed in: at least `repeats`,
    /// more where the trace is short (see `--repeats`).
    pub(super) rounds: usize,
    /// Slices each round cut the full trace and the rest in, taken in turn.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) slices: Option<usize>,
    /// What the times were taken on: `wall` or `cpu` (the process's CPU time).
    pub(super) clock: &'static str,
    /// Where the estimate and the full trace ran: `cpu` or `gpu`.
    pub(super) device: &'static str,
    /// The GPU adapter's name with `--device gpu`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) adapter: Option<String>,
    /// The thesis's (secondary: it judges the sample against its own walk's full count, not
    /// against time): Σ|est − full| / Σ full of `C` under the default model.
    pub(super) prediction_error: Option<f64>,
    /// The same for `B` and for `T` alone.
    pub(super) prediction_error_nodes: Option<f64>,
    pub(super) prediction_error_tris: Option<f64>,
    /// Reduced traversal of the sample, gather included, on all cores (or on the GPU, the
    /// rays' upload included).
    pub(super) estimate_seconds: f64,
    /// Full trace (closest or any hit, with triangle tests) of all rays, on all cores (or on
    /// the GPU, upload and read-back included). On the CPU, the least over the rounds of the
    /// trace's slices' sum (see `raytrace::cost::Rounds`).
    pub(super) trace_seconds: f64,
    /// Estimate over full trace; on the CPU, the median over the pairs of rounds of each
    /// pair's own.
    pub(super) overhead: f64,
    /// With `--walk trace` on the CPU: the full trace less the sampled rays, which a render
    /// takes from the estimate instead of tracing them again; timed in slices, as the trace.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) rest_seconds: Option<f64>,
    /// The error against time with full counts: the best any sample rate could do.
    pub(super) error_vs_time_full: Option<f64>,
    pub(super) spearman_full_vs_time: Option<f64>,
    /// Σ measured task times (one thread).
    pub(super) measured_seconds: f64,
    /// Mean `B`, `T` per ray of the reduced traversal and of the real trace (an any-hit
    /// trace counts up to its first hit): the reduced traversal never shortens a ray, so it
    /// enters more nodes than the trace does, which bounds how cheap a sample can be.
    pub(super) reduced_nodes_per_ray: f64,
    pub(super) reduced_tris_per_ray: f64,
    pub(super) trace_nodes_per_ray: f64,
    pub(super) trace_tris_per_ray: f64,
    pub(super) default_model: Model,
    pub(super) calibration: Option<Calibration>,
    pub(super) build_seconds: f64,
}

#[derive(Debug, Serialize)]
pub(super) struct Model {
    pub(super) kr: f64,
    pub(super) kb: f64,
    pub(super) kt: f64,
}

/// Where the estimate and the full trace ran, for the table.
fn ran_on(r: &Report) -> String {
    match &r.adapter {
        Some(name) => format!("the GPU ({name})"),
        None if r.clock == "cpu" => format!("{} threads, CPU time of all", r.threads),
        None => format!("{} threads", r.threads),
    }
}

impl Report {
    /// The table printed without `--json`: the headline figures, then one row per walk.
    pub(super) fn table(&self) -> String {
        let r = self;
        let pct = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{:.2} %", 100.0 * v));
        let num = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
        let cal = r.calibration.as_ref().map_or("n/a".to_string(), |c| {
            format!(
                "kR = {:.3e} s, kB = {:.3e} s, kT = {:.3e} s ({}), R² = {:.3}",
                c.kr, c.kb, c.kt, c.form, c.r2
            )
        });
        let rows = [
            (
                "error vs time",
                format!(
                    "{} (bound, the trace's own counts: {}; full counts of this walk: {})",
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
            ("net overhead", {
                // The pairs' middle half first: it belongs to the net overhead.
                let mut notes: Vec<String> = r
                    .net_overhead_quartiles
                    .map(|[a, b]| {
                        format!(
                            "the middle half of the pairs of rounds {} to {}",
                            pct(Some(a)),
                            pct(Some(b))
                        )
                    })
                    .into_iter()
                    .collect();
                if r.rest_seconds.is_some() {
                    notes.push(format!(
                        "the sampled rays' hits are reused; {} counting their trace as waste",
                        pct(Some(r.overhead))
                    ));
                }
                if notes.is_empty() {
                    pct(Some(r.net_overhead))
                } else {
                    format!("{} ({})", pct(Some(r.net_overhead)), notes.join("; "))
                }
            }),
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
                match r.sample_error {
                    None => format!(
                        "{:.1} % ({} rays, in runs of {}), {} walk",
                        100.0 * r.sample_rate,
                        r.sampled_rays,
                        r.sample_run,
                        r.walk
                    ),
                    Some(e) => format!(
                        "{:.1} % ({} rays, in runs of {}; refined by --sample-error {e}, \
                         at most {:.1} %), {} walk",
                        100.0 * r.sampled_rays as f64 / r.rays.max(1) as f64,
                        r.sampled_rays,
                        r.sample_run,
                        100.0 * r.sample_rate,
                        r.walk
                    ),
                },
            ),
            (
                "estimate",
                format!("{:.4} s on {}", r.estimate_seconds, ran_on(r)),
            ),
            (
                "full trace",
                format!(
                    "{:.4} s on {}, each time the least of {} rounds{}",
                    r.trace_seconds,
                    ran_on(r),
                    r.rounds,
                    // On the CPU only, which times in rounds.
                    r.slices.map_or(String::new(), |n| {
                        let sliced = if n > 1 {
                            format!("; it and the rest in {n} slices taken in turn")
                        } else {
                            String::new()
                        };
                        format!("{sliced}; overheads, the median of each pair of rounds' own")
                    })
                ),
            ),
            (
                "prediction error",
                format!(
                    "{} against the walk's full count (B {}, T {})",
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
        for f in r.walk_fits.iter().flatten() {
            text += &format!(
                "{:<17} error vs time {}, spearman {} (full counts)\n",
                format!("walk {}", f.walk),
                pct(f.error_vs_time),
                num(f.spearman_vs_time)
            );
        }
        if !r.walks.is_empty() {
            text += &format!(
                "\n| walk | error vs time | spearman | net overhead | overhead | prediction error | LPT balance, {} devices |\n|---|---:|---:|---:|---:|---:|---:|\n",
                r.balance_devices
            );
            for f in &r.walks {
                text += &format!(
                    "| {} | {} | {} | {} | {} | {} | {} |\n",
                    f.walk,
                    pct(f.error_vs_time),
                    num(f.spearman_vs_time),
                    pct(Some(f.net_overhead)),
                    pct(Some(f.overhead)),
                    pct(f.prediction_error),
                    pct(f.lpt_balance)
                );
            }
            text += &format!(
                "| measured times (no estimate can do better) | | | | | | {} |\n| none (tasks in order) | | | | | | {} |\n",
                pct(r.balance_measured),
                pct(r.balance_uniform)
            );
        }
        text
    }
}
