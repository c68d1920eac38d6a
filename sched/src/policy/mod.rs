//! Scheduling policies. Each policy's design notes, with the bounds it carries, are on its type.

mod central_queue;
mod hybrid;
mod lpt;
mod static_dispatch;
mod static_equal;

use std::fmt;
use std::str::FromStr;

pub use central_queue::QueueDispatch;
pub use hybrid::HybridDispatch;
pub use lpt::plan_lpt;
pub use static_dispatch::StaticDispatch;
pub use static_equal::plan_equal;

use crate::{Costs, Dispatch, Homes, Plan, SchedError, Speeds, plan_lpt_homed};

/// How tasks are assigned to devices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum Policy {
    /// The thesis's regular static scheme: each device gets a contiguous share of the tasks,
    /// proportional to its speed, whatever they cost. One launch per device.
    StaticEqual,
    /// Longest processing time first: tasks in decreasing cost, each to the device where it
    /// would finish earliest. One launch per device. ≤ (4/3 − 1/(3m))·OPT on identical
    /// devices, ≤ (1 + √3/3)·OPT on devices of different speeds.
    StaticLpt,
    /// A central queue in task order; an idle device takes the next task. One launch per
    /// task. A list schedule: ≤ (2 − 1/m)·OPT.
    QueueFifo,
    /// A central queue in decreasing cost. One launch per task.
    QueueSorted,
    /// An LPT plan whose devices launch their lists one task at a time where launching is
    /// free, in halves where its cost is unknown, and all but a reserve first where it is
    /// known; an idle device steals the smallest unlaunched tasks of the one expected to
    /// finish last, but only as many as it can finish before that device would. Never worse
    /// than `StaticLpt` with exact costs and no latency, and robust to wrong estimates.
    Hybrid,
}

impl Policy {
    /// Every policy, in the order reports list them.
    pub const ALL: [Policy; 5] = [
        Policy::StaticEqual,
        Policy::StaticLpt,
        Policy::QueueFifo,
        Policy::QueueSorted,
        Policy::Hybrid,
    ];

    /// The policy's command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Policy::StaticEqual => "static-equal",
            Policy::StaticLpt => "static-lpt",
            Policy::QueueFifo => "queue-fifo",
            Policy::QueueSorted => "queue-sorted",
            Policy::Hybrid => "hybrid",
        }
    }

    /// The up-front plan of a static policy, or the starting plan of `Hybrid`; `None` for the
    /// queues, which decide at run time.
    pub fn plan(self, costs: &Costs, speeds: &Speeds) -> Option<Plan> {
        match self {
            Policy::StaticEqual => Some(plan_equal(costs.len(), speeds)),
            Policy::StaticLpt | Policy::Hybrid => Some(plan_lpt(costs, speeds)),
            Policy::QueueFifo | Policy::QueueSorted => None,
        }
    }

    /// The run-time state of this policy for one workload: the planning step. Launch
    /// overheads are unknown; see [`Policy::dispatcher_with_overheads`].
    pub fn dispatcher<'a>(self, costs: &'a Costs, speeds: &Speeds) -> Box<dyn Dispatch + 'a> {
        self.dispatcher_with_overheads(costs, speeds, &[])
    }

    /// [`Policy::dispatcher`] for devices whose launch overheads in seconds are known
    /// (`None`, or a missing entry, where not): `Hybrid` sizes its launches by them.
    pub fn dispatcher_with_overheads<'a>(
        self,
        costs: &'a Costs,
        speeds: &Speeds,
        overheads: &[Option<f64>],
    ) -> Box<dyn Dispatch + 'a> {
        match self {
            Policy::StaticEqual | Policy::StaticLpt => {
                let plan = self.plan(costs, speeds).unwrap_or_else(|| unreachable!());
                Box::new(StaticDispatch::new(plan, costs))
            }
            Policy::QueueFifo => Box::new(QueueDispatch::fifo(costs)),
            Policy::QueueSorted => Box::new(QueueDispatch::sorted(costs)),
            Policy::Hybrid => Box::new(HybridDispatch::with_overheads(costs, speeds, overheads)),
        }
    }

    /// [`Policy::dispatcher_with_overheads`] for tasks that have a home (see [`Homes`]):
    /// static LPT plans each task where it finishes earliest once its move is paid
    /// ([`plan_lpt_homed`]), Hybrid starts from that plan and steals only what the thief
    /// finishes, moves included, before the victim would, and the queues hand an idle device
    /// the first task at home there before any other. `StaticEqual` ignores homes as it
    /// ignores costs. Homes whose moves are all free change nothing: the dispatcher is
    /// [`Policy::dispatcher_with_overheads`]'s.
    ///
    /// # Errors
    /// [`SchedError::LengthMismatch`] when `homes` and `costs` differ in length, and
    /// [`SchedError::BadHome`] for a home beyond the last device.
    pub fn dispatcher_homed<'a>(
        self,
        costs: &'a Costs,
        speeds: &Speeds,
        overheads: &[Option<f64>],
        homes: &'a Homes,
    ) -> Result<Box<dyn Dispatch + 'a>, SchedError> {
        homes.check(costs.len(), speeds.len())?;
        if homes.is_free() {
            return Ok(self.dispatcher_with_overheads(costs, speeds, overheads));
        }
        Ok(match self {
            Policy::StaticEqual => self.dispatcher_with_overheads(costs, speeds, overheads),
            Policy::StaticLpt => Box::new(StaticDispatch::new(
                plan_lpt_homed(costs, speeds, homes)?,
                costs,
            )),
            Policy::QueueFifo => Box::new(
                QueueDispatch::in_order((0..costs.len() as u32).collect())
                    .preferring_home(homes, speeds.len()),
            ),
            Policy::QueueSorted => {
                Box::new(QueueDispatch::sorted(costs).preferring_home(homes, speeds.len()))
            }
            Policy::Hybrid => Box::new(HybridDispatch::homed(costs, speeds, overheads, homes)?),
        })
    }
}

impl fmt::Display for Policy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Policy {
    type Err = SchedError;

    /// Accepts the command-line names and short forms: `equal`, `lpt`, `fifo`, `sorted`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s.trim().to_ascii_lowercase().as_str() {
            "static-equal" | "equal" | "static" => Policy::StaticEqual,
            "static-lpt" | "lpt" => Policy::StaticLpt,
            "queue-fifo" | "fifo" | "queue" => Policy::QueueFifo,
            "queue-sorted" | "sorted" => Policy::QueueSorted,
            "hybrid" => Policy::Hybrid,
            _ => return Err(SchedError::UnknownPolicy(s.to_owned())),
        })
    }
}
