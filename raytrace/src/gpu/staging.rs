//! The buffers a GPU device keeps from one hit launch to the next: rays going up, results
//! coming back, and the host-visible buffers they pass through.
//!
//! A launch that allocated its own paid for fresh memory at every step (packing into a new
//! vector, copying it into a new upload buffer, copying results out of a new read-back buffer
//! into more vectors), which on a virtual machine, where a first touch of a page is dear, took
//! many times the kernels' time. Here the rays are packed straight into a mapped upload
//! buffer and the hits read straight out of a mapped read-back buffer, all four buffers
//! reused; they grow (to a power of two of rays) when a launch needs more, never past one
//! binding or [`MOST_RAYS`]: a larger launch goes in several.

use std::ops::Range;

use crate::{RayBatch, Traffic, Walk};

use super::buffers::{GpuRay, RESULT_BYTES, copy, map, rays_per_launch, readback_err};
use super::trace::{TraceDevice, trace_resident};
use super::{GpuContext, GpuError};

const RAY_BYTES: u64 = size_of::<GpuRay>() as u64;

/// Rays per launch at most, however many a binding could hold: a launch through very large
/// buffers pays a fixed cost that grows with the buffers, not the launch (wgpu tracks their
/// every byte), and a million rays keep that cost small against the launch's own packing and
/// reading back.
const MOST_RAYS: usize = 1 << 20;

/// See the module documentation.
#[derive(Debug)]
pub(crate) struct Staging {
    /// Rays each buffer holds.
    capacity: u64,
    /// `MAP_WRITE | COPY_SRC`: the rays, packed on the host.
    upload: wgpu::Buffer,
    /// `STORAGE | COPY_DST`: the rays, as the kernels read them.
    rays: wgpu::Buffer,
    /// `STORAGE | COPY_SRC`: the results, as the kernels write them.
    out: wgpu::Buffer,
    /// `MAP_READ | COPY_DST`: the results, for the host.
    download: wgpu::Buffer,
}

impl Staging {
    fn new(ctx: &GpuContext, capacity: u64) -> Self {
        // Each buffer holds `capacity` rays or results of `per_ray` bytes.
        let buffer = |label, per_ray, usage| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: capacity * per_ray,
                usage,
                mapped_at_creation: false,
            })
        };
        use wgpu::BufferUsages as U;
        Self {
            capacity,
            upload: buffer("cobalt ray upload", RAY_BYTES, U::MAP_WRITE | U::COPY_SRC),
            rays: buffer("cobalt rays", RAY_BYTES, U::STORAGE | U::COPY_DST),
            out: buffer("cobalt results", RESULT_BYTES, U::STORAGE | U::COPY_SRC),
            download: buffer(
                "cobalt results read-back",
                RESULT_BYTES,
                U::MAP_READ | U::COPY_DST,
            ),
        }
    }

    /// `staging` if it holds `n` rays, else new buffers for the next power of two of them (at
    /// most a binding's worth, and at most [`MOST_RAYS`]).
    fn fit(staging: Option<Self>, ctx: &GpuContext, n: u64) -> Self {
        match staging {
            Some(s) if s.capacity >= n => s,
            _ => {
                let most = rays_per_launch(&ctx.limits).min(MOST_RAYS) as u64;
                Self::new(ctx, n.next_power_of_two().clamp(64, most.max(n)))
            }
        }
    }
}

/// `mode`'s results for the rays of `ranges`, one after another, through `staging`'s buffers
/// (grown or made as needed): one `[u32; 2]` per ray, `[t bits, prim]` (a miss is `[+inf
/// bits, u32::MAX]`) or the counts `[B, T]`; with the kernels' GPU seconds where timestamps
/// measured them.
///
/// # Errors
/// The errors of [`trace_resident`], and [`GpuError::Readback`] when mapping fails.
pub(crate) fn staged(
    staging: &mut Option<Staging>,
    dev: &TraceDevice,
    rays: &RayBatch,
    ranges: &[&Range<usize>],
    mode: Walk,
    traffic: &mut Traffic,
) -> Result<(Vec<[u32; 2]>, Option<f64>), GpuError> {
    let total: usize = ranges.iter().map(|r| r.len()).sum();
    let ctx = &dev.ctx;
    if dev.scene.empty {
        let none = match mode {
            Walk::Trace { .. } => [f32::INFINITY.to_bits(), u32::MAX],
            Walk::Reduced | Walk::FirstLeaf => [0, 0],
        };
        return Ok((vec![none; total], None));
    }
    let mut out = Vec::with_capacity(total);
    let mut seconds = ctx.timestamps.then_some(0.0);
    let most = rays_per_launch(&ctx.limits).min(MOST_RAYS);
    for launch in launches(ranges, most) {
        let n: usize = launch.iter().map(Range::len).sum();
        let s = Staging::fit(staging.take(), ctx, n as u64);
        let launched = run(&s, dev, rays, &launch, mode, &mut out, traffic);
        // A launch that failed may have left a buffer mapped: the next one starts afresh.
        if launched.is_ok() {
            *staging = Some(s);
        }
        seconds = seconds.zip(launched?).map(|(a, b)| a + b);
    }
    Ok((out, seconds))
}

