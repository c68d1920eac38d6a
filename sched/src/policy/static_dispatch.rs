use crate::dispatch::Orphans;
use crate::{Costs, Dispatch, Plan};

/// Runs a static plan: each device's whole list in one launch, then (only if another device
/// failed) whatever it left behind, largest first, one task per launch.
///
/// A launch runs its list in task order, not in the order it was planned: a static plan's
/// makespan does not depend on the order, but the caches do. The caller's order is usually
/// memory order (cobalt's ray tasks are neighbouring pixels), and LPT's largest-first order
/// jumped across the image: on 512-ray AO tasks (forest, two CPU devices) the devices' busy
/// time fell by 12 % in task order (1.359 → 1.190 s, median of six renders each).
#[derive(Debug)]
pub struct StaticDispatch<'a> {
    plan: Plan,
    launched: Vec<bool>,
    orphans: Orphans,
    costs: &'a Costs,
}

impl<'a> StaticDispatch<'a> {
    /// Dispatches `plan`, whose task indices refer to `costs`.
    pub fn new(plan: Plan, costs: &'a Costs) -> Self {
        StaticDispatch {
            launched: vec![false; plan.devices()],
            plan,
            orphans: Orphans::default(),
            costs,
        }
    }
}

impl Dispatch for StaticDispatch<'_> {
    fn next(&mut self, device: usize, _now: f64, launch: &mut Vec<u32>) {
        if !self.launched[device] {
            self.launched[device] = true;
            if !self.plan.tasks(device).is_empty() {
                let start = launch.len();
                launch.extend_from_slice(self.plan.tasks(device));
                launch[start..].sort_unstable();
                return;
            }
        }
        launch.extend(self.orphans.pop());
    }

    fn fail(&mut self, device: usize, undone: &[u32]) {
        self.orphans.extend(self.costs, undone.iter().copied());
        if !self.launched[device] {
            self.launched[device] = true;
            self.orphans
                .extend(self.costs, self.plan.tasks(device).iter().copied());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Speeds;
    use crate::policy::plan_lpt;

    #[test]
    fn a_launch_runs_its_list_in_task_order() {
        let costs = Costs::new(vec![1.0, 5.0, 2.0, 4.0, 3.0, 6.0]).unwrap();
        let plan = plan_lpt(&costs, &Speeds::identical(2).unwrap());
        // Planned largest first: 5, 4, 2 on device 0 and 1, 3, 0 on device 1.
        assert_eq!(
            (plan.tasks(0), plan.tasks(1)),
            (&[5, 4, 2][..], &[1, 3, 0][..])
        );
        let mut d = StaticDispatch::new(plan, &costs);
        let mut launch = Vec::new();
        d.next(1, 0.0, &mut launch);
        assert_eq!(launch, vec![0, 1, 3]);
        launch.clear();
        d.next(0, 0.0, &mut launch);
        assert_eq!(launch, vec![2, 4, 5]);
    }
}
