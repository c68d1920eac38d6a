//! One cell of the matrix from several runs of it: `--repeats N` runs the whole matrix `N`
//! times, round after round, and keeps the median of each figure with every run's MRays/s and
//! balance beside it.
//!
//! On a shared machine one run is a sample of the neighbours' load as much as of the policy:
//! two identical static-LPT renders can give equal halves of work several points of balance
//! apart. A median of rounds, each of which runs every cell once, stops such a run from
//! deciding a cell, and the runs kept beside it show how much the cell moved.

use super::record::Record;

/// The median of `values` (the mean of the middle two for an even count); `None` when empty.
pub fn median(values: &[f64]) -> Option<f64> {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some(0.5 * (v[n / 2 - 1] + v[n / 2])),
    }
}

/// The index of the run whose time is the median's (the faster of the middle two for an even
/// count): the run whose tasks the simulator replays.
pub fn median_run(runs: &[Record]) -> Option<usize> {
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by(|&a, &b| runs[a].seconds.total_cmp(&runs[b].seconds));
    order.get(runs.len().saturating_sub(1) / 2).copied()
}

/// One record of a cell's runs (all of one scene, shader, task size, policy and mode): the
/// median seconds (and MRays/s over them), balance, estimation and planning time; the
/// launches of the median run; reruns and reused estimates summed; every run's MRays/s and
/// balance in run order. `None` when there are no runs.
pub fn combine(runs: &[Record]) -> Option<Record> {
    let mid = median_run(runs)?;
    let of =
        |f: fn(&Record) -> f64| -> Option<f64> { median(&runs.iter().map(f).collect::<Vec<_>>()) };
    let mut out = runs[mid].clone();
    out.seconds = of(|r| r.seconds)?;
    out.mrays_per_s = out.rays as f64 / out.seconds.max(1e-12) / 1e6;
    out.balance_efficiency = of(|r| r.balance_efficiency)?;
    out.estimate_seconds = of(|r| r.estimate_seconds)?;
    out.plan_seconds = of(|r| r.plan_seconds)?;
    out.reruns = runs.iter().map(|r| r.reruns).sum();
    out.estimates_reused = runs.iter().map(|r| r.estimates_reused).sum();
    out.repeats = runs.len();
    out.run_mrays_per_s = runs.iter().map(|r| r.mrays_per_s).collect();
    out.run_balance_efficiency = runs.iter().map(|r| r.balance_efficiency).collect();
    out.run_simulated_over_measured = runs
        .iter()
        .flat_map(|r| r.run_simulated_over_measured.iter().copied())
        .collect();
    out.run_predicted_over_measured = runs
        .iter()
        .flat_map(|r| r.run_predicted_over_measured.iter().copied())
        .collect();
    // Only when every run was replayed (predicted): a median of some runs would not be the
    // cell's.
    let simulated: Option<Vec<f64>> = runs.iter().map(|r| r.simulated_seconds).collect();
    out.simulated_seconds = simulated.and_then(|s| median(&s));
    let predicted: Option<Vec<f64>> = runs.iter().map(|r| r.predicted_seconds).collect();
    out.predicted_seconds = predicted.and_then(|s| median(&s));
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(seconds: f64, balance: f64, launches: u64, reruns: u64) -> Record {
        Record {
            source: "measured",
            scene: "s".into(),
            shader: "ao",
            ray_kind: "diffuse",
            policy: "static-lpt",
            mode: "cost",
            walk: "trace",
            sample_rate: 0.03125,
            backups: true,
            task_size: 512,
            tasks: 1,
            cut_task_size: 512,
            devices: 2,
            device_list: "cpu:2".into(),
            cameras: 1,
            width: 8,
            height: 8,
            rays: 2_000_000,
            seconds,
            mrays_per_s: 2.0 / seconds,
            balance_efficiency: balance,
            estimate_seconds: 0.1 * seconds,
            estimates_reused: 0,
            plan_seconds: 0.001,
            prediction_error: Some(0.02),
            launches,
            reruns,
            repeats: 1,
            run_mrays_per_s: vec![2.0 / seconds],
            run_balance_efficiency: vec![balance],
            traffic: Default::default(),
            film_bytes: 0,
            simulated_seconds: Some(seconds),
            run_simulated_over_measured: vec![1.0],
            predicted_seconds: None,
            run_predicted_over_measured: Vec::new(),
            makespan_seconds: seconds,
            simulated_makespan_seconds: Some(seconds),
            lower_bound_seconds: Some(0.5 * seconds),
            fractional_bound_seconds: Some(0.4 * seconds),
            makespan_over_bound: Some(2.0),
            calibration: None,
            left_idle: Vec::new(),
            mpi: None,
        }
    }

    #[test]
    fn medians_of_odd_and_even_counts() {
        assert_eq!(median(&[]), None);
        assert_eq!(median(&[3.0]), Some(3.0));
        assert_eq!(median(&[5.0, 1.0, 3.0]), Some(3.0));
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), Some(2.5));
    }

    /// A slow outlier moves neither the time nor the balance; the median run's launches are
    /// kept, reruns add up, and every run stays visible in run order.
    #[test]
    fn a_cell_keeps_its_median_run_and_lists_every_run() {
        let runs = [
            run(0.5, 0.99, 2, 0),
            run(0.9, 0.90, 3, 1),
            run(0.6, 0.98, 4, 0),
        ];
        let c = combine(&runs).expect("three runs");
        assert_eq!(c.seconds, 0.6);
        assert!((c.mrays_per_s - 2.0 / 0.6).abs() < 1e-12);
        assert_eq!(c.balance_efficiency, 0.98);
        assert!((c.estimate_seconds - 0.06).abs() < 1e-15);
        assert_eq!((c.launches, c.reruns, c.repeats), (4, 1, 3));
        assert_eq!(c.run_balance_efficiency, vec![0.99, 0.90, 0.98]);
        assert_eq!(c.run_mrays_per_s.len(), 3);
        assert_eq!(median_run(&runs), Some(2));
        // Two runs: the mean of both times, the faster run's launches.
        let two = combine(&runs[..2]).expect("two runs");
        assert!((two.seconds - 0.7).abs() < 1e-15);
        assert_eq!((two.launches, two.repeats), (2, 2));
        assert!(combine(&[]).is_none());
    }
}
