use std::ops::Range;

use sched::{DeviceError, Executor};

use crate::{KnnIndex, KnnQueries};

/// One CPU device: runs a task (a range of the Morton-sorted queries) on the calling thread
/// with kiddo's `nearest_n`, and returns `k` neighbour indices per query, in task order.
#[derive(Debug, Clone, Copy)]
pub struct Device<'a> {
    index: &'a KnnIndex,
    queries: &'a KnnQueries,
    id: usize,
    speed: f64,
}

impl<'a> Device<'a> {
    /// Device number `id` (for reports) over a shared index and query batch.
    pub fn new(index: &'a KnnIndex, queries: &'a KnnQueries, id: usize) -> Self {
        Device {
            index,
            queries,
            id,
            speed: 1.0,
        }
    }

    /// The same device with a relative speed for planning (measured, or 1).
    #[must_use]
    pub fn with_speed(mut self, speed: f64) -> Self {
        self.speed = speed;
        self
    }

    /// `devices` identical devices.
    pub fn many(index: &'a KnnIndex, queries: &'a KnnQueries, devices: usize) -> Vec<Self> {
        (0..devices)
            .map(|d| Device::new(index, queries, d))
            .collect()
    }
}

impl Executor<Range<usize>> for Device<'_> {
    type Output = Vec<u32>;

    fn run(&mut self, task: &Range<usize>) -> Result<Vec<u32>, DeviceError> {
        let points = self
            .queries
            .points
            .get(task.clone())
            .ok_or_else(|| DeviceError::msg(format!("task {task:?} is outside the batch")))?;
        let mut out = Vec::with_capacity(points.len() * self.queries.k.get());
        for q in points {
            self.index.nearest(q, self.queries.k, &mut out);
        }
        Ok(out)
    }

    fn speed(&self) -> f64 {
        self.speed
    }

    /// Queries run on the runtime's device thread itself: a launch costs nothing.
    fn launch_overhead(&self) -> Option<f64> {
        Some(0.0)
    }

    fn name(&self) -> String {
        format!("cpu{} (kiddo)", self.id)
    }
}
