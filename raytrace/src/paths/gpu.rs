//! The GPU path device: one adapter running the path kernels ([`GpuRenderer`]) on its tasks.
//! Primary rays are made on the device, every generation is traced and shaded there, and the
//! paths' values are read back once, at the end of the launch.

use std::collections::VecDeque;
use std::ops::Range;
use std::time::Instant;

use sched::{DeviceError, SampleRate};

use super::{Estimate, Frame, Launch, PathDevice};
use crate::gpu::{GpuContext, GpuError, GpuRenderer};
use crate::traverse::walk::Walk;
use crate::{Bvh, Scene};

/// One GPU. See the module documentation.
pub struct GpuPaths {
    renderer: GpuRenderer,
    name: String,
    /// The latest launches' seconds beyond their kernels (submission, read-back, unpacking).
    overheads: VecDeque<f64>,
}

/// Launches whose overhead the median is taken over: recent enough to follow the frames,
/// enough that one slow read-back does not decide it.
const OVERHEADS_KEPT: usize = 9;

impl GpuPaths {
    /// The adapter of `ctx` with `scene` and its `bvh` uploaded and the kernels compiled,
    /// named as the context names itself.
    ///
    /// # Errors
    /// As [`GpuRenderer::new`].
    pub fn new(ctx: GpuContext, scene: &Scene, bvh: &Bvh) -> Result<Self, GpuError> {
        let name = ctx.name();
        Ok(Self {
            renderer: GpuRenderer::new(ctx, scene, bvh)?,
            name,
            overheads: VecDeque::new(),
        })
    }
}

impl PathDevice for GpuPaths {
    fn render(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
    ) -> Result<Launch, DeviceError> {
        let started = Instant::now();
        let out = self.renderer.render(frame.options, tasks)?;
        if let Some(kernels) = out.device_seconds {
            let beyond = started.elapsed().as_secs_f64() - kernels;
            if self.overheads.len() == OVERHEADS_KEPT {
                self.overheads.pop_front();
            }
            self.overheads.push_back(beyond.max(0.0));
        }
        Ok(out)
    }

    /// On the GPU: the sample is made, traced (or its camera rays walked) and summed by the
    /// path kernels ([`GpuRenderer::sample_paths`]); one pair of sums per task and kind comes
    /// back.
    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        rate: SampleRate,
        walk: Walk,
    ) -> Result<Estimate, DeviceError> {
        Ok(self
            .renderer
            .sample_paths(frame.options, tasks, rate, walk)?)
    }

    /// The kernels' trace walk counts on the compressed wide tree, not on the host's.
    fn estimate_kind(&self) -> &'static str {
        "gpu"
    }

    fn name(&self) -> String {
        self.name.clone()
    }

    /// The median of the latest launches' time beyond their kernels, where the adapter times
    /// its kernels and a launch has been made: known, it lets a policy launch most of a
    /// device's list at once instead of halving it launch after launch, which on a GPU that
    /// traces a frame in less time than a dozen read-backs take cost more than the imbalance
    /// it saved.
    fn launch_overhead(&self) -> Option<f64> {
        let mut seen: Vec<f64> = self.overheads.iter().copied().collect();
        seen.sort_by(f64::total_cmp);
        seen.get(seen.len() / 2).copied()
    }

    fn class(&self) -> String {
        format!("{} ({})", self.name, self.renderer.context().info.name)
    }
}
