//! The readable side of `cobalt bench`: Markdown tables of the runs, the balance targets
//! checked against them, the simulated and projected machines and the sampling trade.

use super::record::Record;
use super::simulate::SimRecord;
use super::trade::TradePoint;

fn pct(x: f64) -> String {
    format!("{:.2} %", 100.0 * x)
}

/// A cell's median, and with several runs their range: `7.41 (7.02–7.80)`.
fn spread(median: f64, runs: &[f64], show: impl Fn(f64) -> String) -> String {
    let (lo, hi) = runs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    if runs.len() > 1 {
        format!("{} ({}–{})", show(median), show(lo), show(hi))
    } else {
        show(median)
    }
}

/// `; k of n runs` when a cell ran more than once: in how many runs `ok` held.
fn of_runs(n: usize, ok: impl Fn(usize) -> bool) -> String {
    if n > 1 {
        format!("; {} of {n} runs", (0..n).filter(|&i| ok(i)).count())
    } else {
        String::new()
    }
}

/// Every measured run.
pub fn runs(records: &[Record]) -> String {
    let mut s = String::from(
        "| scene | shader | task size | policy | mode | rays | MRays/s | balance | makespan / bound (fractional) | simulated / measured | estimate s | plan s | pred. error | launches | link bytes |\n\
         |---|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in records {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.5} | {} | {} | {} |\n",
            r.scene,
            r.shader,
            r.task_size,
            r.policy,
            r.mode,
            r.rays,
            spread(r.mrays_per_s, &r.run_mrays_per_s, |x| format!("{x:.2}")),
            spread(r.balance_efficiency, &r.run_balance_efficiency, pct),
            match (r.lower_bound_seconds, r.fractional_bound_seconds) {
                (Some(b), Some(f)) => format!(
                    "{:.3} ({:.3})",
                    r.makespan_seconds / b.max(1e-300),
                    r.makespan_seconds / f.max(1e-300)
                ),
                _ => "–".into(),
            },
            match r.simulated_seconds {
                Some(sim) => spread(
                    sim / r.seconds.max(1e-12),
                    &r.run_simulated_over_measured,
                    |x| format!("{x:.3}")
                ),
                None => "–".into(),
            },
            match r.estimates_reused {
                0 => format!("{:.4}", r.estimate_seconds),
                n => format!("{:.4} ({n} reused)", r.estimate_seconds),
            },
            r.plan_seconds,
            r.prediction_error.map_or_else(|| "–".into(), pct),
            r.launches,
            r.traffic.bytes(),
        );
    }
    s
}

/// The balance targets on two devices, per scene, shader and task size: cost-based StaticLpt
/// balance ≥ 97 %, Hybrid ≥ 99 %, and LPT (cost) at least as fast as Equal and FIFO (regular).
/// Each is judged on the cells' medians; with several runs, also in how many runs it held
/// (for the speeds, run `i` of each cell against run `i` of the others: the same round).
pub fn targets(records: &[Record]) -> String {
    let find = |r0: &Record, policy: &str, mode: &str| {
        records.iter().find(|r| {
            r.scene == r0.scene
                && r.shader == r0.shader
                && r.task_size == r0.task_size
                && r.policy == policy
                && r.mode == mode
        })
    };
    let mark = |ok: bool| if ok { "yes" } else { "**no**" };
    let mut s = String::from(
        "| scene | shader | task size | LPT cost balance ≥ 97 % | Hybrid cost balance ≥ 99 % | LPT cost MRays/s ≥ Equal, FIFO regular |\n\
         |---|---|---:|---|---|---|\n",
    );
    let mut seen = Vec::new();
    for r in records {
        let key = (&r.scene, r.shader, r.task_size);
        if seen.contains(&key) {
            continue;
        }
        seen.push(key);
        let lpt = find(r, "static-lpt", "cost");
        let hyb = find(r, "hybrid", "cost");
        let (eq, fifo) = (
            find(r, "static-equal", "regular"),
            find(r, "queue-fifo", "regular"),
        );
        let cell_b = |x: Option<&Record>, min: f64| {
            x.map_or("–".into(), |x| {
                let runs = &x.run_balance_efficiency;
                format!(
                    "{} ({}{})",
                    mark(x.balance_efficiency >= min),
                    pct(x.balance_efficiency),
                    of_runs(runs.len(), |i| runs[i] >= min)
                )
            })
        };
        let speed = match (lpt, eq, fifo) {
            (Some(l), Some(e), Some(f)) => {
                let (lr, er, fr) = (&l.run_mrays_per_s, &e.run_mrays_per_s, &f.run_mrays_per_s);
                let rounds = lr.len().min(er.len()).min(fr.len());
                format!(
                    "{} ({:.2} vs {:.2}, {:.2}{})",
                    mark(l.mrays_per_s >= e.mrays_per_s && l.mrays_per_s >= f.mrays_per_s),
                    l.mrays_per_s,
                    e.mrays_per_s,
                    f.mrays_per_s,
                    of_runs(rounds, |i| lr[i] >= er[i] && lr[i] >= fr[i])
                )
            }
            _ => "–".into(),
        };
        s += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.scene,
            r.shader,
            r.task_size,
            cell_b(lpt, 0.97),
            cell_b(hyb, 0.99),
            speed
        );
    }
    s
}

