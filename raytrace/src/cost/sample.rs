//! Uniform task sampling and compaction (thesis, figure 3.1 b and section 3.3): every task
//! keeps rays at a fixed stride, and the kept rays of all tasks are gathered into one
//! contiguous batch, so the reduced trace streams through memory and its parallel loop sees
//! one flat array instead of many short strided ones.

use std::ops::Range;

use super::CostError;
use crate::RayBatch;

/// The fraction of each task's rays that is traced, in `(0, 1]`.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct SampleRate(f64);

impl SampleRate {
    /// Every ray: the estimate equals the full reduced traversal.
    pub const FULL: Self = Self(1.0);
    /// 12.5 %, the thesis's chosen trade-off between overhead and accuracy (Table 4.1).
    pub const THESIS: Self = Self(0.125);

    /// Checks the rate: finite and in `(0, 1]`.
    pub fn new(rate: f64) -> Result<Self, CostError> {
        if rate.is_finite() && rate > 0.0 && rate <= 1.0 {
            Ok(Self(rate))
        } else {
            Err(CostError::BadRate { value: rate })
        }
    }

    /// The rate as a fraction.
    pub fn get(self) -> f64 {
        self.0
    }

    /// How many of `len` rays are kept: `ceil(len · rate)`, at least one for a non-empty task.
    /// The tiny epsilon keeps `4096 · 0.125` at 512 despite rounding in the rate.
    pub fn samples(self, len: usize) -> usize {
        if len == 0 {
            return 0;
        }
        ((len as f64 * self.0 - 1e-9).ceil() as usize).clamp(1, len)
    }
}

/// Index (within a task of `len` rays) of sample `j` of `k`: the middle of the `j`-th of `k`
/// equal strata. With `k == len` it is `j`, so rate 1 keeps every ray exactly once.
#[inline]
fn stride_index(j: usize, k: usize, len: usize) -> usize {
    // (2j + 1)·len / (2k) in integers: never rounds past the stratum, never overflows for
    // batches below 2^62 rays.
    ((2 * j + 1) * len) / (2 * k)
}

/// The sampled rays of all tasks, compacted into one contiguous list of ray indices: task
/// `t`'s samples are `index[offsets[t]..offsets[t + 1]]`, and together they stand for the
/// task's `lens[t]` rays. The CPU's reduced traversal reads the sampled rays in place through
/// the list; [`Compacted::rays`] copies them out for a device that wants them contiguous.
#[derive(Clone, Debug, Default)]
pub struct Compacted {
    /// Index in the batch of every sampled ray, task after task.
    pub index: Vec<usize>,
    /// Task `t`'s samples start at `offsets[t]`; one more entry than there are tasks.
    pub offsets: Vec<usize>,
    /// Rays in each task.
    pub lens: Vec<usize>,
}

impl Compacted {
    /// Samples every task of `rays` at `rate` and gathers the samples.
    ///
    /// Checks before reading: every task must be non-empty and inside the batch, and the
    /// batch's columns must agree in length.
    pub fn gather(
        rays: &RayBatch,
        tasks: &[Range<usize>],
        rate: SampleRate,
    ) -> Result<Self, CostError> {
        check_tasks(rays, tasks)?;
        let mut offsets = Vec::with_capacity(tasks.len() + 1);
        offsets.push(0);
        for (task, r) in tasks.iter().enumerate() {
            offsets.push(offsets[task] + rate.samples(r.len()));
        }
        let total = offsets[tasks.len()];
        let mut index = Vec::with_capacity(total);
        for r in tasks {
            let (len, k) = (r.len(), rate.samples(r.len()));
            index.extend((0..k).map(|j| r.start + stride_index(j, k, len)));
        }
        Ok(Self {
            index,
            offsets,
            lens: tasks.iter().map(|r| r.len()).collect(),
        })
    }

    /// Number of tasks.
    pub fn tasks(&self) -> usize {
        self.lens.len()
    }

    /// The sampled rays of `rays` (the batch this sample was taken of), copied out in order.
    ///
    /// # Panics
    /// Panics if `rays` is shorter than the batch sampled.
    pub fn rays(&self, rays: &RayBatch) -> RayBatch {
        gather_columns(rays, &self.index)
    }
}

