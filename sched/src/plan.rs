use crate::{Costs, Load, Speeds};

/// A static assignment: for each device, the tasks it runs, in the order the planner assigned
/// them (LPT: largest first). `StaticDispatch` launches each list in task order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Plan {
    devices: Vec<Vec<u32>>,
}

impl Plan {
    /// A plan from per-device task lists.
    pub fn from_lists(devices: Vec<Vec<u32>>) -> Self {
        Plan { devices }
    }

    /// The tasks of `device`, in the order the planner assigned them.
    pub fn tasks(&self, device: usize) -> &[u32] {
        &self.devices[device]
    }

    /// Number of devices the plan covers.
    pub fn devices(&self) -> usize {
        self.devices.len()
    }

    /// The device of each task, in task order; `u32::MAX` for a task the plan leaves out.
    pub fn assignment(&self, tasks: usize) -> Vec<u32> {
        let mut out = vec![u32::MAX; tasks];
        for (d, list) in self.devices.iter().enumerate() {
            for &t in list {
                out[t as usize] = d as u32;
            }
        }
        out
    }

    /// The latest finish time, each device's `Σ cost / speed` summed exactly: the plan's
    /// makespan with exact costs and no dispatch latency.
    pub fn makespan(&self, costs: &Costs, speeds: &Speeds) -> f64 {
        self.devices
            .iter()
            .enumerate()
            .map(|(d, list)| {
                list.iter()
                    .fold(Load::ZERO, |l, &t| l.plus(costs[t as usize] / speeds[d]))
                    .value()
            })
            .fold(0.0, f64::max)
    }
}
