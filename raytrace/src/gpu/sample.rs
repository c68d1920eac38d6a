//! The cost of tasks of paths, estimated on the GPU that would render them: every
//! `stride`-th path of each task is made by `raygen`, traced and shaded through all of its
//! generations by the path kernels, each trace adding its rays' counts `B` and `T` to their
//! path's entry, and `estimate.wgsl`'s `sum_launch` adds each task's paths in 64-bit
//! integers. Only the task list goes in and one pair of sums per task and kind comes back
//! (8 and 32 bytes a task): no ray crosses.
//!
//! The traces are the render's, counting as the CPU's counted traces count, so the sums equal
//! [`crate::paths::estimate_paths`]'s sample bit for bit wherever the kernels find the CPU's
//! hits (on lavapipe, always).

use std::ops::Range;

use super::GpuError;
use super::buffers::{check_size, storage};
use super::pipeline::grid;
use super::render::{FrameParams, GpuRenderer, Tally};
use crate::paths::Traffic;
use crate::shade::{AoSettings, Shader};

/// One task's sample as the GPU summed it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathSums {
    /// `B` and `T` of the sampled paths' primary, mirror and shadow rays.
    pub paths: [u64; 2],
    /// `B` and `T` of their AO probes.
    pub probes: [u64; 2],
    /// Paths sampled.
    pub sampled: usize,
}

/// What a sampling launch returned: each task's sums, and what crossed.
#[derive(Clone, Debug, Default)]
pub struct SampledPaths {
    /// Per task, in order.
    pub tasks: Vec<PathSums>,
    /// Bytes each way and host waits.
    pub traffic: Traffic,
}

impl GpuRenderer {
    /// Traces every `stride`-th path of each of `tasks` (from its first) with `shader` and
    /// sums its rays' counts per task (see the module docs).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the sampled paths or their probes exceed one binding,
    /// [`GpuError::LoopCut`] when a trace's queue was not drained (a checked re-run, which
    /// the renders have, would not count: the caller estimates elsewhere), and the errors of
    /// [`GpuRenderer::render_ao`].
    pub fn sample_paths(
        &self,
        frame: &FrameParams<'_>,
        tasks: &[&Range<usize>],
        shader: &Shader,
        stride: u32,
    ) -> Result<SampledPaths, GpuError> {
        self.sample_launch(frame, tasks, shader, stride)?
            .ok_or_else(|| GpuError::LoopCut {
                adapter: self.ctx.info.name.clone(),
                batches: super::pipeline::BATCHES,
            })
    }

    /// One launch of [`GpuRenderer::sample_paths`], one submission; `None` when a queue was
    /// not drained.
    fn sample_launch(
        &self,
        frame: &FrameParams<'_>,
        tasks: &[&Range<usize>],
        shader: &Shader,
        stride: u32,
    ) -> Result<Option<SampledPaths>, GpuError> {
        let mut traffic = Traffic::default();
        let (ao, secondary) = match shader {
            Shader::Ao(s) => (*s, s.samples),
            Shader::Whitted(_) => (
                AoSettings {
                    samples: 0,
                    ..AoSettings::default()
                },
                self.whitted.light_count,
            ),
        };
        let (stage, first) = self.begin(frame, tasks, &ao, secondary, stride, &mut traffic)?;
        let stride = stride.max(1) as usize;
        let sampled: Vec<usize> = tasks.iter().map(|t| t.len().div_ceil(stride)).collect();
        if self.scene.empty {
            // Every ray misses the root: nothing is counted.
            let tasks = sampled
                .iter()
                .map(|&sampled| PathSums {
                    sampled,
                    ..PathSums::default()
                })
                .collect();
            return Ok(Some(SampledPaths { tasks, traffic }));
        }
        if stage.chunk < stage.n {
            return Err(GpuError::TooLarge {
                adapter: self.ctx.info.name.clone(),
                what: "AO probes of a sample",
                bytes: u64::from(stage.n) * u64::from(ao.samples) * 32,
                limit: "max_storage_buffer_binding_size",
                max: u64::from(stage.chunk) * u64::from(ao.samples) * 32,
            });
        }
        let n = u64::from(stage.n);
        let device = &self.ctx.device;
        // New buffers are zeroed by wgpu: every launch counts from nothing.
        let zeroed = |label: &str, size: u64, usage| storage(device, label, size.max(16), usage);
        check_size(&self.ctx, "per-path counts", n * 8)?;
        let none = wgpu::BufferUsages::empty();
        let tally = Tally {
            paths: zeroed("cobalt sampled path counts", n * 8, none),
            probes: zeroed("cobalt sampled probe counts", n * 8, none),
        };
        let mut launch = self.recorder(&stage, false);
        match shader {
            Shader::Ao(s) => {
                self.record_ao(
                    &mut launch,
                    &stage,
                    &first,
                    s.samples,
                    Some(&tally),
                    &mut traffic,
                )?;
            }
            Shader::Whitted(s) => {
                self.record_whitted(&mut launch, &stage, &first, s, Some(&tally), &mut traffic)?;
            }
        }
        // `sum_launch` reads the launch's own task list: no second one crosses.
        let n_tasks = tasks.len() as u32;
        let params = self.resident.uniform(
            &self.ctx,
            ("cobalt sample sums parameters", 0),
            bytemuck::cast_slice(&[n_tasks, stage.n, 0, 0]),
            &mut traffic,
        );
        let t = tasks.len() as u64;
        let copy = wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let sums = zeroed("cobalt sample sums", 32 * t, copy);
        let probe_sums = zeroed("cobalt sample probe sums", 16 * t, copy);
        let cells = grid(&self.ctx.limits, n_tasks);
        for (counts, out) in [(&tally.paths, &sums), (&tally.probes, &probe_sums)] {
            let group = self.sums.program.bind(
                device,
                "cobalt sample sums bind group",
                &[&stage.tasks, counts, out, &params],
            );
            launch.pass(&self.sums.sum_launch, &group, cells);
        }
        if t > 0 {
            launch.copy(&probe_sums, 0, &sums, 16 * t, 16 * t);
        }
        let done = launch.finish(&sums, 32 * t, &mut traffic)?;
        traffic.device_to_host_bytes += 32 * t;
        if !done.drained {
            return Ok(None);
        }
        let words: Vec<[u32; 4]> = bytemuck::pod_collect_to_vec(&done.values);
        let pair = |w: [u32; 4]| {
            [
                u64::from(w[0]) | u64::from(w[1]) << 32,
                u64::from(w[2]) | u64::from(w[3]) << 32,
            ]
        };
        let (paths, probes) = words.split_at(tasks.len());
        let tasks = sampled
            .iter()
            .zip(paths.iter().zip(probes))
            .map(|(&sampled, (&p, &q))| PathSums {
                paths: pair(p),
                probes: pair(q),
                sampled,
            })
            .collect();
        Ok(Some(SampledPaths { tasks, traffic }))
    }
}
