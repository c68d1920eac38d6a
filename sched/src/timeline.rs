/// One task run on one device, in seconds from the start of the run.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Span {
    /// The device that ran it.
    pub device: u32,
    /// The task's index in the workload.
    pub task: u32,
    /// When it started.
    pub start: f64,
    /// When its output was delivered.
    pub end: f64,
    /// The task's time as the device itself measured it (a GPU's timestamp queries, for a
    /// launch of its own), where the executor reported one ([`crate::Sink::push_timed`]):
    /// the share of the span spent computing rather than transferring and launching.
    pub device_seconds: Option<f64>,
}

/// What happened during a run (real or simulated): every task run that delivered an output.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Timeline {
    /// Number of devices, including those that ran nothing.
    pub devices: usize,
    /// The spans, in delivery order.
    pub spans: Vec<Span>,
}

/// Balance metrics, with the thesis's definitions.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Metrics {
    /// Time from the start until the last output.
    pub makespan: f64,
    /// Per device: time spent running tasks.
    pub busy: Vec<f64>,
    /// Per device: `makespan − busy`.
    pub idle: Vec<f64>,
    /// Σ busy / (makespan × devices); 1 when every device works until the end.
    pub balance_efficiency: f64,
}

impl Metrics {
    /// Metrics from per-device busy times and the makespan.
    pub fn new(makespan: f64, busy: Vec<f64>) -> Self {
        let idle = busy.iter().map(|b| (makespan - b).max(0.0)).collect();
        // Each share of the makespan first: their sum, or the makespan times the device count,
        // overflows for costs near `f64::MAX`.
        let balance_efficiency = if makespan > 0.0 {
            busy.iter().map(|b| b / makespan).sum::<f64>() / busy.len() as f64
        } else {
            1.0
        };
        Metrics {
            makespan,
            busy,
            idle,
            balance_efficiency,
        }
    }
}

impl Timeline {
    /// Makespan, busy and idle time per device, and balance efficiency.
    pub fn metrics(&self) -> Metrics {
        let mut busy = vec![0.0; self.devices];
        let mut makespan: f64 = 0.0;
        for s in &self.spans {
            busy[s.device as usize] += s.end - s.start;
            makespan = makespan.max(s.end);
        }
        Metrics::new(makespan, busy)
    }

    /// The device that delivered each task's output, in task order (`u32::MAX` if none).
    pub fn assignment(&self, tasks: usize) -> Vec<u32> {
        let mut out = vec![u32::MAX; tasks];
        for s in &self.spans {
            out[s.task as usize] = s.device;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balance_is_busy_over_capacity() {
        let t = Timeline {
            devices: 2,
            spans: vec![
                Span {
                    device: 0,
                    task: 0,
                    start: 0.0,
                    end: 4.0,
                    device_seconds: None,
                },
                Span {
                    device: 1,
                    task: 1,
                    start: 0.0,
                    end: 2.0,
                    device_seconds: Some(1.5),
                },
            ],
        };
        let m = t.metrics();
        assert_eq!(m.makespan, 4.0);
        assert_eq!(m.idle, vec![0.0, 2.0]);
        assert_eq!(m.balance_efficiency, 0.75);
        assert_eq!(t.assignment(3), vec![0, 1, u32::MAX]);
    }
}
