//! Lower bounds on the optimal makespan and the guarantees each policy carries.

use crate::{Costs, Load, Speeds};

/// A lower bound on the optimal makespan on devices of the given speeds (Horvath, Lam and
/// Sethi 1977): the `k` largest tasks need at least the `k` fastest devices, for every
/// `k < m`, and all work needs all speed. On identical devices it is
/// `max(largest cost, total / m)`.
///
/// It is integral: tasks are not split, so no plan beats the largest task on the fastest
/// device. A generation of fewer or coarser tasks than devices can do nothing about is judged
/// by it, where [`fractional_bound`] would blame the plan for the tasks' size.
pub fn lower_bound(costs: &Costs, speeds: &Speeds) -> f64 {
    let mut c = costs.as_slice().to_vec();
    c.sort_by(|a, b| b.total_cmp(a));
    let mut s = speeds.as_slice().to_vec();
    s.sort_by(|a, b| b.total_cmp(a));
    let mut bound: f64 = 0.0;
    let (mut work, mut speed) = (Load::ZERO, Load::ZERO);
    for k in 0..s.len().min(c.len()) {
        work = work.plus(c[k]);
        speed = speed.plus(s[k]);
        bound = bound.max(work.value() / speed.value());
    }
    bound.max(costs.total().value() / speeds.total())
}

/// The bound of perfectly divisible work: total work over total speed. It is what balance
/// efficiency measures against, and no more than [`lower_bound`].
pub fn fractional_bound(costs: &Costs, speeds: &Speeds) -> f64 {
    costs.total().value() / speeds.total()
}

/// Graham (1969): LPT on `m` identical devices is within this factor of optimal.
pub fn lpt_identical_factor(m: usize) -> f64 {
    4.0 / 3.0 - 1.0 / (3.0 * m as f64)
}

/// Graham (1966): any list schedule on `m` identical devices (a central queue in any order)
/// is within this factor of optimal.
pub fn list_factor(m: usize) -> f64 {
    2.0 - 1.0 / m as f64
}

/// Kovács (2010): LPT that picks the earliest finish on devices of different speeds is
/// within `1 + √3/3 ≈ 1.577` of optimal.
pub const LPT_UNIFORM_FACTOR: f64 = 1.0 + 0.577_350_269_189_625_8;

/// The factor the given policy is proven to stay within, for these speeds, if any.
pub fn guarantee(policy: crate::Policy, speeds: &Speeds) -> Option<f64> {
    use crate::Policy::*;
    let m = speeds.len();
    match (policy, speeds.are_identical()) {
        // A cost-sorted queue on identical devices hands the next largest task to the least
        // loaded device: LPT's choices.
        (StaticLpt | Hybrid | QueueSorted, true) => Some(lpt_identical_factor(m)),
        (StaticLpt | Hybrid, false) => Some(LPT_UNIFORM_FACTOR),
        (QueueFifo, true) => Some(list_factor(m)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_on_mixed_speeds() {
        let costs = Costs::new(vec![10.0, 1.0, 1.0]).unwrap();
        let speeds = Speeds::new(vec![2.0, 1.0]).unwrap();
        // The big task alone needs 10 / 2 = 5 on the fastest device.
        assert_eq!(lower_bound(&costs, &speeds), 5.0);
        assert_eq!(lower_bound(&Costs::default(), &speeds), 0.0);
        assert!((LPT_UNIFORM_FACTOR - (1.0 + 3f64.sqrt() / 3.0)).abs() < 1e-15);
        // Divisible, the same work would need (10 + 1 + 1) / 3 = 4.
        assert_eq!(fractional_bound(&costs, &speeds), 4.0);
    }
}
