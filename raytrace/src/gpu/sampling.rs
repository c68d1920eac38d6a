//! The thesis's estimator on the GPU: every task sampled and its samples compacted
//! on the host ([`Compacted::gather`], the CPU estimator's own sample), only the samples
//! uploaded, traced there by the reduced traversal and their `B` and `T` summed per task;
//! one pair of sums per task comes back.
//!
//! The thesis samples and compacts on the GPU, where its rays already are. Ours are made on the
//! host, and uploading every ray of every task to keep an eighth of them made the estimate
//! cost most of the GPU's trace. Sampling first uploads an eighth of the bytes, and tasks of
//! any length can be sampled (the device's u32 sample arithmetic limited them to 46 340 rays).
//!
//! The samples are the CPU's and their counts are summed exactly (64-bit integers), so its
//! [`Work`] is bit for bit the CPU's [`crate::cost::ReducedTraversal::try_work`]. The
//! estimator built on it, [`crate::gpu::GpuReducedTraversal`], is `estimate.rs`.

use std::ops::Range;

use super::GpuError;
use super::buffers::{
    GpuRay, SceneBuffers, check_size, fetch, init, pack_at, rays_per_launch, storage,
};
use super::context::GpuContext;
use super::program::{Kernel, READ, UNIFORM, WRITE, dispatch};
use super::trace::{TraceKernels, TraceMode, grid, trace_resident};
use crate::cost::{Compacted, CostError, SampleRate, Work};
use crate::ray::RayBatch;
use crate::traffic::Traffic;
use crate::traverse::walk::Walk;

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
            rays: self.sampled as f64,
        }
        .scaled(self.len, self.sampled)
    }
}

/// The compiled `estimate.wgsl`: each task's sums of its samples' counts.
pub(crate) fn estimate_kernel(device: &wgpu::Device) -> Kernel {
    Kernel::new(
        device,
        "estimate",
        include_str!("estimate.wgsl"),
        &[READ, READ, WRITE, UNIFORM],
    )
}

/// What the estimator traces: each task's sample at `rate`, by `walk`'s reduced traversal.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sampling {
    pub rate: SampleRate,
    pub walk: Walk,
}

/// Sampled sums of every task of `rays` (see the module docs).
///
/// # Errors
/// [`GpuError::BadTasks`] for an empty task, one beyond the batch or an inconsistent batch
/// (checked before anything is uploaded), and the errors of a launch.
#[allow(clippy::too_many_arguments)] // the device's parts, the work, and what it moved
pub(crate) fn sampled_counts(
    ctx: &GpuContext,
    kernels: &TraceKernels,
    estimate: &Kernel,
    scene: &SceneBuffers,
    rays: &RayBatch,
    tasks: &[Range<usize>],
    sampling: Sampling,
    traffic: &mut Traffic,
) -> Result<Vec<SampledCounts>, GpuError> {
    // Before the sample is gathered: a walk the GPU cannot run is refused at once.
    let mode = TraceMode::counts(sampling.walk)?;
    let sample = Compacted::gather(rays, tasks, sampling.rate)
        .map_err(|e: CostError| GpuError::BadTasks { why: e.to_string() })?;
    let mut out = Vec::with_capacity(tasks.len());
    // Consecutive tasks whose samples fit one binding go together (a task's sample alone
    // may not: then `check_size` names the limit).
    let limit = rays_per_launch(&ctx.limits);
    let mut first = 0;
    while first < tasks.len() {
        let mut end = first + 1;
        while end < tasks.len() && sample.offsets[end + 1] - sample.offsets[first] <= limit {
            end += 1;
        }
        out.extend(group(
            ctx,
            kernels,
            estimate,
            scene,
            rays,
            &sample,
            first..end,
            mode,
            traffic,
        )?);
        first = end;
    }
    Ok(out)
}

/// [`sampled_counts`] for tasks `group` of `sample`, whose samples fit one ray buffer.
#[allow(clippy::too_many_arguments)] // the device's parts, passed in as the other kernels are
fn group(
    ctx: &GpuContext,
    kernels: &TraceKernels,
    estimate: &Kernel,
    scene: &SceneBuffers,
    rays: &RayBatch,
    sample: &Compacted,
    group: Range<usize>,
    mode: TraceMode,
    traffic: &mut Traffic,
) -> Result<Vec<SampledCounts>, GpuError> {
    let base = sample.offsets[group.start];
    let index = &sample.index[base..sample.offsets[group.end]];
    // The task table: each task's sample count and where its counts start.
    let word = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
    let table: Vec<[u32; 2]> = group
        .clone()
        .map(|t| {
            let (a, b) = (sample.offsets[t], sample.offsets[t + 1]);
            [word(b - a), word(a - base)]
        })
        .collect();
    let result = |sums: &[[u32; 4]]| -> Vec<SampledCounts> {
        group
            .clone()
            .zip(&table)
            .zip(sums)
            .map(|((t, row), s)| SampledCounts {
                nodes: u64::from(s[0]) | (u64::from(s[1]) << 32),
                tris: u64::from(s[2]) | (u64::from(s[3]) << 32),
                sampled: row[0] as usize,
                len: sample.lens[t],
            })
            .collect()
    };
    if scene.empty {
        // No triangle: every ray misses the root, and every count is 0.
        return Ok(result(&vec![[0; 4]; group.len()]));
    }
    let device = &ctx.device;
    // Refused before the host packs them.
    check_size(
        ctx,
        "sampled rays",
        (index.len() * size_of::<GpuRay>()) as u64,
    )?;
    let packed = pack_at(rays, index);
    let n_tasks = word(group.len());
    let n_samples = word(index.len());
    let table_buf = init(
        device,
        "cobalt estimate tasks",
        bytemuck::cast_slice(&table),
        wgpu::BufferUsages::STORAGE,
    );
    let sampled = init(
        device,
        "cobalt sampled rays",
        bytemuck::cast_slice(&packed),
        wgpu::BufferUsages::STORAGE,
    );
    let params = init(
        device,
        "cobalt estimate parameters",
        bytemuck::cast_slice(&[n_tasks, 0, 0, 0]),
        wgpu::BufferUsages::UNIFORM,
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
    trace_resident(
        ctx, kernels, scene, &sampled, &counts, n_samples, mode, traffic,
    )?;
    let bind = estimate.program.bind(
        device,
        "cobalt estimate bind group",
        &[&table_buf, &counts, &sums, &params],
    );
    let sum = dispatch(
        device,
        "cobalt sample sums",
        &estimate.pipeline,
        &bind,
        grid(&ctx.limits, n_tasks),
    );
    ctx.queue.submit([sum.finish()]);
    let bytes = fetch(ctx, &sums, sums_bytes)?;
    traffic.host_to_device_bytes +=
        (table.len() * 8 + packed.len() * size_of::<GpuRay>()) as u64 + 16;
    traffic.device_to_host_bytes += sums_bytes;
    traffic.host_waits += 1;
    Ok(result(&bytemuck::pod_collect_to_vec::<u8, [u32; 4]>(
        &bytes,
    )))
}
