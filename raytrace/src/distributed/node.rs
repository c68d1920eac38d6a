//! Rank 0's own node as one device of the plan over nodes, and how a node finds the
//! estimated work of the tasks it is sent.

use std::ops::Range;

use sched::{DeviceError, Executor, Sink};

use crate::cost::Work;
use crate::scheduled::ScheduledTracer;
use crate::{HitBatch, RayBatch, RayKind};

/// The work of `batch`'s tasks, found by position: tasks are the fixed-size ranges of
/// `split_ranges`, so a range is task `start / task_size`. A range that is not one of
/// `tasks` is refused, naming it.
pub(super) fn batch_work(
    batch: &[Range<usize>],
    tasks: &[Range<usize>],
    work: Option<&[Work]>,
    task_size: usize,
) -> Result<Option<Vec<Work>>, DeviceError> {
    let mut part = Vec::with_capacity(batch.len());
    for range in batch {
        let i = range.start / task_size;
        if tasks.get(i) != Some(range) {
            return Err(DeviceError::msg(format!(
                "task {range:?} is not one of this generation's {} tasks",
                tasks.len()
            )));
        }
        if let Some(w) = work {
            part.push(w[i]);
        }
    }
    Ok(work.map(|_| part))
}

/// Rank 0's own node as a device of the plan over nodes: its batches run on its devices with
/// the local policy.
pub(super) struct LocalNode<'t, 'a, 'r> {
    pub tracer: &'t mut ScheduledTracer<'a>,
    pub kind: RayKind,
    pub rays: &'r RayBatch,
    pub tasks: &'r [Range<usize>],
    pub work: Option<&'r [Work]>,
    pub task_size: usize,
    pub speed: f64,
}

impl Executor<Range<usize>> for LocalNode<'_, '_, '_> {
    type Output = HitBatch;

    fn run(&mut self, task: &Range<usize>) -> Result<HitBatch, DeviceError> {
        let batch = [task.clone()];
        let part = batch_work(&batch, self.tasks, self.work, self.task_size)?;
        self.tracer
            .trace_tasks(self.kind, self.rays, &batch, part.as_deref())
            .pop()
            .ok_or_else(|| DeviceError::msg(format!("rank0: no hits for task {task:?}")))
    }

    fn run_batch(
        &mut self,
        tasks: &[&Range<usize>],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        let batch: Vec<Range<usize>> = tasks.iter().map(|&t| t.clone()).collect();
        let part = batch_work(&batch, self.tasks, self.work, self.task_size)?;
        for hits in self
            .tracer
            .trace_tasks(self.kind, self.rays, &batch, part.as_deref())
        {
            sink.push(hits);
        }
        Ok(())
    }

    fn speed(&self) -> f64 {
        self.speed
    }

    fn name(&self) -> String {
        String::from("rank0")
    }
}
