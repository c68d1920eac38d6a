use std::time::Instant;

use crate::{Load, SchedError, Task};

/// Validated task costs: finite and non-negative, in any unit (seconds, node visits…), for
/// at most `u32::MAX` tasks (task indices are `u32` to halve the size of plans).
///
/// Only the ratios between costs matter to a policy; the simulator reads them as time.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Costs(Vec<f64>);

impl Costs {
    /// Checks every cost; the error names the first bad one.
    pub fn new(costs: Vec<f64>) -> Result<Self, SchedError> {
        if costs.len() > u32::MAX as usize {
            return Err(SchedError::TooManyTasks { tasks: costs.len() });
        }
        if let Some((task, &value)) = costs
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.is_finite() && **c >= 0.0))
        {
            return Err(SchedError::BadCost { task, value });
        }
        // Every policy and the simulator add costs up; a total that overflows would come out
        // as an infinite makespan and a NaN balance.
        let mut total = 0.0f64;
        for (task, &value) in costs.iter().enumerate() {
            total += value;
            if !total.is_finite() {
                return Err(SchedError::CostOverflow { task, value });
            }
        }
        // −0.0 passes the check; make it +0.0 so costs order like their bits.
        Ok(Costs(costs.into_iter().map(|c| c + 0.0).collect()))
    }

    /// `n` tasks of cost 1: the thesis's "regular mode", where every task looks the same.
    pub fn uniform(n: usize) -> Self {
        Costs(vec![1.0; n])
    }

    /// The costs, in task order.
    pub fn as_slice(&self) -> &[f64] {
        &self.0
    }

    /// Number of tasks.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// True when there are no tasks.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The exact total.
    pub fn total(&self) -> Load {
        Load::sum(self.0.iter().copied())
    }

    /// Task indices sorted by decreasing cost, ties by index: the order of LPT and of a
    /// cost-sorted queue.
    pub fn decreasing_order(&self) -> Vec<u32> {
        // Non-negative finite doubles order like their bit patterns (`new` turns −0 into +0),
        // so one unstable sort of integer keys gives the order; the index in the low bits
        // breaks ties, which keeps plans reproducible. About 5× faster than sorting indices
        // through a comparison closure on a million tasks.
        let mut keys: Vec<u128> = self
            .0
            .iter()
            .enumerate()
            .map(|(i, c)| (u128::from(!c.to_bits()) << 32) | i as u128)
            .collect();
        keys.sort_unstable();
        keys.into_iter().map(|k| k as u32).collect()
    }
}

impl std::ops::Index<usize> for Costs {
    type Output = f64;
    fn index(&self, task: usize) -> &f64 {
        &self.0[task]
    }
}

/// Estimates what each task will cost before it runs.
///
/// One required method. An estimator may sample (the reduced traversal of 1/8 of a task's
/// rays) and may be wrong; policies only need the order and rough ratios to be right.
pub trait CostEstimator<T: Task> {
    /// One cost per task, in task order, in any consistent unit.
    fn estimate(&self, tasks: &[T]) -> Vec<f64>;

    /// Estimates, validates and times the estimate, so its overhead can be reported.
    fn estimate_timed(&self, tasks: &[T]) -> Result<Estimate, SchedError> {
        let start = Instant::now();
        let raw = self.estimate(tasks);
        let seconds = start.elapsed().as_secs_f64();
        if raw.len() != tasks.len() {
            return Err(SchedError::LengthMismatch {
                what: "estimator returned a cost per task",
                expected: tasks.len(),
                got: raw.len(),
            });
        }
        Ok(Estimate {
            costs: Costs::new(raw)?,
            seconds,
        })
    }
}

/// Estimated costs and the time it took to get them.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate {
    /// The validated costs.
    pub costs: Costs,
    /// Wall time of the estimation, in seconds: the estimation overhead.
    pub seconds: f64,
}

/// Every task costs the same: the regular (cost-free) mode of the thesis.
#[derive(Debug, Clone, Copy, Default)]
pub struct Uniform;

impl<T: Task> CostEstimator<T> for Uniform {
    fn estimate(&self, tasks: &[T]) -> Vec<f64> {
        vec![1.0; tasks.len()]
    }
}

/// A task costs its number of items: a good estimate when items cost about the same.
#[derive(Debug, Clone, Copy, Default)]
pub struct ByItems;

impl<T: Task> CostEstimator<T> for ByItems {
    fn estimate(&self, tasks: &[T]) -> Vec<f64> {
        tasks.iter().map(|t| t.items() as f64).collect()
    }
}

