//! A launch's counts, made on the device: the host sends the number of tasks (4 bytes) and
//! each task's first path and length (8 bytes a task); `header.wgsl` turns them into the
//! launch's [`Header`] and each task's first slot before any other kernel runs. What the
//! kernel computes is what [`Header::of`] computes on the host, which sizes the launch's
//! buffers; the frame-constant inputs (`stride`, `fit`, `secondary`) are a [`Setup`] block
//! kept with the frame's other parameters.

use std::ops::Range;

use bytemuck::{Pod, Zeroable};

use super::launch::Recorder;
use super::program::{Kernel, UNIFORM, WRITE};

/// A launch's counts (`header` in `header.wgsl`), copied on the device into the uniform
/// blocks and trace parameters that use them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub(super) struct Header {
    /// Paths of the launch (one slot each).
    pub count: u32,
    /// Paths whose secondary rays are traced together (all of them, unless AO probes must
    /// be cut into chunks that fit one binding).
    pub chunk: u32,
    /// Tasks of the launch: the one word the host sends.
    pub tasks: u32,
    /// Secondary rays of the first chunk: AO probes, or one shadow ray per path and light.
    pub secondary: u32,
}

impl Header {
    /// Byte offset of [`Header::count`].
    pub const COUNT: u64 = 0;
    /// Byte offset of [`Header::tasks`].
    pub const TASKS: u64 = 8;
    /// Byte offset of [`Header::secondary`].
    pub const SECONDARY: u64 = 12;

    /// Slots of a launch of `tasks`: every `stride`-th path of each task, from its first.
    pub fn slots(tasks: &[&Range<usize>], stride: u32) -> u64 {
        let stride = stride.max(1) as usize;
        tasks.iter().map(|t| t.len().div_ceil(stride) as u64).sum()
    }

    /// The header `header.wgsl` makes for `tasks` under `setup`, or `None` when the slots
    /// overflow 32 bits (the caller's binding limit refuses such launches first).
    pub fn of(tasks: &[&Range<usize>], setup: &Setup) -> Option<Self> {
        let count = u32::try_from(Self::slots(tasks, setup.stride)).ok()?;
        let chunk = count.min(setup.fit);
        Some(Self {
            count,
            chunk,
            tasks: u32::try_from(tasks.len()).ok()?,
            secondary: chunk.saturating_mul(setup.secondary),
        })
    }
}

/// The frame-constant inputs of `header.wgsl` (`struct Setup`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub(super) struct Setup {
    /// Every `stride`-th path of a task has a slot (at least 1).
    pub stride: u32,
    /// The most primaries whose probes fit one binding (`u32::MAX` without probes).
    pub fit: u32,
    /// Secondary rays per path.
    pub secondary: u32,
    pad: u32,
}

impl Setup {
    pub fn new(stride: u32, fit: u32, secondary: u32) -> Self {
        Self {
            stride: stride.max(1),
            fit,
            secondary,
            pad: 0,
        }
    }
}

/// What the host sends of `tasks`: each one's first path and length (ranks and lengths are
/// below the image's pixels, at most 2^32, checked by the caller).
pub(super) fn task_list(tasks: &[&Range<usize>]) -> Vec<[u32; 2]> {
    tasks
        .iter()
        .map(|t| [t.start as u32, t.len() as u32])
        .collect()
}

/// The compiled `header.wgsl`.
pub(super) fn header_kernel(device: &wgpu::Device) -> Kernel {
    Kernel::new(
        device,
        "header",
        include_str!("header.wgsl"),
        &[WRITE, WRITE, UNIFORM],
    )
}

/// Records `kernel` (from [`header_kernel`]) filling `header` and rewriting `tasks` (see the
/// module docs).
pub(super) fn record(
    kernel: &Kernel,
    launch: &mut Recorder<'_>,
    device: &wgpu::Device,
    [header, tasks, setup]: [&wgpu::Buffer; 3],
) {
    let group = kernel.program.bind(
        device,
        "cobalt launch header bind group",
        &[header, tasks, setup],
    );
    launch.pass(&kernel.pipeline, &group, (1, 1));
}
