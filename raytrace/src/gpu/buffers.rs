//! The buffers the kernels read and write: the scene (BVH nodes and triangles, uploaded
//! unchanged from the CPU layout), rays, results, the queue head, and the read-back of results.
//!
//! Every buffer is checked against `max_storage_buffer_binding_size` and `max_buffer_size`
//! before it is created: scene buffers that do not fit give [`GpuError::TooLarge`] naming the
//! limit; ray batches are split into launches that fit ([`rays_per_launch`]).

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use crate::{Bvh, BvhTriangle, RayBatch};

use super::{GpuContext, GpuError};

/// A ray as the kernels read it (WGSL `struct GpuRay { org: vec4<f32>, dir: vec4<f32> }`):
/// origin and `tmin`, direction and `tmax`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuRay {
    /// Origin x, y, z and `tmin`.
    pub org: [f32; 4],
    /// Direction x, y, z and `tmax`.
    pub dir: [f32; 4],
}

const _: () = assert!(size_of::<GpuRay>() == 32);

/// Bytes of one result (`vec2<u32>`: t bits and primitive, or B and T).
pub const RESULT_BYTES: u64 = 8;

impl GpuRay {
    /// Ray `i` of `rays`.
    pub(crate) fn of(rays: &RayBatch, i: usize) -> Self {
        GpuRay {
            org: [rays.ox[i], rays.oy[i], rays.oz[i], rays.tmin[i]],
            dir: [rays.dx[i], rays.dy[i], rays.dz[i], rays.tmax[i]],
        }
    }
}

/// The largest single buffer the kernels may bind on this device.
fn max_binding(limits: &wgpu::Limits) -> u64 {
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
}

/// Rays that one launch may hold on a device with `limits` (the ray buffer, 32 bytes a ray,
/// is the largest), rounded down to whole batches of 64.
pub fn rays_per_launch(limits: &wgpu::Limits) -> usize {
    let n = max_binding(limits) / size_of::<GpuRay>() as u64;
    usize::try_from(n / 64 * 64).unwrap_or(usize::MAX).max(64)
}

/// Checks that a storage buffer of `bytes` fits the device's limits.
///
/// # Errors
/// [`GpuError::TooLarge`] naming the limit exceeded.
pub fn check_size(ctx: &GpuContext, what: &'static str, bytes: u64) -> Result<(), GpuError> {
    let l = &ctx.limits;
    let (limit, max) = if l.max_buffer_size < l.max_storage_buffer_binding_size {
        ("max_buffer_size", l.max_buffer_size)
    } else {
        (
            "max_storage_buffer_binding_size",
            l.max_storage_buffer_binding_size,
        )
    };
    if bytes > max {
        return Err(GpuError::TooLarge {
            adapter: ctx.info.name.clone(),
            what,
            bytes,
            limit,
            max,
        });
    }
    Ok(())
}

/// A BVH on one device: its node and triangle arrays, as the CPU lays them out.
#[derive(Clone, Debug)]
pub struct SceneBuffers {
    /// The node array (`Bvh::nodes`).
    pub nodes: wgpu::Buffer,
    /// The triangle array (`Bvh::triangles`); one zero triangle when the tree has none.
    pub tris: wgpu::Buffer,
    /// True when the tree has no triangle: nothing is launched, every ray misses.
    pub empty: bool,
}

impl SceneBuffers {
    /// Uploads `bvh` to `ctx`'s device.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the node or triangle array exceeds a binding limit.
    pub fn upload(ctx: &GpuContext, bvh: &Bvh) -> Result<Self, GpuError> {
        Self::upload_arrays(ctx, bytemuck::cast_slice(bvh.nodes()), bvh.triangles())
    }

    /// Uploads a compressed wide tree (`--layout wide`) to `ctx`'s device.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the node or triangle array exceeds a binding limit.
    pub fn upload_wide(
        ctx: &GpuContext,
        tree: &super::wide::CompressedTree,
    ) -> Result<Self, GpuError> {
        let dummy = [super::wide::CompressedNode::default()];
        let nodes = if tree.nodes.is_empty() {
            &dummy[..]
        } else {
            &tree.nodes[..]
        };
        Self::upload_arrays(ctx, bytemuck::cast_slice(nodes), &tree.tris)
    }

