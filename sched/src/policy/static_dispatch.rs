use crate::dispatch::Orphans;
use crate::{Costs, Dispatch, Plan};

/// Runs a static plan: each device's whole list in one launch, then (only if another device
/// failed) whatever it left behind, largest first, one task per launch.
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
                launch.extend_from_slice(self.plan.tasks(device));
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