/// `rays[index[i]]` for every `i`, column by column: each pass reads one source column and
/// writes one destination column, which is what the hardware prefetchers like best. The eight
/// columns are gathered in parallel (this copy is part of the estimation overhead).
fn gather_columns(rays: &RayBatch, index: &[usize]) -> RayBatch {
    use rayon::prelude::*;
    let src = [
        &rays.ox, &rays.oy, &rays.oz, &rays.dx, &rays.dy, &rays.dz, &rays.tmin, &rays.tmax,
    ];
    let mut cols: Vec<Vec<f32>> = src
        .par_iter()
        .map(|c| index.iter().map(|&i| c[i]).collect())
        .collect();
    let mut next = || cols.remove(0);
    RayBatch {
        ox: next(),
        oy: next(),
        oz: next(),
        dx: next(),
        dy: next(),
        dz: next(),
        tmin: next(),
        tmax: next(),
    }
}

/// Every task non-empty and inside a consistent batch: checked before any ray is read.
pub(crate) fn check_tasks(rays: &RayBatch, tasks: &[Range<usize>]) -> Result<(), CostError> {
    if !rays.is_consistent() {
        return Err(CostError::InconsistentBatch);
    }
    for (task, r) in tasks.iter().enumerate() {
        if r.end > rays.len() || r.start > r.end {
            return Err(CostError::TaskOutOfRange {
                task,
                start: r.start,
                end: r.end,
                rays: rays.len(),
            });
        }
        if r.is_empty() {
            return Err(CostError::EmptyTask { task });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Ray;
    use glam::Vec3;

    fn batch(n: usize) -> RayBatch {
        (0..n)
            .map(|i| Ray::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::X))
            .collect()
    }

    #[test]
    fn rates_outside_zero_one_are_rejected_by_value() {
        for bad in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
            let err = SampleRate::new(bad).unwrap_err();
            assert!(err.to_string().contains("sample rate"), "{err}");
        }
        assert_eq!(SampleRate::new(0.125).unwrap(), SampleRate::THESIS);
    }

    #[test]
    fn every_task_keeps_at_least_one_ray_even_at_tiny_rates() {
        let rate = SampleRate::new(1e-9).unwrap();
        let c = Compacted::gather(&batch(1000), &sched::split_ranges(1000, 7), rate).unwrap();
        assert_eq!(c.tasks(), 143);
        assert!(c.offsets.windows(2).all(|w| w[1] - w[0] == 1));
        assert_eq!(c.rays(&batch(1000)).len(), 143);
        // The single sample of a 7-ray task is its middle ray, standing for all seven.
        assert_eq!(c.rays(&batch(1000)).ox[0], 3.0);
        assert_eq!((c.lens[0], c.lens[142]), (7, 6)); // the last task has 1000 - 142·7 rays
    }

    #[test]
    fn samples_are_a_uniform_stride_and_rate_one_keeps_everything() {
        let rays = batch(64);
        let c = Compacted::gather(&rays, &[0..32, 32..64], SampleRate::THESIS).unwrap();
        assert_eq!(
            c.rays(&rays).ox,
            vec![4.0, 12.0, 20.0, 28.0, 36.0, 44.0, 52.0, 60.0]
        );
        assert_eq!(c.offsets, vec![0, 4, 8]);
        let all = Compacted::gather(&rays, &[0..40, 40..64], SampleRate::FULL).unwrap();
        assert_eq!(all.rays(&rays), rays);
        assert_eq!(all.offsets, vec![0, 40, 64]);
        assert_eq!(SampleRate::THESIS.samples(4096), 512);
        assert_eq!(SampleRate::THESIS.samples(513), 65);
    }

    #[test]
    fn empty_and_out_of_range_tasks_are_errors_naming_the_task() {
        let rays = batch(10);
        let empty = Compacted::gather(&rays, &[0..5, 5..5], SampleRate::FULL).unwrap_err();
        assert_eq!(empty, CostError::EmptyTask { task: 1 });
        let out = Compacted::gather(&rays, &[0..5, 5..11], SampleRate::FULL).unwrap_err();
        assert!(matches!(
            out,
            CostError::TaskOutOfRange {
                task: 1,
                end: 11,
                rays: 10,
                ..
            }
        ));
        let mut broken = rays.clone();
        broken.tmax.pop();
        let err = Compacted::gather(&broken, &[0..5, 5..9], SampleRate::FULL).unwrap_err();
        assert_eq!(err, CostError::InconsistentBatch);
    }
}
