//! Estimates judged by measured task times ([`judge`], for `cobalt estimate` and the bench's
//! sampling trade): beyond the thesis's prediction error (`sched::prediction_error`, against
//! the full reduced traversal), their error against measured time ([`error_vs_time`]) and
//! rank correlation with it (`sched::rank_correlation`), both fractions, not percentages; and
//! what an estimate buys a plan: the balance of a static LPT plan made from the estimates,
//! judged by the measured task times. It puts a plan's view beside `error_vs_time`: an error
//! that leaves the tasks' order intact costs a plan little, one that swaps big and small tasks
//! costs it much.

use super::calibrate::{Fit, calibrate};
use super::model::Work;
use sched::{Costs, Speeds, plan_equal, plan_lpt};

/// Estimates judged by measured task times: calibrated to them, then their error, rank
/// correlation and the balance they buy a plan (each `None` where it cannot be had).
#[derive(Clone, Copy, Debug, Default)]
pub struct Judged {
    /// The calibration of the estimates to the times.
    pub fit: Option<Fit>,
    /// The calibrated estimates' error against the times ([`error_vs_time`]).
    pub error_vs_time: Option<f64>,
    /// Their rank correlation with the times ([`sched::rank_correlation`]).
    pub spearman_vs_time: Option<f64>,
    /// The balance of an LPT plan by them, judged by the times ([`lpt`]).
    pub lpt_balance: Option<f64>,
}

/// `work` calibrated against `measured` (one time per task) and judged by it.
pub fn judge(work: &[Work], measured: &[f64]) -> Judged {
    let Some(fit) = calibrate(work, measured) else {
        return Judged::default();
    };
    let costs = fit.model.costs(work);
    Judged {
        fit: Some(fit),
        error_vs_time: error_vs_time(&costs, measured),
        spearman_vs_time: sched::rank_correlation(&costs, measured),
        lpt_balance: lpt(&costs, measured),
    }
}

/// Error against measured time: the estimates are scaled to seconds by the least-squares
/// factor `s = Σ e·t / Σ e²`, then `Σ|s·e − t| / Σ t`. Estimates in any unit can be judged.
/// `None` if the lengths differ, there is no task, a value is not finite and non-negative,
/// or the estimates or the times are all zero.
pub fn error_vs_time(estimated: &[f64], seconds: &[f64]) -> Option<f64> {
    let usable = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x >= 0.0);
    if estimated.len() != seconds.len() || !usable(estimated) || !usable(seconds) {
        return None;
    }
    let ee: f64 = estimated.iter().map(|e| e * e).sum();
    let et: f64 = estimated.iter().zip(seconds).map(|(e, t)| e * t).sum();
    let total: f64 = seconds.iter().sum();
    if ee <= 0.0 || total <= 0.0 {
        return None;
    }
    let s = et / ee;
    let diff: f64 = estimated
        .iter()
        .zip(seconds)
        .map(|(e, t)| (s * e - t).abs())
        .sum();
    Some(diff / total)
}

/// Equal devices the plans are made for: with tasks of 4096 rays a 512² frame gives each of
/// them 8 tasks, few enough that where each big task goes shows in the balance.
pub const DEVICES: usize = 8;

/// Balance (mean over largest device time, in `(0, 1]`) of the LPT plan made from
/// `estimates` on [`DEVICES`] equal devices, each device's time the sum of its tasks'
/// `measured` times; `None` if either list is unusable (empty, of other lengths, negative
/// or not finite).
pub fn lpt(estimates: &[f64], measured: &[f64]) -> Option<f64> {
    if estimates.len() != measured.len() {
        return None;
    }
    let plan = plan_lpt(&Costs::new(estimates.to_vec()).ok()?, &speeds());
    judged(&plan, measured)
}

/// The balance without an estimate: tasks dealt out in order, the same number to each device.
pub fn uniform(measured: &[f64]) -> Option<f64> {
    judged(&plan_equal(measured.len(), &speeds()), measured)
}

fn speeds() -> Speeds {
    Speeds::identical(DEVICES).expect("a positive number of devices")
}

fn judged(plan: &sched::Plan, measured: &[f64]) -> Option<f64> {
    let costs = Costs::new(measured.to_vec()).ok()?;
    let makespan = plan.makespan(&costs, &speeds());
    let total: f64 = measured.iter().sum();
    (makespan > 0.0).then(|| total / (DEVICES as f64 * makespan))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_estimates_balance_better_than_none_and_than_inverted_ones() {
        // 16 tasks, one big one and a tail: LPT by the truth places the big task alone.
        let measured: Vec<f64> = (0..16)
            .map(|i| if i == 5 { 8.0 } else { 1.0 + i as f64 * 0.1 })
            .collect();
        let exact = lpt(&measured, &measured).unwrap();
        let inverted: Vec<f64> = measured.iter().map(|t| 1.0 / t).collect();
        let wrong = lpt(&inverted, &measured).unwrap();
        let none = uniform(&measured).unwrap();
        assert!(exact <= 1.0 && exact > none && none > 0.0, "{exact} {none}");
        assert!(wrong < exact, "{wrong} {exact}");
        assert_eq!(lpt(&[1.0], &[]), None);
        assert_eq!(lpt(&[f64::NAN, 1.0], &[1.0, 1.0]), None);
    }

    #[test]
    fn error_vs_time_ignores_the_unit() {
        let t = [1e-3, 2e-3, 4e-3];
        assert!(error_vs_time(&[10.0, 20.0, 40.0], &t).unwrap() < 1e-12);
        assert!(error_vs_time(&[1.0, 1.0, 1.0], &t).unwrap() > 0.2);
        assert_eq!(error_vs_time(&[0.0; 3], &t), None);
        assert_eq!(error_vs_time(&[], &[]), None);
        assert_eq!(error_vs_time(&[1.0, 2.0], &t), None);
        assert_eq!(error_vs_time(&[1.0, f64::NAN, 1.0], &t), None);
    }

    #[test]
    fn rank_correlation_on_known_vectors() {
        let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
        let rho = sched::rank_correlation;
        assert!(close(
            rho(&[1.0, 2.0, 3.0, 4.0], &[10.0, 20.0, 30.0, 1e9]).unwrap(),
            1.0
        ));
        // No ties: ranks of b are (2, 1, 4, 3, 5), so d = (−1, 1, −1, 1, 0), Σd² = 4, ρ = 1 − 24/120.
        let r = rho(&[1.0, 2.0, 3.0, 4.0, 5.0], &[2.0, 1.0, 3.0, 2.5, 6.0]).unwrap();
        assert!(close(r, 0.8), "{r}");
    }
}
