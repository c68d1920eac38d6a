//! The optimal makespan of small instances, by branch and bound: the reference that the
//! policies' guarantees are tested against.

use crate::{Costs, Policy, Speeds};

/// The least makespan of any assignment of `costs` to devices of `speeds`.
///
/// Exponential in the number of tasks: meant for checking policies on instances of up to
/// about 12 tasks and 4 devices, where it answers in milliseconds. Devices of equal speed and
/// equal load are interchangeable, so only the first of them is tried.
pub fn optimal_makespan(costs: &Costs, speeds: &Speeds) -> f64 {
    let mut order: Vec<f64> = costs.as_slice().to_vec();
    order.sort_by(|a, b| b.total_cmp(a));
    let upper = Policy::StaticLpt
        .plan(costs, speeds)
        .map_or(f64::INFINITY, |p| p.makespan(costs, speeds));
    let mut search = Search {
        costs: order,
        speeds: speeds.as_slice().to_vec(),
        finish: vec![0.0; speeds.len()],
        best: upper,
    };
    search.go(0, 0.0);
    search.best
}

struct Search {
    costs: Vec<f64>,
    speeds: Vec<f64>,
    finish: Vec<f64>,
    best: f64,
}

impl Search {
    fn go(&mut self, next: usize, makespan: f64) {
        if next == self.costs.len() {
            self.best = self.best.min(makespan);
            return;
        }
        let c = self.costs[next];
        for d in 0..self.finish.len() {
            let twin = (0..d)
                .any(|e| self.speeds[e] == self.speeds[d] && self.finish[e] == self.finish[d]);
            if twin {
                continue;
            }
            let before = self.finish[d];
            let after = before + c / self.speeds[d];
            if after >= self.best {
                continue;
            }
            self.finish[d] = after;
            self.go(next + 1, makespan.max(after));
            self.finish[d] = before;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_perfect_partition_lpt_misses() {
        let costs = Costs::new(vec![3.0, 3.0, 2.0, 2.0, 2.0]).unwrap();
        assert_eq!(
            optimal_makespan(&costs, &Speeds::identical(2).unwrap()),
            6.0
        );
    }

    #[test]
    fn uses_speeds() {
        let costs = Costs::new(vec![4.0, 2.0]).unwrap();
        assert_eq!(
            optimal_makespan(&costs, &Speeds::new(vec![2.0, 1.0]).unwrap()),
            2.0
        );
        assert_eq!(
            optimal_makespan(&Costs::default(), &Speeds::identical(3).unwrap()),
            0.0
        );
    }
}
