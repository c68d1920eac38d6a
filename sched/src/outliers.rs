//! Timing spikes kept out of what a run learns.
//!
//! A device's speed and a cost model's coefficients are fitted to measured task times. One
//! task that a page fault, a preempted thread or a neighbour's burst made a hundred times
//! slower than it is would, in a least-squares fit or a sum of busy time, move the next plan
//! on its own. So each task's time is first compared with its prediction: the ratio
//! `seconds / predicted` of every task one device ran is set against the median ratio of
//! those tasks, and a task beyond [`SPIKE_FACTOR`] of it, either way, is left out (and
//! counted). The median is what one spike cannot move.

/// How far from the median ratio a task's time may be and still be learnt from.
pub const SPIKE_FACTOR: f64 = 1.5;

/// Which of the tasks (`predicted[i]` cost, `seconds[i]` measured, all on one device) are
/// fit to learn from: within `factor` of their median `seconds / predicted`. Tasks without a
/// positive, finite prediction and time are kept out too. With fewer than three usable tasks
/// there is no median to trust, and every usable one is kept. The median is the lower middle
/// ratio itself, never a mean of two: so at least one task is always kept, even when the
/// ratios fall into two groups far apart (a launch timed as a whole beside tasks timed at
/// almost nothing), where the mean of the two middle ones lay beyond `factor` of both.
pub fn inliers(predicted: &[f64], seconds: &[f64], factor: f64) -> Vec<bool> {
    let ratio = |i: usize| {
        let (p, s) = (predicted[i], seconds[i]);
        (p > 0.0 && p.is_finite() && s > 0.0 && s.is_finite()).then(|| s / p)
    };
    let n = predicted.len().min(seconds.len());
    let ratios: Vec<Option<f64>> = (0..n).map(ratio).collect();
    let mut usable: Vec<f64> = ratios.iter().flatten().copied().collect();
    if usable.len() < 3 {
        return ratios.iter().map(Option::is_some).collect();
    }
    usable.sort_by(f64::total_cmp);
    let median = usable[(usable.len() - 1) / 2];
    ratios
        .iter()
        .map(|r| r.is_some_and(|r| r <= factor * median && r * factor >= median))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spike_is_left_out_and_the_rest_kept() {
        let predicted = [1.0, 2.0, 3.0, 4.0, 5.0];
        let mut seconds = [1.1, 2.0, 2.9, 4.2, 5.0];
        assert_eq!(inliers(&predicted, &seconds, SPIKE_FACTOR), vec![true; 5]);
        seconds[2] *= 100.0;
        assert_eq!(
            inliers(&predicted, &seconds, SPIKE_FACTOR),
            vec![true, true, false, true, true]
        );
        // Too fast is as suspect as too slow; unusable values are never learnt from.
        seconds[2] = 0.01;
        seconds[4] = f64::NAN;
        assert_eq!(
            inliers(&predicted, &seconds, SPIKE_FACTOR),
            vec![true, true, false, true, false]
        );
        // Two tasks: no median to trust.
        assert_eq!(inliers(&[1.0, 1.0], &[1.0, 100.0], 1.5), vec![true, true]);
        // Two groups far apart: the lower one is learnt from, never none.
        assert_eq!(
            inliers(&[1.0; 4], &[1.0, 1.0, 100.0, 100.0], 1.5),
            vec![true, true, false, false]
        );
    }
}
