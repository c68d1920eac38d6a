//! What a GPU keeps across launches and frames, so that a launch sends only what is new to
//! it: its task list and its number of tasks (see `header.rs`).
//!
//! - Scratch buffers, by label: each label keeps its largest buffer, and a launch that fits in
//!   it reuses it. Every launch waits for its read-back before the next one is recorded, so no
//!   two launches use one buffer at once.
//! - Uniform blocks, by content: a frame's camera and shading parameters are uploaded by its
//!   first launch and kept while they stay the same. The words that change from launch to
//!   launch (the counts) are zero in the kept copy and are copied in on the device from the
//!   launch's header, as is every trace's ray count.

use std::collections::HashMap;
use std::sync::{Mutex, PoisonError};

use super::GpuContext;
use super::buffers::{init, storage};
use crate::Traffic;

/// A uniform block's name and index (a Whitted block per bounce).
type UniformKey = (&'static str, u32);

/// A device's kept buffers. See the module documentation.
#[derive(Debug, Default)]
pub(super) struct Resident {
    scratch: Mutex<HashMap<&'static str, wgpu::Buffer>>,
    /// Each block's bytes as uploaded, and its buffer.
    uniforms: Mutex<HashMap<UniformKey, (Vec<u8>, wgpu::Buffer)>>,
}

impl Resident {
    /// A storage buffer of at least `size` bytes (and of one element of any array), also
    /// usable as `usage`. The kernels bound their loops by the launch's counts, never by a
    /// buffer's length.
    pub(super) fn scratch(
        &self,
        device: &wgpu::Device,
        label: &'static str,
        size: u64,
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        // A binding holds at least one element of its array (the largest, a ray, is 32 bytes),
        // even for a launch with none: a scene without lights has no shadow rays.
        let size = size.max(64);
        let wanted = wgpu::BufferUsages::STORAGE | usage;
        // A poisoned lock only means another launch panicked; the buffers are still valid.
        let mut kept = self.scratch.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(b) = kept
            .get(label)
            .filter(|b| b.size() >= size && b.usage() == wanted)
        {
            return b.clone();
        }
        let b = storage(device, label, size, usage);
        kept.insert(label, b.clone());
        b
    }

    /// A uniform block holding `bytes`, uploaded (and counted in `traffic`) only when the
    /// block kept under `key` holds something else. The block may be written on the device
    /// (it is a copy destination): `bytes` holds zeros where a launch copies its counts.
    pub(super) fn uniform(
        &self,
        ctx: &GpuContext,
        key: UniformKey,
        bytes: &[u8],
        traffic: &mut Traffic,
    ) -> wgpu::Buffer {
        let mut kept = self.uniforms.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some((_, b)) = kept.get(&key).filter(|(held, _)| held == bytes) {
            return b.clone();
        }
        traffic.host_to_device_bytes += bytes.len() as u64;
        let b = init(
            &ctx.device,
            key.0,
            bytes,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        kept.insert(key, (bytes.to_vec(), b.clone()));
        b
    }

    /// `bytes` written at `offset` into the scratch buffer `label` (counted in `traffic`): a
    /// launch's number of tasks and its task list.
    pub(super) fn upload(
        &self,
        ctx: &GpuContext,
        label: &'static str,
        offset: u64,
        bytes: &[u8],
        traffic: &mut Traffic,
    ) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC;
        let b = self.scratch(&ctx.device, label, offset + bytes.len() as u64, usage);
        if !bytes.is_empty() {
            ctx.queue.write_buffer(&b, offset, bytes);
            traffic.host_to_device_bytes += bytes.len() as u64;
        }
        b
    }
}