    fn upload_arrays(
        ctx: &GpuContext,
        nodes: &[u8],
        triangles: &[BvhTriangle],
    ) -> Result<Self, GpuError> {
        let empty = triangles.is_empty();
        let dummy = [BvhTriangle::default()];
        let tris: &[u8] = if empty {
            bytemuck::cast_slice(&dummy)
        } else {
            bytemuck::cast_slice(triangles)
        };
        check_size(ctx, "BVH nodes", nodes.len() as u64)?;
        check_size(ctx, "BVH triangles", tris.len() as u64)?;
        let init = |label: &str, contents: &[u8]| {
            init(&ctx.device, label, contents, wgpu::BufferUsages::STORAGE)
        };
        Ok(Self {
            nodes: init("cobalt bvh nodes", nodes),
            tris: init("cobalt bvh triangles", tris),
            empty,
        })
    }
}

/// A storage buffer of `size` bytes, also usable as `usage`, left for the kernels to fill.
pub(crate) fn storage(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | usage,
        mapped_at_creation: false,
    })
}

/// A buffer of `usage` holding `contents`.
pub(crate) fn init(
    device: &wgpu::Device,
    label: &str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage,
    })
}

/// A buffer of `size` bytes the host maps to read what is copied into it.
pub(crate) fn readable(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Copies the first `bytes` of `buffer` (usage `COPY_SRC`) back, once the work submitted
/// before has run.
///
/// # Errors
/// As [`read_back`].
pub(crate) fn fetch(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u8>, GpuError> {
    let device = &ctx.device;
    // A mapped buffer may not be empty.
    let readback = readable(device, "cobalt read-back", bytes.max(16));
    copy(ctx, "cobalt read-back copy", buffer, &readback, bytes);
    let mut all = read_back(device, &ctx.info.name, &readback)?;
    all.truncate(bytes as usize);
    Ok(all)
}

/// Submits a copy of the first `bytes` of `from` to the start of `to`.
pub(crate) fn copy(
    ctx: &GpuContext,
    label: &str,
    from: &wgpu::Buffer,
    to: &wgpu::Buffer,
    bytes: u64,
) {
    let mut encoder = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
    encoder.copy_buffer_to_buffer(from, 0, to, 0, bytes);
    ctx.queue.submit([encoder.finish()]);
}

/// Waits for `buffer` (usage `MAP_READ`) to map and returns a copy of its bytes.
///
/// # Errors
/// [`GpuError::Readback`] when polling or mapping fails.
pub fn read_back(
    device: &wgpu::Device,
    adapter: &str,
    buffer: &wgpu::Buffer,
) -> Result<Vec<u8>, GpuError> {
    map(device, adapter, buffer.slice(..), wgpu::MapMode::Read)?;
    let bytes = buffer
        .get_mapped_range(..)
        .map_err(|e| readback_err(adapter, "reading results", e.to_string()))?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}

/// Maps `slice` of a buffer for `mode`, waiting for the work submitted before to finish.
///
/// # Errors
/// [`GpuError::Readback`] when polling or mapping fails.
pub(crate) fn map(
    device: &wgpu::Device,
    adapter: &str,
    slice: wgpu::BufferSlice,
    mode: wgpu::MapMode,
) -> Result<(), GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(mode, move |r| {
        // The receiver waits below; a failed send means it is gone, and then nobody cares.
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| readback_err(adapter, "waiting for the GPU", e.to_string()))?;
    let what = match mode {
        wgpu::MapMode::Read => "mapping results",
        wgpu::MapMode::Write => "mapping rays for upload",
    };
    rx.recv()
        .map_err(|e| readback_err(adapter, what, e.to_string()))?
        .map_err(|e| readback_err(adapter, what, e.to_string()))
}

pub(crate) fn readback_err(adapter: &str, what: &'static str, why: String) -> GpuError {
    GpuError::Readback {
        adapter: adapter.to_string(),
        what,
        why,
    }
}
