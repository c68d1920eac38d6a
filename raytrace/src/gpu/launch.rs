//! One launch of paths as one submission: every kernel and trace of the launch recorded back
//! to back, and a single read-back at the end that brings the paths' values and the launch's
//! verdict together. The host blocks once per launch, not once per trace round.
//!
//! A trace's dispatches are counted to drain its queue when every workgroup runs its loop to
//! the end, which is what they do unless an implementation cuts a loop short. At the end of
//! the launch, `verdict.wgsl` folds every trace's queue state into one word that proves it.
//! Should a queue not be drained, the launch is recorded again with the host checking every
//! trace ([`trace_resident`](super::trace::trace_resident)): slower, but the same values.
//!
//! Nothing of a trace is uploaded: its queue is a new (zeroed) buffer and its ray count is
//! copied on the device from the launch's [`Header`](super::header::Header).

use super::buffers::{init, read_back, readable, storage};
use super::program::{Kernel, READ, WRITE};
use super::trace::{
    TraceDevice, TraceRound, grid, loop_cut, pass_timestamps, stamp_seconds, timestamps,
    trace_resident,
};
use super::{GpuContext, GpuError};
use crate::{Traffic, Walk};

/// The kernel folding a launch's queue states into one word (`verdict.wgsl`).
pub(super) fn verdict_kernel(device: &wgpu::Device) -> Kernel {
    Kernel::new(
        device,
        "verdict",
        include_str!("verdict.wgsl"),
        &[READ, WRITE],
    )
}

/// Where a recorded trace gets its ray count, and whether it counts its rays' work.
#[derive(Clone, Copy)]
pub(super) enum Count<'b> {
    /// Copied on the device from the 4 bytes at an offset of a buffer (a launch's header).
    Copied(&'b wgpu::Buffer, u64),
    /// Uploaded with the trace.
    Uploaded,
    /// Uploaded with the trace, which adds each ray's `B` and `T` to its path's entry of
    /// `counts` (two words a path; `per_path` consecutive rays a path).
    Counted {
        counts: &'b wgpu::Buffer,
        per_path: u32,
    },
}

/// The verdict's bits (`verdict.wgsl`).
const LOOP_CUT: u32 = 1;
const NOT_DRAINED: u32 = 2;

/// A trace recorded in the launch: its queue and parameters, read by the verdict.
struct Recorded {
    round: TraceRound,
    params: wgpu::Buffer,
}

/// The commands of one launch, recorded until [`Recorder::finish`] submits them.
pub(super) struct Recorder<'a> {
    dev: &'a TraceDevice,
    /// Where the thesis's walks run, when not on `dev` (see [`Recorder::walk_on`]).
    walks: Option<&'a TraceDevice>,
    verdict: &'a Kernel,
    encoder: wgpu::CommandEncoder,
    traces: Vec<Recorded>,
    /// Passes recorded so far.
    passes: u64,
    /// The launch's two timestamps (its first pass's start, the verdict's end), where the
    /// adapter has timestamps and the host does not check each trace.
    timing: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    /// Trace each generation with the host checking its queue (the fallback).
    checked: bool,
    /// Kernel seconds of the checked traces.
    checked_seconds: f64,
    /// Record no dispatch of a trace (see `GpuRenderer::starved`).
    #[cfg(test)]
    pub(super) starved: bool,
}

/// What a finished launch read back.
pub(super) struct Finished {
    /// The first bytes of the buffer handed to [`Recorder::finish`].
    pub values: Vec<u8>,
    /// Kernel seconds of the launch, from its first pass's start to its last pass's end
    /// (in the checked fallback, of its traces only), where the adapter has timestamps.
    pub kernel_seconds: Option<f64>,
    /// False when a trace's queue was not drained: the values are not to be used.
    pub drained: bool,
}

fn encoder(ctx: &GpuContext) -> wgpu::CommandEncoder {
    ctx.device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cobalt launch of paths"),
        })
}

