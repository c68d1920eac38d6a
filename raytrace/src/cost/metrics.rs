//! How good an estimate is beyond the thesis's prediction error (`sched::prediction_error`,
//! against the full reduced traversal): its error against measured time. Its rank correlation
//! with them is `sched::rank_correlation`. Both are fractions, not percentages.

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

#[cfg(test)]
mod tests {
    use super::*;

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
