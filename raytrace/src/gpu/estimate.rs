//! The thesis's estimator on the GPU (issue 5): sample every task at a stride (pairs of
//! neighbouring rays, as [`crate::cost::SAMPLE_RUN`] says), compact the
//! samples into one contiguous ray buffer, trace them by the reduced traversal and sum `B` and
//! `T` per task, all on the device; only one pair of sums per task comes back.
//!
//! It picks exactly the rays [`crate::cost::Compacted::gather`] picks (same `k` per task, same
//! sample indices in integers) and sums their counts exactly (64-bit integers), so its
//! [`Work`] is bit for bit the CPU's [`crate::cost::ReducedTraversal::try_work`].
//!
//! The sample indices (products up to `len²`) are computed in u32 (WGSL has no 64-bit integers), so
//! a task may hold at most [`MAX_TASK_RAYS`] rays; longer ones are refused with
//! [`GpuError::TaskTooLong`] rather than sampled wrongly.

use std::ops::Range;

use super::buffers::{
    GpuRay, SceneBuffers, check_size, fetch, init, pack_rays, rays_per_launch, storage,
};
use super::pipeline::{GpuMode, Kernels, Threads, grid, trace_resident};
use super::program::{Program, READ, UNIFORM, WRITE, dispatch};
use super::{GpuContext, GpuDevice, GpuError};
use crate::cost::{CostError, CostModel, SampleRate, Work, check_tasks};
use crate::{Probe, RayBatch};

/// The longest task the GPU estimator samples: `len² < 2^32`, so the sample indices' products
/// fit u32.
pub const MAX_TASK_RAYS: usize = 46_340;

/// A task's sampled sums as the GPU computed them: exact integer sums of the reduced-traversal
/// counts of its `sampled` rays, standing for its `len` rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampledCounts {
    /// `B` summed over the samples.
    pub nodes: u64,
    /// `T` summed over the samples.
    pub tris: u64,
    /// Rays sampled.
    pub sampled: usize,
    /// Rays in the task.
    pub len: usize,
}

impl SampledCounts {
    /// The task's estimated work: the sums scaled by `len / sampled`, as the CPU scales them.
    pub fn work(&self) -> Work {
        Work {
            nodes: self.nodes as f64,
            tris: self.tris as f64,
        }
        .scaled(self.len, self.sampled)
    }
}

/// The compiled `gather` and `sum` kernels of `estimate.wgsl`.
#[derive(Debug)]
pub(crate) struct EstimateKernels {
    program: Program,
    gather: wgpu::ComputePipeline,
    sum: wgpu::ComputePipeline,
}

impl EstimateKernels {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        // The run length is the CPU sampler's, so the two cannot drift apart.
        let source = include_str!("estimate.wgsl").replace(
            "const RUN: u32 = 2u;",
            &format!("const RUN: u32 = {}u;", crate::cost::SAMPLE_RUN),
        );
        let program = Program::new(
            device,
            "estimate",
            source,
            &[READ, READ, WRITE, READ, WRITE, UNIFORM],
        );
        Self {
            gather: program.pipeline(device, "gather", "cobalt sample gather pipeline"),
            sum: program.pipeline(device, "sum", "cobalt sample sums pipeline"),
            program,
        }
    }
}

/// What the estimator traces: each task's sample at `rate`, by `probe`'s reduced traversal.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sampling {
    pub rate: SampleRate,
    pub probe: Probe,
}