/// The simulated machines, for the PCIe link and one task size (all of them are in the JSON):
/// the thesis's regular baselines against the cost-based policies.
pub fn simulated(records: &[SimRecord], task_size: usize) -> String {
    let mut s = String::from(
        "| scene | shader | devices (speeds) | link | policy | mode | MRays/s | balance | makespan / bound | launches |\n\
         |---|---|---|---|---|---|---:|---:|---:|---:|\n",
    );
    let shown = [
        ("static-equal", "regular"),
        ("queue-fifo", "regular"),
        ("static-lpt", "cost"),
        ("hybrid", "cost"),
    ];
    for r in records.iter().filter(|r| {
        r.source != "projected"
            && r.link == "pcie"
            && r.task_size == task_size
            && shown.contains(&(r.policy, r.mode))
    }) {
        let speeds: Vec<String> = r.speeds.iter().take(4).map(|v| v.to_string()).collect();
        s += &format!(
            "| {} | {} | {} ({}{}) | {} | {} | {} | {:.2} | {} | {:.4} | {} |\n",
            r.scene,
            r.shader,
            r.devices,
            speeds.join(","),
            if r.speeds.len() > 4 { ",…" } else { "" },
            r.link,
            r.policy,
            r.mode,
            r.mrays_per_s,
            pct(r.balance_efficiency),
            r.makespan_over_bound,
            r.launches
        );
    }
    s
}

/// The projected machines for one task size (thesis Figures 4.1 and 4.2): MRays/s and balance
/// of every policy and mode, a column per machine.
pub fn projected(records: &[SimRecord], task_size: usize) -> String {
    let shown: Vec<&SimRecord> = (records.iter())
        .filter(|r| r.source == "projected" && r.task_size == task_size)
        .collect();
    let mut machines: Vec<&str> = Vec::new();
    let mut rows: Vec<(&str, &str, &str, &str)> = Vec::new();
    for r in &shown {
        let machine = r.device_list.as_deref().unwrap_or_default();
        if !machines.contains(&machine) {
            machines.push(machine);
        }
        let row = (r.scene.as_str(), r.shader, r.policy, r.mode);
        if !rows.contains(&row) {
            rows.push(row);
        }
    }
    let mut s = format!(
        "| scene | shader | policy | mode | {} |\n|---|---|---|---|{}\n",
        machines.join(" | "),
        "---:|".repeat(machines.len())
    );
    for row in rows {
        s += &format!("| {} | {} | {} | {} |", row.0, row.1, row.2, row.3);
        for &machine in &machines {
            let cell = shown.iter().find(|r| {
                (r.scene.as_str(), r.shader, r.policy, r.mode) == row
                    && r.device_list.as_deref() == Some(machine)
            });
            s += &cell.map_or(" – |".into(), |r| {
                format!(" {:.2} / {} |", r.mrays_per_s, pct(r.balance_efficiency))
            });
        }
        s += "\n";
    }
    s
}

/// What the projected figures assume, with each class's launch latency as the records used it.
pub fn projection_assumptions(records: &[SimRecord]) -> String {
    // Each class's range of latencies over the replays, and where they came from.
    let mut classes: Vec<(&str, &str, f64, f64)> = Vec::new();
    for r in records.iter().filter(|r| r.source == "projected") {
        let class = r.device_list.as_deref().and_then(|l| l.split(':').next());
        let class = class.unwrap_or_default();
        match classes.iter_mut().find(|c| (c.0, c.1) == (class, r.link)) {
            Some(c) => (c.2, c.3) = (c.2.min(r.latency), c.3.max(r.latency)),
            None => classes.push((class, r.link, r.latency, r.latency)),
        }
    }
    let latencies: Vec<String> = (classes.iter())
        .map(|&(class, link, lo, hi)| {
            let range = if hi > lo {
                format!("{:.1}–{:.1}", 1e6 * lo, 1e6 * hi)
            } else {
                format!("{:.1}", 1e6 * lo)
            };
            let why = if link == "measured" {
                "measured"
            } else {
                "the PCIe link's, none measured"
            };
            format!("{class} {range} µs, {why}")
        })
        .collect();
    format!(
        "Assumptions: every projected device is identical, at the mean speed the run measured \
         for its class; each measured task takes its measured time scaled by its device's \
         measured rate over that speed; each launch waits the class's launch latency ({}); \
         the host-device traffic is what the measured task times include. Not modelled: \
         contention between the devices for the link, the memory or the host (a host core \
         per GPU), memory bandwidth and capacity, and the estimation and planning time \
         (MRays/s is over the makespans alone).\n",
        latencies.join("; ")
    )
}

