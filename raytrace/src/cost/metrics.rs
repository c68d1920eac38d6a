//! How good an estimate is beyond the thesis's prediction error (`sched::prediction_error`,
//! against the full reduced traversal): error and rank correlation against measured time.
//! Both are fractions, not percentages.

use super::CostError;

/// Checks two per-task series: same length, at least `needed` tasks, values finite and
/// non-negative.
fn check(
    what: &'static str,
    a: (&'static str, &[f64]),
    b: (&'static str, &[f64]),
    needed: usize,
) -> Result<(), CostError> {
    if a.1.len() != b.1.len() {
        return Err(CostError::LengthMismatch {
            what,
            expected: a.1.len(),
            got: b.1.len(),
        });
    }
    if a.1.len() < needed {
        return Err(CostError::TooFewTasks {
            what,
            needed,
            got: a.1.len(),
        });
    }
    for (name, values) in [a, b] {
        if let Some((task, &value)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(CostError::BadValue {
                what: name,
                task,
                value,
            });
        }
    }
    Ok(())
}

/// Error against measured time: the estimates are scaled to seconds by the least-squares
/// factor `s = Σ e·t / Σ e²`, then `Σ|s·e − t| / Σ t`. Estimates in any unit can be judged.
pub fn error_vs_time(estimated: &[f64], seconds: &[f64]) -> Result<f64, CostError> {
    check(
        "error vs time",
        ("estimated cost", estimated),
        ("measured time", seconds),
        1,
    )?;
    let ee: f64 = estimated.iter().map(|e| e * e).sum();
    let et: f64 = estimated.iter().zip(seconds).map(|(e, t)| e * t).sum();
    let total: f64 = seconds.iter().sum();
    if ee <= 0.0 || total <= 0.0 {
        return Err(CostError::Degenerate {
            what: "error vs time",
            why: "the estimates or the times are all zero",
        });
    }
    let s = et / ee;
    let diff: f64 = estimated
        .iter()
        .zip(seconds)
        .map(|(e, t)| (s * e - t).abs())
        .sum();
    Ok(diff / total)
}

/// Spearman's rank correlation (Pearson's on the ranks, ties averaged), in `[−1, 1]`: whether
/// the estimates order the tasks as the measurements do, which is what LPT needs. The inputs
/// are checked here, naming what is wrong; the statistic is [`sched::rank_correlation`].
pub fn spearman(a: &[f64], b: &[f64]) -> Result<f64, CostError> {
    check(
        "rank correlation",
        ("first value", a),
        ("second value", b),
        2,
    )?;
    sched::rank_correlation(a, b).ok_or(CostError::Degenerate {
        what: "rank correlation",
        why: "one of the series is constant",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_vs_time_ignores_the_unit() {
        let t = [1e-3, 2e-3, 4e-3];
        assert!(error_vs_time(&[10.0, 20.0, 40.0], &t).unwrap() < 1e-12);
        assert!(error_vs_time(&[1.0, 1.0, 1.0], &t).unwrap() > 0.2);
        assert!(error_vs_time(&[0.0; 3], &t).is_err());
    }

    #[test]
    fn spearman_on_known_vectors() {
        let close = |x: f64, y: f64| (x - y).abs() < 1e-12;
        assert!(close(
            spearman(&[1.0, 2.0, 3.0, 4.0], &[10.0, 20.0, 30.0, 1e9]).unwrap(),
            1.0
        ));
        assert!(close(
            spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap(),
            -1.0
        ));
        // No ties: ranks of b are (2, 1, 4, 3, 5), so d = (−1, 1, −1, 1, 0), Σd² = 4, ρ = 1 − 24/120.
        let rho = spearman(&[1.0, 2.0, 3.0, 4.0, 5.0], &[2.0, 1.0, 3.0, 2.5, 6.0]).unwrap();
        assert!(close(rho, 0.8), "{rho}");
        // Ties take the mean rank: a ranks (1.5, 1.5, 3, 4).
        let tied = spearman(&[5.0, 5.0, 7.0, 9.0], &[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!(close(tied, 4.5 / (4.5f64 * 5.0).sqrt()), "{tied}");
        assert!(matches!(
            spearman(&[1.0, 1.0], &[1.0, 2.0]),
            Err(CostError::Degenerate { .. })
        ));
        assert!(matches!(
            spearman(&[1.0], &[1.0]),
            Err(CostError::TooFewTasks { .. })
        ));
    }
}