/// Sampled sums of every task of `rays` (see the module docs).
///
/// # Errors
/// [`GpuError::BadTasks`] for an empty task, one beyond the batch or an inconsistent batch
/// (checked before anything is uploaded), [`GpuError::TaskTooLong`] beyond
/// [`MAX_TASK_RAYS`], and the errors of a launch.
pub(crate) fn sampled_counts(
    ctx: &GpuContext,
    kernels: &Kernels,
    estimate: &EstimateKernels,
    scene: &SceneBuffers,
    rays: &RayBatch,
    tasks: &[Range<usize>],
    sampling: Sampling,
) -> Result<Vec<SampledCounts>, GpuError> {
    check_tasks(rays, tasks).map_err(|e: CostError| GpuError::BadTasks { why: e.to_string() })?;
    if let Some((task, r)) = tasks
        .iter()
        .enumerate()
        .find(|(_, r)| r.len() > MAX_TASK_RAYS)
    {
        return Err(GpuError::TaskTooLong {
            task,
            len: r.len(),
            max: MAX_TASK_RAYS,
        });
    }
    let mut out = Vec::with_capacity(tasks.len());
    // Consecutive tasks whose rays fit one binding go together; one task always fits, since
    // a binding holds far more than `MAX_TASK_RAYS` rays.
    let limit = rays_per_launch(&ctx.limits).max(MAX_TASK_RAYS);
    let mut first = 0;
    while first < tasks.len() {
        let mut end = first;
        let mut held = 0;
        while end < tasks.len() && (end == first || held + tasks[end].len() <= limit) {
            held += tasks[end].len();
            end += 1;
        }
        out.extend(group(
            ctx,
            kernels,
            estimate,
            scene,
            rays,
            &tasks[first..end],
            sampling,
        )?);
        first = end;
    }
    Ok(out)
}

/// [`sampled_counts`] for tasks whose rays fit one ray buffer.
fn group(
    ctx: &GpuContext,
    kernels: &Kernels,
    estimate: &EstimateKernels,
    scene: &SceneBuffers,
    rays: &RayBatch,
    tasks: &[Range<usize>],
    sampling: Sampling,
) -> Result<Vec<SampledCounts>, GpuError> {
    // The task table: where each task's rays sit in the packed upload, how many samples it
    // keeps (the CPU's own rounding), and where they go (the prefix sum of the samples).
    let mut table: Vec<[u32; 4]> = Vec::with_capacity(tasks.len());
    let (mut start, mut offset) = (0usize, 0usize);
    for r in tasks {
        let k = sampling.rate.samples(r.len());
        // Every value is below the binding limit's ray count, far below 2^32.
        let word = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
        table.push([word(start), word(r.len()), word(k), word(offset)]);
        start += r.len();
        offset += k;
    }
    let samples = offset;
    let result = |sums: &[[u32; 4]]| -> Vec<SampledCounts> {
        tasks
            .iter()
            .zip(&table)
            .zip(sums)
            .map(|((r, row), s)| SampledCounts {
                nodes: u64::from(s[0]) | (u64::from(s[1]) << 32),
                tris: u64::from(s[2]) | (u64::from(s[3]) << 32),
                sampled: row[2] as usize,
                len: r.len(),
            })
            .collect()
    };
    if scene.empty {
        // No triangle: every ray misses the root, and every count is 0.
        return Ok(result(&vec![[0; 4]; tasks.len()]));
    }
    let device = &ctx.device;
    let ranges: Vec<&Range<usize>> = tasks.iter().collect();
    let packed = pack_rays(rays, &ranges);
    check_size(
        ctx,
        "rays of the estimated tasks",
        (packed.len() * size_of::<GpuRay>()) as u64,
    )?;
    check_size(ctx, "sampled rays", (samples * size_of::<GpuRay>()) as u64)?;
    let n_tasks = u32::try_from(tasks.len()).unwrap_or(u32::MAX);
    let n_samples = u32::try_from(samples).unwrap_or(u32::MAX);
    let table_buf = init(
        device,
        "cobalt estimate tasks",
        bytemuck::cast_slice(&table),
        wgpu::BufferUsages::STORAGE,
    );
    let ray_buf = init(
        device,
        "cobalt estimate rays",
        bytemuck::cast_slice(&packed),
        wgpu::BufferUsages::STORAGE,
    );
    let params = init(
        device,
        "cobalt estimate parameters",
        bytemuck::cast_slice(&[n_tasks, 0, 0, 0]),
        wgpu::BufferUsages::UNIFORM,
    );
    let ray_bytes = size_of::<GpuRay>() as u64;
    let sampled = storage(
        device,
        "cobalt sampled rays",
        u64::from(n_samples) * ray_bytes,
        wgpu::BufferUsages::empty(),
    );
    let counts = storage(
        device,
        "cobalt sampled counts",
        u64::from(n_samples) * 8,
        wgpu::BufferUsages::empty(),
    );
    let sums_bytes = u64::from(n_tasks) * 16;
    let sums = storage(
        device,
        "cobalt task sums",
        sums_bytes,
        wgpu::BufferUsages::COPY_SRC,
    );
    let bind = estimate.program.bind(
        device,
        "cobalt estimate bind group",
        &[&table_buf, &ray_buf, &sampled, &counts, &sums, &params],
    );
    let grid = grid(&ctx.limits, n_tasks);
    let pass = |pipeline: &wgpu::ComputePipeline, label: &str| {
        dispatch(device, label, pipeline, &bind, grid).finish()
    };
    ctx.queue
        .submit([pass(&estimate.gather, "cobalt sample gather")]);
    trace_resident(
        ctx,
        kernels,
        scene,
        &sampled,
        &counts,
        n_samples,
        GpuMode::counts(sampling.probe),
        Threads::Persistent,
    )?;
    ctx.queue
        .submit([pass(&estimate.sum, "cobalt sample sums")]);
    let bytes = fetch(ctx, &sums, sums_bytes)?;
    Ok(result(&bytemuck::pod_collect_to_vec::<u8, [u32; 4]>(
        &bytes,
    )))
}

