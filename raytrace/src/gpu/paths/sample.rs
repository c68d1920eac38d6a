//! The cost of tasks of paths, estimated on the GPU that would render them: every
//! `stride`-th path of each task is made by `raygen`, traced and shaded through all of its
//! generations by the path kernels, each trace adding its rays' counts `B` and `T` to their
//! path's entry, and `sums.wgsl` adds each task's paths. Only the task list goes in and one
//! pair of 32-bit sums per task and kind comes back (8 and 16 bytes a task): no ray crosses.
//!
//! The traces are the render's, on the renderer's tree (the compressed wide one: `B` counts
//! the wide nodes fetched, `T` the triangles tested); on the binary tree they count as the
//! CPU's counted traces of it count, so the sums equal [`crate::paths::sample_paths`]'s sample
//! on [`crate::Layout::Binary`] bit for bit wherever the kernels find the CPU's hits (on
//! lavapipe, always). With the thesis's walks ([`Walk::Reduced`], [`Walk::FirstLeaf`]) only
//! the sampled paths' camera rays are made and walked, by the trace kernels' counting modes on
//! the binary tree (uploaded beside the wide one), as [`crate::paths::walk_paths`] walks them
//! on the host. A sum that would not fit 32
//! bits (billions of node visits in one task's sample) saturates, and the launch fails with
//! [`GpuError::CountOverflow`]: the caller estimates on the host.

use std::ops::Range;

use sched::SampleRate;

use super::render::{GpuRenderer, Tally};
use crate::cost::Work;
use crate::gpu::GpuError;
use crate::gpu::buffers::{check_size, storage};
use crate::gpu::trace::{grid, loop_cut};
use crate::paths::{Estimate, sampled_options, task_work};
use crate::ray::RayKind;
use crate::shade::{AoSettings, RenderOptions, Shader};
use crate::traffic::Traffic;
use crate::traverse::walk::Walk;

impl GpuRenderer {
    /// The estimated work of each of `tasks` of `frame` from a sample at `rate`: every
    /// `rate.stride()`-th path of each task (from its first) traced as the render would trace
    /// it, with the rate's share of its AO probes ([`crate::paths::sampled_options`]), or its
    /// camera ray alone walked by a reduced `walk`, its rays' counts summed per task on the
    /// device and scaled to the task as the host scales them ([`crate::paths::task_work`]; see
    /// the module docs).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the sampled paths or their probes exceed one binding,
    /// [`GpuError::LoopCut`] when a trace's queue was not drained (a checked re-run, which
    /// the renders have, would not count: the caller estimates elsewhere),
    /// [`GpuError::CountOverflow`] when a task's sums do not fit 32 bits, and the errors of
    /// [`GpuRenderer::render`].
    pub fn sample_paths(
        &self,
        frame: &RenderOptions,
        tasks: &[&Range<usize>],
        rate: SampleRate,
        walk: Walk,
    ) -> Result<Estimate, GpuError> {
        // One launch of every `stride`-th path, one submission.
        let reduced = !matches!(walk, Walk::Trace { .. });
        let (frame, probe_scale) = if reduced {
            (*frame, 1.0)
        } else {
            sampled_options(frame, rate)
        };
        let frame = &frame;
        let stride = u32::try_from(rate.stride()).unwrap_or(u32::MAX);
        let shader = &frame.shader;
        let mut traffic = Traffic::default();
        let no_ao = AoSettings {
            samples: 0,
            ..AoSettings::default()
        };
        let (ao, secondary) = match shader {
            Shader::Ao(s) if !reduced => (*s, s.samples),
            Shader::Whitted(_) if !reduced => (no_ao, self.whitted.light_count),
            // A reduced walk makes the camera rays alone.
            _ => (no_ao, 0),
        };
        let (stage, first) = self.begin(frame, tasks, &ao, secondary, stride, &mut traffic)?;
        // Each task's work from its sampled paths' sums `B`, `T` and their probes'.
        let stride = stride.max(1) as usize;
        let scaled = |words: &[[u32; 4]]| -> Vec<Work> {
            let work = |nodes: u32, tris: u32| Work {
                nodes: nodes.into(),
                tris: tris.into(),
                rays: 0.0,
            };
            (tasks.iter().zip(words))
                .map(|(t, w)| {
                    let (paths, probes) = (work(w[0], w[1]), work(w[2], w[3]));
                    let sampled = t.len().div_ceil(stride);
                    task_work(paths, probes, t.len(), sampled, probe_scale)
                })
                .collect()
        };
        if self.dev.scene.empty {
            // Every ray misses the root: nothing is counted.
            let work = scaled(&vec![[0; 4]; tasks.len()]);
            return Ok(Estimate { work, traffic });
        }
        if stage.chunk < stage.n {
            return Err(GpuError::TooLarge {
                adapter: self.dev.ctx.info.name.clone(),
                what: "AO probes of a sample",
                bytes: u64::from(stage.n) * u64::from(ao.samples) * 32,
                limit: "max_storage_buffer_binding_size",
                max: u64::from(stage.chunk) * u64::from(ao.samples) * 32,
            });
        }
        let n = u64::from(stage.n);
        let device = &self.dev.ctx.device;
        // New buffers are zeroed by wgpu: every launch counts from nothing.
        let zeroed = |label: &str, size: u64, usage| storage(device, label, size.max(16), usage);
        check_size(&self.dev.ctx, "per-path counts", n * 8)?;
        let none = wgpu::BufferUsages::empty();
        let tally = Tally {
            paths: zeroed("cobalt sampled path counts", n * 8, none),
            probes: zeroed("cobalt sampled probe counts", n * 8, none),
            // A reduced walk counts the camera rays by its own walk, the trace walk traces them.
            primary: walk.for_kind(RayKind::Primary),
        };
        let mut launch = self.recorder(&stage, false);
        if let (true, Some(walks)) = (reduced, &self.walks) {
            launch.walk_on(walks.device()?);
        }
        if let (Shader::Whitted(s), false) = (shader, reduced) {
            self.record_whitted(&mut launch, &stage, &first, s, Some(&tally), &mut traffic)?;
        } else {
            // Without probes (a reduced walk's), the camera rays alone.
            let samples = ao.samples;
            self.record_ao(
                &mut launch,
                &stage,
                &first,
                samples,
                Some(&tally),
                &mut traffic,
            )?;
        }
        // The sums read the launch's own task list and header: no second one crosses.
        let t = tasks.len() as u64;
        let sums = zeroed("cobalt sample sums", 16 * t, wgpu::BufferUsages::COPY_SRC);
        let group = self.path_sums.program.bind(
            device,
            "cobalt sample sums bind group",
            &[
                &stage.tasks,
                &tally.paths,
                &tally.probes,
                &sums,
                &stage.header,
            ],
        );
        launch.pass(
            &self.path_sums.pipeline,
            &group,
            grid(&self.dev.ctx.limits, tasks.len() as u32),
        );
        let done = launch.finish(&sums, 16 * t, &mut traffic)?;
        traffic.device_to_host_bytes += 16 * t;
        if !done.drained {
            return Err(loop_cut(&self.dev.ctx.info.name));
        }
        let words: Vec<[u32; 4]> = bytemuck::pod_collect_to_vec(&done.values);
        if let Some(task) = words.iter().position(|w| w.contains(&u32::MAX)) {
            return Err(GpuError::CountOverflow {
                adapter: self.dev.ctx.info.name.clone(),
                task,
            });
        }
        Ok(Estimate {
            work: scaled(&words),
            traffic,
        })
    }
}
