//! The table `cobalt estimate` prints without `--json`: the headline figures, one line each,
//! then with `--walk auto` each walk's fit, and on the CPU one row per walk.

use super::report::Report;

/// A fraction as a percentage; `n/a` where it is undefined.
fn pct(v: Option<f64>) -> String {
    v.map_or("n/a".to_string(), |v| format!("{:.2} %", 100.0 * v))
}

/// A number to three places; `n/a` where it is undefined.
fn num(v: Option<f64>) -> String {
    v.map_or("n/a".to_string(), |v| format!("{v:.3}"))
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
    pub fn table(&self) -> String {
        let rows = [self.judged_rows(), self.run_rows()].concat();
        let mut text: String = rows.iter().map(|(k, v)| format!("{k:<17} {v}\n")).collect();
        text += &self.walks_table();
        text
    }

    /// The lines that judge the estimate: its error and rank correlation against time, and
    /// what it costs a render.
    fn judged_rows(&self) -> Vec<(&'static str, String)> {
        let r = self;
        vec![
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
        ]
    }

    /// The lines that say what was estimated, how, and what it took.
    fn run_rows(&self) -> Vec<(&'static str, String)> {
        let r = self;
        let cal = r.calibration.as_ref().map_or("n/a".to_string(), |c| {
            let (m, form) = (c.fit.model, c.fit.form.name());
            format!(
                "kR = {:.3e} s, kB = {:.3e} s, kT = {:.3e} s ({form}), R² = {:.3}",
                m.kr, m.kb, m.kt, c.fit.r2
            )
        });
        vec![
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
        ]
    }

    /// With `--walk auto`, each walk's fit; on the CPU, the table of every walk's trade.
    fn walks_table(&self) -> String {
        let r = self;
        let mut text = String::new();
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
                    f.figures.walk,
                    pct(f.figures.error_vs_time),
                    num(f.figures.spearman_vs_time),
                    pct(Some(f.figures.net_overhead)),
                    pct(Some(f.figures.overhead)),
                    pct(f.figures.prediction_error),
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
