use std::ops::Range;

use sched::{DeviceError, Executor};

use crate::{Pair, World, broad, narrow};

/// One CPU device: for each body of a task (a range of the Morton-sorted bodies), the broad
/// phase through the BVHs, then parry3d's contact on each candidate. Returns the contacts.
#[derive(Debug, Clone, Copy)]
pub struct Device<'a> {
    world: &'a World,
    id: usize,
}

impl<'a> Device<'a> {
    /// Device number `id` (for reports) over a shared world.
    pub fn new(world: &'a World, id: usize) -> Self {
        Device { world, id }
    }

    /// `devices` identical devices.
    pub fn many(world: &'a World, devices: usize) -> Vec<Self> {
        (0..devices).map(|d| Device::new(world, d)).collect()
    }
}

impl Executor<Range<usize>> for Device<'_> {
    type Output = Vec<Pair>;

    fn run(&mut self, task: &Range<usize>) -> Result<Vec<Pair>, DeviceError> {
        if task.end > self.world.len() {
            return Err(DeviceError::msg(format!(
                "task {task:?} is outside the world"
            )));
        }
        let unsupported = |i: usize| DeviceError::msg(format!("no contact algorithm for body {i}"));
        let mut pairs = Vec::new();
        let mut candidates = Vec::new();
        for i in task.clone() {
            candidates.clear();
            broad::body_candidates(self.world, i, &mut candidates);
            for &j in &candidates {
                if narrow::bodies_touch(self.world, i, j as usize).ok_or_else(|| unsupported(i))? {
                    pairs.push(Pair::Bodies(i as u32, j));
                }
            }
            candidates.clear();
            broad::mesh_candidates(self.world, i, &mut candidates);
            for &t in &candidates {
                if narrow::touches_triangle(self.world, i, t).ok_or_else(|| unsupported(i))? {
                    pairs.push(Pair::Mesh {
                        body: i as u32,
                        triangle: t,
                    });
                }
            }
        }
        Ok(pairs)
    }

    /// Pairs are tested on the runtime's device thread itself: a launch costs nothing.
    fn launch_overhead(&self) -> Option<f64> {
        Some(0.0)
    }

    fn name(&self) -> String {
        format!("cpu{} (parry3d)", self.id)
    }
}