impl<'a> Recorder<'a> {
    /// A launch on `dev`; `checked` has the host check every trace's queue before the next
    /// step is recorded.
    pub(super) fn new(dev: &'a TraceDevice, verdict: &'a Kernel, checked: bool) -> Self {
        let ctx = &dev.ctx;
        Self {
            dev,
            walks: None,
            verdict,
            encoder: encoder(ctx),
            traces: Vec::new(),
            passes: 0,
            timing: if checked { None } else { timestamps(ctx) },
            checked,
            checked_seconds: 0.0,
            #[cfg(test)]
            starved: false,
        }
    }

    /// Runs the reduced walks' traces on `walks` (the binary tree beside a wide one, on the
    /// same device) instead of the launch's tree.
    pub(super) fn walk_on(&mut self, walks: &'a TraceDevice) {
        self.walks = Some(walks);
    }

    /// Records a copy of `bytes` bytes on the device, from `from` at `from_at` to `to` at
    /// `to_at`: a launch's counts into the blocks that use them.
    pub(super) fn copy(
        &mut self,
        from: &wgpu::Buffer,
        from_at: u64,
        to: &wgpu::Buffer,
        to_at: u64,
        bytes: u64,
    ) {
        self.encoder
            .copy_buffer_to_buffer(from, from_at, to, to_at, bytes);
    }

    /// Records one pass of `pipeline` with one invocation per item.
    pub(super) fn pass_over(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        items: u32,
    ) {
        self.pass(
            pipeline,
            group,
            grid(&self.dev.ctx.limits, items.div_ceil(64)),
        );
    }

    /// Records one pass of `pipeline` over `grid` workgroups.
    pub(super) fn pass(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        grid: (u32, u32),
    ) {
        self.pass_timed(pipeline, group, grid, false);
    }

    /// [`Recorder::pass`], the launch's first pass starting its time and, when `last`, this
    /// one ending it.
    fn pass_timed(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        grid: (u32, u32),
        last: bool,
    ) {
        let first = self.passes == 0;
        self.passes += 1;
        let timestamp_writes =
            (self.timing.as_ref()).and_then(|(set, _)| pass_timestamps(set, first, last));
        let mut pass = self
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cobalt render pass"),
                timestamp_writes,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(grid.0, grid.1, 1);
    }

    /// Records the trace of the first `n` rays of `rays` into `out` (checked: runs it), its
    /// ray count and what it counts as `count` says. A checked trace counts nothing: a launch
    /// with counted traces is not run checked.
    ///
    /// # Errors
    /// Those of [`trace_resident`] when checked.
    pub(super) fn trace(
        &mut self,
        rays: &wgpu::Buffer,
        out: &wgpu::Buffer,
        n: u32,
        mode: Walk,
        count: Count<'_>,
        traffic: &mut Traffic,
    ) -> Result<(), GpuError> {
        if n == 0 {
            return Ok(());
        }
        let dev = match (mode, self.walks) {
            (Walk::Trace { .. }, _) | (_, None) => self.dev,
            (_, Some(walks)) => walks,
        };
        if self.checked {
            // What was recorded runs first; the trace then waits on the device.
            let before = std::mem::replace(&mut self.encoder, encoder(&self.dev.ctx));
            self.dev.ctx.queue.submit([before.finish()]);
            let seconds = trace_resident(dev, rays, out, n, mode, traffic)?;
            self.checked_seconds += seconds.unwrap_or(0.0);
            return Ok(());
        }
        let device = &self.dev.ctx.device;
        // New buffers are zeroed by wgpu: the queue starts empty without an upload.
        let queue = storage(device, "cobalt ray queue", 8, wgpu::BufferUsages::COPY_SRC);
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_SRC;
        let mut upload = |words: [u32; 4]| {
            traffic.host_to_device_bytes += 16;
            init(
                device,
                "cobalt trace parameters",
                bytemuck::cast_slice(&words),
                usage,
            )
        };
        let (params, counts) = match count {
            Count::Copied(from, at) => {
                let params = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("cobalt trace parameters"),
                    size: 16,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                self.copy(from, at, &params, 0, 4);
                (params, None)
            }
            Count::Uploaded => (upload([n, 0, 0, 0]), None),
            Count::Counted { counts, per_path } => {
                (upload([n, per_path.max(1), 1, 0]), Some(counts))
            }
        };
        let round = TraceRound::bound(dev, rays, out, n, mode, queue, params.clone(), counts);
        // A launch that starts with a trace starts its time there.
        let timing = self.timing.as_ref().filter(|_| self.passes == 0);
        #[cfg(test)]
        let dispatches = if self.starved { 0 } else { round.dispatches };
        #[cfg(not(test))]
        let dispatches = round.dispatches;
        round.record(
            &dev.kernels,
            &mut self.encoder,
            dispatches,
            timing.map(|(set, _)| set),
        );
        self.passes += dispatches;
        self.traces.push(Recorded { round, params });
        Ok(())
    }

