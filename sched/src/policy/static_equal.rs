use crate::{Plan, Speeds};

/// Contiguous blocks of tasks, sized in proportion to device speed (largest remainder, ties
/// to the lower device index). With identical devices: `n / m` tasks each, in order.
pub fn plan_equal(tasks: usize, speeds: &Speeds) -> Plan {
    let total = speeds.total();
    let quotas: Vec<f64> = speeds
        .as_slice()
        .iter()
        .map(|s| tasks as f64 * s / total)
        .collect();
    let mut counts: Vec<usize> = quotas.iter().map(|q| q.floor() as usize).collect();
    let assigned: usize = counts.iter().sum();
    let mut by_remainder: Vec<usize> = (0..counts.len()).collect();
    by_remainder.sort_by(|&a, &b| {
        (quotas[b] - quotas[b].floor()).total_cmp(&(quotas[a] - quotas[a].floor()))
    });
    // Rounding can leave the floors a few tasks short (never over): hand those out.
    for &d in by_remainder
        .iter()
        .cycle()
        .take(tasks.saturating_sub(assigned))
    {
        counts[d] += 1;
    }
    let mut next = 0u32;
    Plan::from_lists(
        counts
            .into_iter()
            .map(|c| {
                let list = (next..next + c as u32).collect();
                next += c as u32;
                list
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_follow_speeds() {
        let plan = plan_equal(10, &Speeds::new(vec![1.0, 1.0, 2.0]).unwrap());
        assert_eq!(plan.tasks(0), &[0, 1, 2]);
        assert_eq!(plan.tasks(1), &[3, 4]);
        assert_eq!(plan.tasks(2), &[5, 6, 7, 8, 9]);
    }

    #[test]
    fn more_devices_than_tasks() {
        let plan = plan_equal(2, &Speeds::identical(5).unwrap());
        let sizes: Vec<usize> = (0..5).map(|d| plan.tasks(d).len()).collect();
        assert_eq!(sizes.iter().sum::<usize>(), 2);
        assert!(sizes.iter().all(|&s| s <= 1));
    }
}
