//! One launch of paths as one submission: every kernel and trace of the launch recorded back
//! to back, and a single read-back at the end that brings the paths' values, each trace's
//! queue state and its timestamps together. The host blocks once per launch, not once per
//! trace round.
//!
//! A trace's dispatches are counted to drain its queue when every workgroup runs its loop to
//! the end, which is what they do unless an implementation cuts a loop short; the queue
//! states read at the end prove it. Should one not be drained, the launch is recorded again
//! with the host checking every trace ([`trace_resident`](super::pipeline::trace_resident)):
//! slower, but the same values.

use super::buffers::{SceneBuffers, read_back};
use super::pipeline::{
    GpuMode, Kernels, Threads, TraceRound, grid, stamp_seconds, timestamps, trace_resident,
};
use super::{GpuContext, GpuError};
use crate::paths::Traffic;

/// A trace recorded in the launch, checked when the launch's results are read.
struct Recorded {
    round: TraceRound,
    n: u32,
    timing: Option<(wgpu::QuerySet, wgpu::Buffer)>,
}

/// The commands of one launch, recorded until [`Recorder::finish`] submits them.
pub(super) struct Recorder<'a> {
    ctx: &'a GpuContext,
    kernels: &'a Kernels,
    scene: &'a SceneBuffers,
    threads: Threads,
    encoder: wgpu::CommandEncoder,
    traces: Vec<Recorded>,
    /// Trace each generation with the host checking its queue (the fallback).
    checked: bool,
    /// Kernel seconds of the checked traces.
    checked_seconds: f64,
}

/// What a finished launch read back.
pub(super) struct Finished {
    /// The first bytes of the buffer handed to [`Recorder::finish`].
    pub values: Vec<u8>,
    /// Kernel seconds of the traces, where the adapter has timestamps.
    pub trace_seconds: Option<f64>,
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
    /// A launch on `ctx` tracing `scene` with `kernels` and `threads`; `checked` has the host
    /// check every trace's queue before the next step is recorded.
    pub(super) fn new(
        ctx: &'a GpuContext,
        kernels: &'a Kernels,
        scene: &'a SceneBuffers,
        threads: Threads,
        checked: bool,
    ) -> Self {
        Self {
            ctx,
            kernels,
            scene,
            threads,
            encoder: encoder(ctx),
            traces: Vec::new(),
            checked,
            checked_seconds: 0.0,
        }
    }

    /// Records one pass of `pipeline` with one invocation per item.
    pub(super) fn pass_over(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        items: u32,
    ) {
        self.pass(pipeline, group, grid(&self.ctx.limits, items.div_ceil(64)));
    }

    /// Records one pass of `pipeline` over `grid` workgroups.
    pub(super) fn pass(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        group: &wgpu::BindGroup,
        grid: (u32, u32),
    ) {
        let mut pass = self
            .encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cobalt render pass"),
                timestamp_writes: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.dispatch_workgroups(grid.0, grid.1, 1);
    }

    /// Records the trace of the first `n` rays of `rays` into `out` (checked: runs it).
    ///
    /// # Errors
    /// Those of [`trace_resident`] when checked.
    pub(super) fn trace(
        &mut self,
        rays: &wgpu::Buffer,
        out: &wgpu::Buffer,
        n: u32,
        mode: GpuMode,
        traffic: &mut Traffic,
    ) -> Result<(), GpuError> {
        if n == 0 {
            return Ok(());
        }
        if self.checked {
            // What was recorded runs first; the trace then waits on the device.
            let before = std::mem::replace(&mut self.encoder, encoder(self.ctx));
            self.ctx.queue.submit([before.finish()]);
            let seconds = trace_resident(
                self.ctx,
                self.kernels,
                self.scene,
                rays,
                out,
                n,
                mode,
                self.threads,
                traffic,
            )?;
            self.checked_seconds += seconds.unwrap_or(0.0);
            return Ok(());
        }
        let round = TraceRound::new(
            self.ctx,
            self.kernels,
            self.scene,
            rays,
            out,
            n,
            mode,
            self.threads,
            traffic,
        );
        let timing = timestamps(self.ctx);
        round.record(
            self.kernels,
            &mut self.encoder,
            round.dispatches,
            timing.as_ref().map(|t| &t.0),
        );
        self.traces.push(Recorded { round, n, timing });
        Ok(())
    }

    /// Submits the launch and reads back, in one wait, the first `bytes` of `values` with
    /// every trace's queue state and timestamps.
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
        // Values first, then per trace its queue's 8 bytes and, with timestamps, 16 more:
        // offsets stay multiples of 8 as long as `bytes` is rounded up to one.
        let head = bytes.next_multiple_of(8);
        let per_trace = if self.ctx.timestamps { 24 } else { 8 };
        let state_bytes = per_trace * self.traces.len() as u64;
        let readback = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cobalt launch read-back"),
            size: (head + state_bytes).max(16),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if bytes > 0 {
            self.encoder
                .copy_buffer_to_buffer(values, 0, &readback, 0, bytes);
        }
        for (k, t) in self.traces.iter().enumerate() {
            let at = head + per_trace * k as u64;
            self.encoder
                .copy_buffer_to_buffer(&t.round.queue, 0, &readback, at, 8);
            if let Some((set, resolve)) = &t.timing {
                self.encoder.resolve_query_set(set, 0..2, resolve, 0);
                self.encoder
                    .copy_buffer_to_buffer(resolve, 0, &readback, at + 8, 16);
            }
        }
        self.ctx.queue.submit([self.encoder.finish()]);
        let all = read_back(&self.ctx.device, &self.ctx.info.name, &readback)?;
        traffic.device_to_host_bytes += state_bytes;
        traffic.host_waits += 1;
        let name = self.ctx.info.name.as_str();
        let mut seconds = self.checked_seconds;
        let mut drained = true;
        for (k, t) in self.traces.iter().enumerate() {
            let at = (head + per_trace * k as u64) as usize;
            let state: [u32; 2] = bytemuck::pod_read_unaligned(&all[at..at + 8]);
            drained &= t.round.check(name, state, t.n, self.threads)?.is_none();
            if t.timing.is_some() {
                seconds += stamp_seconds(
                    self.ctx,
                    bytemuck::pod_read_unaligned(&all[at + 8..at + 24]),
                );
            }
        }
        Ok(Finished {
            values: all[..bytes as usize].to_vec(),
            trace_seconds: self.ctx.timestamps.then_some(seconds),
            drained,
        })
    }
}