/// The reduced-traversal estimator of [`crate::cost::ReducedTraversal`], run on a GPU: the
/// same sample, the same sums, the same costs.
///
/// As a [`sched::CostEstimator`] it cannot return an error: when the GPU fails or a task is
/// bad, every cost is NaN, which [`sched::CostEstimator::estimate_timed`] rejects;
/// [`GpuReducedTraversal::try_work`] says why.
#[derive(Clone, Copy, Debug)]
pub struct GpuReducedTraversal<'a> {
    device: &'a GpuDevice,
    rays: &'a RayBatch,
    rate: SampleRate,
    model: CostModel,
    probe: Probe,
}

impl<'a> GpuReducedTraversal<'a> {
    /// An estimator of tasks of `rays` on `device`, sampling at `rate`, with the default
    /// [`CostModel`].
    pub fn new(device: &'a GpuDevice, rays: &'a RayBatch, rate: SampleRate) -> Self {
        Self {
            device,
            rays,
            rate,
            model: CostModel::default(),
            probe: Probe::Thesis,
        }
    }

    /// The same estimator weighing `B` and `T` by a calibrated model.
    pub fn with_model(self, model: CostModel) -> Self {
        Self { model, ..self }
    }

    /// The same estimator tracing its sample with another reduced traversal.
    pub fn with_probe(self, probe: Probe) -> Self {
        Self { probe, ..self }
    }

    /// Estimated `B` and `T` of every task (equal to the CPU's).
    ///
    /// # Errors
    /// As [`GpuDevice::sampled_counts`].
    pub fn try_work(&self, tasks: &[Range<usize>]) -> Result<Vec<Work>, GpuError> {
        Ok(self
            .device
            .sampled_counts(self.rays, tasks, self.rate, self.probe)?
            .iter()
            .map(SampledCounts::work)
            .collect())
    }

    /// Estimated cost of every task.
    ///
    /// # Errors
    /// As [`GpuDevice::sampled_counts`].
    pub fn try_estimate(&self, tasks: &[Range<usize>]) -> Result<Vec<f64>, GpuError> {
        Ok(self.model.costs(&self.try_work(tasks)?))
    }
}

impl sched::CostEstimator<Range<usize>> for GpuReducedTraversal<'_> {
    fn estimate(&self, tasks: &[Range<usize>]) -> Vec<f64> {
        self.try_estimate(tasks)
            .unwrap_or_else(|_| vec![f64::NAN; tasks.len()])
    }
}