/// `ranges` cut into launches of at most `most` rays each, in order.
fn launches(ranges: &[&Range<usize>], most: usize) -> Vec<Vec<Range<usize>>> {
    let mut all: Vec<Vec<Range<usize>>> = Vec::new();
    let mut room = 0;
    for r in ranges {
        let mut start = r.start;
        while start < r.end {
            if room == 0 {
                all.push(Vec::new());
                room = most.max(1);
            }
            let end = r.end.min(start + room);
            if let Some(launch) = all.last_mut() {
                launch.push(start..end);
            }
            room -= end - start;
            start = end;
        }
    }
    all
}

/// One launch of the rays of `chunk`, its results appended to `out`.
fn run(
    s: &Staging,
    dev: &TraceDevice,
    rays: &RayBatch,
    chunk: &[Range<usize>],
    mode: Walk,
    out: &mut Vec<[u32; 2]>,
    traffic: &mut Traffic,
) -> Result<Option<f64>, GpuError> {
    let ctx = &dev.ctx;
    let name = ctx.info.name.as_str();
    let n: u64 = chunk.iter().map(|r| r.len() as u64).sum();
    // Only what the launch writes and reads is mapped: wgpu zeroes a mapped range it has not
    // seen written, and the buffers may be far larger than this launch.
    map(
        &ctx.device,
        name,
        s.upload.slice(..n * RAY_BYTES),
        wgpu::MapMode::Write,
    )?;
    {
        let mut view = s
            .upload
            .get_mapped_range_mut(..n * RAY_BYTES)
            .map_err(|e| readback_err(name, "writing rays for upload", e.to_string()))?;
        // Mapped memory may be write-combined, so wgpu lets it be written, never read.
        let (slots, _) = view.slice(..).into_chunks::<{ size_of::<GpuRay>() }>();
        slots.write_iter(
            chunk
                .iter()
                .flat_map(Range::clone)
                .map(|i| bytemuck::cast(GpuRay::of(rays, i))),
        );
    }
    s.upload.unmap();
    copy(ctx, "cobalt ray upload", &s.upload, &s.rays, n * RAY_BYTES);
    // `n` is at most one binding of rays, far below 2^32.
    let count = u32::try_from(n).unwrap_or(u32::MAX);
    let seconds = trace_resident(dev, &s.rays, &s.out, count, mode, traffic)?;
    copy(
        ctx,
        "cobalt results read-back",
        &s.out,
        &s.download,
        n * RESULT_BYTES,
    );
    map(
        &ctx.device,
        name,
        s.download.slice(..n * RESULT_BYTES),
        wgpu::MapMode::Read,
    )?;
    {
        let view = s
            .download
            .get_mapped_range(..n * RESULT_BYTES)
            .map_err(|e| readback_err(name, "reading results", e.to_string()))?;
        out.extend_from_slice(bytemuck::cast_slice(&view));
    }
    s.download.unmap();
    // The rays went up and their hits came back, a wait each way.
    traffic.host_to_device_bytes += n * RAY_BYTES;
    traffic.device_to_host_bytes += n * RESULT_BYTES;
    traffic.host_waits += 2;
    Ok(seconds)
}

#[cfg(test)]
mod tests {
    use super::launches;

    #[test]
    #[allow(clippy::single_range_in_vec_init)] // a launch of one range is meant
    fn ranges_are_cut_into_launches_in_order() {
        let (a, b, c) = (0..5, 7..9, 9..9);
        assert_eq!(
            launches(&[&a, &b, &c], 3),
            [vec![0..3], vec![3..5, 7..8], vec![8..9]]
        );
        assert_eq!(launches(&[&a, &b], 100), [vec![0..5, 7..9]]);
        assert!(launches(&[&c], 3).is_empty());
    }
}