    /// Records the verdict, submits the launch and reads back, in one wait, the first
    /// `bytes` of `values` (a multiple of 4) with the verdict and the launch's timestamps.
    ///
    /// # Errors
    /// [`GpuError::LoopCut`] when a traversal loop was cut short, and the errors of a
    /// read-back.
    pub(super) fn finish(
        mut self,
        values: &wgpu::Buffer,
        bytes: u64,
        traffic: &mut Traffic,
    ) -> Result<Finished, GpuError> {
        let device = &self.dev.ctx.device;
        // Each trace's queue (head, cut) and ray count, side by side for the verdict; one
        // empty state when there is no trace, so that the binding is not empty.
        let states = storage(
            device,
            "cobalt launch queue states",
            16 * self.traces.len().max(1) as u64,
            wgpu::BufferUsages::COPY_DST,
        );
        let word = storage(
            device,
            "cobalt launch verdict",
            16,
            wgpu::BufferUsages::COPY_SRC,
        );
        let traces = std::mem::take(&mut self.traces);
        for (k, t) in traces.iter().enumerate() {
            let at = 16 * k as u64;
            self.copy(&t.round.queue, 0, &states, at, 8);
            self.copy(&t.params, 0, &states, at + 8, 4);
        }
        let verdict = self.verdict;
        let group = verdict.program.bind(
            device,
            "cobalt launch verdict bind group",
            &[&states, &word],
        );
        let workgroups = grid(
            &self.dev.ctx.limits,
            (traces.len().max(1) as u32).div_ceil(64),
        );
        self.pass_timed(&verdict.pipeline, &group, workgroups, true);

        // The values, then the verdict's word, then the two timestamps.
        let head = bytes.next_multiple_of(4);
        let stamps = if self.timing.is_some() { 16 } else { 0 };
        let readback = readable(
            device,
            "cobalt launch read-back",
            (head + 4 + stamps).max(16),
        );
        if bytes > 0 {
            self.copy(values, 0, &readback, 0, bytes);
        }
        self.copy(&word, 0, &readback, head, 4);
        if let Some((set, resolve)) = &self.timing {
            self.encoder.resolve_query_set(set, 0..2, resolve, 0);
            self.encoder
                .copy_buffer_to_buffer(resolve, 0, &readback, head + 4, 16);
        }
        self.dev.ctx.queue.submit([self.encoder.finish()]);
        let name = self.dev.ctx.info.name.as_str();
        let mut all = read_back(device, name, &readback)?;
        traffic.device_to_host_bytes += 4 + stamps;
        traffic.host_waits += 1;
        let at = head as usize;
        let verdict: u32 = bytemuck::pod_read_unaligned(&all[at..at + 4]);
        if verdict & LOOP_CUT != 0 {
            return Err(loop_cut(name));
        }
        let drained = verdict & NOT_DRAINED == 0;
        let kernel_seconds = match &self.timing {
            Some(_) => Some(stamp_seconds(
                &self.dev.ctx,
                bytemuck::pod_read_unaligned(&all[at + 4..at + 20]),
            )),
            None => self.dev.ctx.timestamps.then_some(self.checked_seconds),
        };
        // The values are most of the bytes read back: kept where they are, not copied.
        all.truncate(bytes as usize);
        Ok(Finished {
            values: all,
            kernel_seconds,
            drained,
        })
    }
}