/// Any closure from a task to its cost is an estimator.
impl<T: Task, F: Fn(&T) -> f64> CostEstimator<T> for F {
    fn estimate(&self, tasks: &[T]) -> Vec<f64> {
        tasks.iter().map(self).collect()
    }
}

/// The thesis's prediction error: `Σ|estimated − full| / Σ full`, where "full" is the same
/// estimator over every item (so sampling everything gives 0). `None` if `full` sums to 0 or
/// the lengths differ.
pub fn prediction_error(estimated: &[f64], full: &[f64]) -> Option<f64> {
    let total: f64 = full.iter().sum();
    (estimated.len() == full.len() && total > 0.0).then(|| {
        estimated
            .iter()
            .zip(full)
            .map(|(e, f)| (e - f).abs())
            .sum::<f64>()
            / total
    })
}

/// Spearman's rank correlation (Pearson's on the ranks, ties averaged), in `[−1, 1]`: whether
/// the estimates order the tasks as the measurements do, which is what LPT needs. `None` if
/// the lengths differ, there are fewer than two tasks, or either series is constant.
pub fn rank_correlation(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 2 {
        return None;
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let mean = (a.len() as f64 + 1.0) / 2.0;
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        let (dx, dy) = (x - mean, y - mean);
        ab += dx * dy;
        aa += dx * dx;
        bb += dy * dy;
    }
    (aa > 0.0 && bb > 0.0).then(|| (ab / (aa * bb).sqrt()).clamp(-1.0, 1.0))
}

/// Ranks from 1, tied values sharing the mean of their ranks.
fn ranks(v: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..v.len()).collect();
    order.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        while j + 1 < order.len() && v[order[j + 1]] == v[order[i]] {
            j += 1;
        }
        // Positions i..=j (0-based) share ranks i+1..=j+1: their mean is (i + j)/2 + 1.
        let mean = (i + j) as f64 / 2.0 + 1.0;
        for &k in &order[i..=j] {
            r[k] = mean;
        }
        i = j + 1;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_costs_by_index() {
        for bad in [f64::NAN, f64::INFINITY, -1.0, f64::NEG_INFINITY] {
            let err = Costs::new(vec![1.0, bad]).unwrap_err();
            assert!(matches!(err, SchedError::BadCost { task: 1, .. }), "{err}");
        }
        assert!(Costs::new(vec![0.0, 1e-300, 1e300]).is_ok());
    }

    #[test]
    fn closure_estimators_are_timed_and_checked() {
        let tasks = crate::split_ranges(10, 3);
        let est = (|t: &std::ops::Range<usize>| t.len() as f64 * 2.0).estimate_timed(&tasks);
        assert_eq!(est.unwrap().costs.as_slice(), &[6.0, 6.0, 6.0, 2.0]);
        let bad = (|_: &std::ops::Range<usize>| f64::NAN).estimate_timed(&tasks);
        assert!(matches!(bad, Err(SchedError::BadCost { task: 0, .. })));
    }

    #[test]
    fn prediction_error_is_relative_to_the_full_total() {
        assert_eq!(prediction_error(&[1.0, 2.0], &[1.0, 2.0]), Some(0.0));
        assert_eq!(prediction_error(&[2.0, 2.0], &[1.0, 3.0]), Some(0.5));
        assert_eq!(prediction_error(&[1.0], &[0.0]), None);
        assert_eq!(prediction_error(&[], &[]), None);
        assert_eq!(prediction_error(&[1.0], &[1.0, 1.0]), None);
    }

    #[test]
    fn rank_correlation_averages_ties_and_refuses_constants() {
        assert_eq!(ranks(&[5.0, 5.0, 7.0, 9.0]), vec![1.5, 1.5, 3.0, 4.0]);
        let tied = rank_correlation(&[5.0, 5.0, 7.0, 9.0], &[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!((tied - 0.9486832980505138).abs() < 1e-12, "{tied}");
        assert_eq!(
            rank_correlation(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]),
            Some(-1.0)
        );
        assert_eq!(rank_correlation(&[1.0, 1.0], &[1.0, 2.0]), None);
        assert_eq!(rank_correlation(&[1.0], &[1.0]), None);
    }

    #[test]
    fn decreasing_order_is_stable() {
        let c = Costs::new(vec![1.0, 3.0, 1.0, 3.0, -0.0, 0.0, 1e-300, 2.5]).unwrap();
        assert_eq!(c.decreasing_order(), vec![1, 3, 7, 0, 2, 6, 4, 5]);
    }
}
