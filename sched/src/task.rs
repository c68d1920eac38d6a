use std::ops::Range;

/// One unit of scheduling: what an executor needs to run it.
///
/// A task is identified by its index in the workload slice given to a policy, the runtime or
/// the simulator; timelines and assignments use that index. The only thing the scheduler asks
/// of a task is how many work items (rays, queries) it holds, to report throughput.
pub trait Task: Sync {
    /// Number of work items (rays, queries, pairs) in this task.
    fn items(&self) -> usize;
}

/// A range of a buffer (of rays, queries…) is the most common task.
impl Task for Range<usize> {
    fn items(&self) -> usize {
        self.len()
    }
}

impl<T: Task + ?Sized> Task for &T {
    fn items(&self) -> usize {
        (**self).items()
    }
}

/// Splits `0..len` into consecutive ranges of at most `size` items: the fixed-size tasks of
/// the thesis (a generation of rays cut into tasks of 16384, 4096 or 512 rays).
///
/// # Panics
/// Panics if `size` is zero.
pub fn split_ranges(len: usize, size: usize) -> Vec<Range<usize>> {
    assert!(size > 0, "task size must be positive");
    (0..len.div_ceil(size))
        .map(|i| i * size..((i + 1) * size).min(len))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_covers_everything_once() {
        assert_eq!(split_ranges(10, 4), vec![0..4, 4..8, 8..10]);
        assert!(split_ranges(0, 4).is_empty());
        let total: usize = split_ranges(100_003, 512).iter().map(Task::items).sum();
        assert_eq!(total, 100_003);
    }
}