/// Table 4.1's trade, judged first by time: each estimate's calibrated error and rank
/// correlation against the measured task times, beside their bound (the real trace's own
/// counts) and what estimating costs a render; the thesis's prediction error and figures
/// after them.
pub fn trade(points: &[TradePoint]) -> String {
    let mut s = String::from(
        "| scene | rays | task size | walk | sampled | error vs time | spearman | bound: trace counts | net overhead | LPT balance, 8 devices | prediction error | overhead | thesis (error, overhead) | error ≤ 2 / 3 %, overhead ≤ 4 % |\n\
         |---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|\n",
    );
    let opt = |v: Option<f64>, f: fn(f64) -> String| v.map_or_else(|| "–".into(), f);
    for p in points {
        let thesis = match (p.thesis_prediction_error, p.thesis_overhead) {
            (Some(e), Some(o)) => format!("{}, {}", pct(e), pct(o)),
            _ => "–".into(),
        };
        s += &format!(
            "| {} | {} | {} | {} | {:.2} % | {} | {} | {} ({}) | {} | {} | {} | {} | {} | {} |\n",
            p.scene,
            p.ray_kind,
            p.task_size,
            p.figures.walk,
            100.0 * p.sample_rate,
            opt(p.figures.error_vs_time, pct),
            opt(p.figures.spearman_vs_time, |x| format!("{x:.3}")),
            opt(p.error_vs_time_trace, pct),
            opt(p.spearman_trace_vs_time, |x| format!("{x:.3}")),
            pct(p.figures.net_overhead),
            opt(p.lpt_balance, pct),
            opt(p.figures.prediction_error, pct),
            pct(p.figures.overhead),
            thesis,
            if p.meets_target { "yes" } else { "no" }
        );
    }
    s
}

/// `|simulated / measured − 1|` over every measured run that was replayed: its median and
/// largest, and the runs counted. `None` when no run was replayed.
pub fn replay_error(records: &[Record]) -> Option<(f64, f64, usize)> {
    ratio_error(records, |r| &r.run_simulated_over_measured)
}

/// `|x − 1|` over every ratio `ratios` gives of the records: median, largest and count.
fn ratio_error(records: &[Record], ratios: fn(&Record) -> &[f64]) -> Option<(f64, f64, usize)> {
    let errors: Vec<f64> = records
        .iter()
        .flat_map(|r| ratios(r).iter().map(|x| (x - 1.0).abs()))
        .collect();
    let median = super::repeats::median(&errors)?;
    let largest = errors.iter().copied().fold(0.0, f64::max);
    Some((median, largest, errors.len()))
}

/// The spread of the simulator's replays of the measured runs, in one paragraph.
pub fn replays(records: &[Record]) -> String {
    let ratios: Vec<f64> = records
        .iter()
        .flat_map(|r| r.run_simulated_over_measured.iter().copied())
        .collect();
    match replay_error(records) {
        Some((median, largest, n)) => {
            let (lo, hi) = ratios
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                    (lo.min(x), hi.max(x))
                });
            format!(
                "Simulator replays of the {n} measured runs (their own task times, speeds and launch delays): \
                 simulated / measured {lo:.3} to {hi:.3}, median |simulated / measured − 1| {}, largest {}.\n",
                pct(median),
                pct(largest)
            )
        }
        None => "No measured run could be replayed in the simulator.\n".into(),
    }
}

/// How far the predictions made before each run fell from it, in one paragraph.
pub fn predictions(records: &[Record]) -> String {
    let runs: usize = records.iter().map(|r| r.repeats.max(1)).sum();
    match ratio_error(records, |r| &r.run_predicted_over_measured) {
        Some((median, largest, n)) => format!(
            "Predictions made before each run (its estimates, each device class's paths per \
             second on earlier frames, the policy simulated) for {n} of the {runs} runs: \
             median |predicted / measured − 1| {}, largest {}.\n",
            pct(median),
            pct(largest)
        ),
        None => "No run was predicted: no device class had been measured before it.\n".into(),
    }
}
