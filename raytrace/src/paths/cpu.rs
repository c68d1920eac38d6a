//! The CPU path device: one worker of a `--devices cpu:N[/T]` list, rendering its tasks'
//! paths with the host's shading ([`crate::shade::render_paths`]) in a rayon pool of its own.
//! Its paths live in the host's memory, so nothing crosses a link.

use std::ops::Range;

use sched::{DeviceError, SampleRate};

use super::{Estimate, Frame, Launch, PathDevice, Traffic, estimate_paths};
use crate::Result;
use crate::shade::{CpuTracer, render_paths};

/// One CPU device. See the module documentation.
pub struct CpuPaths {
    index: usize,
    threads: usize,
    pool: rayon::ThreadPool,
}

impl CpuPaths {
    /// Device number `index` (named `cpu{index}`) with a pool of `threads` threads: even one
    /// thread gets its own pool, so that shading's parallel loops stay on the device's
    /// threads instead of the process's global pool.
    ///
    /// # Errors
    /// [`crate::Error::ThreadPool`] when the threads cannot be started.
    pub fn new(index: usize, threads: usize) -> Result<Self> {
        let threads = threads.max(1);
        let pool = crate::cpu::thread_pool(format!("cobalt-cpu{index}"), threads)?;
        Ok(Self {
            index,
            threads,
            pool,
        })
    }

    /// `count` devices of `threads` threads, numbered from `first`.
    ///
    /// # Errors
    /// As [`CpuPaths::new`].
    pub fn many(first: usize, count: usize, threads: usize) -> Result<Vec<Self>> {
        (first..first + count)
            .map(|i| Self::new(i, threads))
            .collect()
    }

    /// Threads of the device.
    pub fn threads(&self) -> usize {
        self.threads
    }
}

impl PathDevice for CpuPaths {
    fn render(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
    ) -> std::result::Result<Launch, DeviceError> {
        let paths = frame.paths();
        if let Some(t) = tasks.iter().find(|t| t.start > t.end || t.end > paths) {
            return Err(DeviceError::msg(format!(
                "{}: task {}..{} is outside the image's {paths} paths",
                self.name(),
                t.start,
                t.end
            )));
        }
        // Ranks are below the image's pixels, which fit a u32 (sides of at most 65536).
        let ranks: Vec<u32> = tasks
            .iter()
            .flat_map(|&t| t.clone())
            .map(|r| r as u32)
            .collect();
        let rendered = self.pool.install(|| {
            render_paths(
                frame.scene,
                &mut CpuTracer::new(frame.bvh),
                frame.options,
                &ranks,
            )
        });
        Ok(Launch {
            values: rendered.values,
            rays: rendered.generations.iter().map(|g| g.rays).sum(),
            ..Launch::default()
        })
    }

    /// On the device's own threads.
    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        rate: SampleRate,
    ) -> std::result::Result<Estimate, DeviceError> {
        Ok(Estimate {
            work: self.pool.install(|| estimate_paths(frame, tasks, rate)),
            traffic: Traffic::default(),
        })
    }

    fn name(&self) -> String {
        format!("cpu{}", self.index)
    }

    fn class(&self) -> String {
        format!("cpu/{}", self.threads)
    }
}
