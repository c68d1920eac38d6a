//! The kernels of `traverse.wgsl` and the host loop that runs them.
//!
//! One shader per tree layout (`traverse.wgsl` for the binary tree, `traverse_wide.wgsl` for the
//! compressed 8-wide nodes of [`super::wide`]), four compute pipelines each (the `MODE`
//! override): closest hit, any hit, and the two reduced traversals (the thesis's and the
//! first-leaf one, see [`crate::Walk`]; the wide layout's host refuses the first-leaf walk).
//! A launch uploads its rays, resets the queue head, and records enough dispatches of
//! persistent workgroups to drain the queue: each workgroup takes [`BATCHES`] batches of 64
//! rays per dispatch, so `ceil(rays / (64 · BATCHES · workgroups))` dispatches suffice when
//! every workgroup runs its loop to the end. The host then reads the head back and dispatches
//! again while rays remain (an implementation that ends loops early, as lavapipe may, still
//! drains), and fails with [`GpuError::LoopCut`] if a traversal loop itself was cut short.

use super::buffers::{GpuRay, RESULT_BYTES, SceneBuffers, init, read_back, readable, storage};
use super::program::{Program, READ, UNIFORM, WRITE};
use super::{GpuContext, GpuError};
use crate::{Bvh, Layout, Traffic, Walk};

/// Batches of 64 rays a workgroup takes per dispatch: few enough that one invocation stays far
/// below lavapipe's ~65 535 loop iterations (a ray rarely needs more than a few hundred).
pub const BATCHES: u32 = 8;

/// The most workgroups one dispatch starts: enough to fill a large GPU with persistent
/// workgroups (an H100 holds about 132 × 16 of 64 invocations).
pub(crate) const MAX_WORKGROUPS: u32 = 2048;

/// Stack entries the kernels are compiled with at most (`Bvh::depth` is at most 256).
const MAX_STACK: usize = 256;

/// The closest-hit trace (`Bvh::closest_hit`), as a launch's mode.
pub(crate) const CLOSEST: Walk = Walk::Trace { any: false };
/// The any-hit trace (`Bvh::any_hit`): the first hit found.
pub(crate) const ANY: Walk = Walk::Trace { any: true };

/// The kernels' `MODE` for a launch that traces `walk`: the trace walk's hits, or the counts
/// `B`, `T` of a reduced walk (`Bvh::reduced_traversal`, `Bvh::first_leaf_traversal`).
fn mode_index(walk: Walk) -> usize {
    match walk {
        CLOSEST => 0,
        ANY => 1,
        Walk::Reduced => 2,
        Walk::FirstLeaf => 3,
    }
}

/// The compiled kernels for trees up to a given depth.
#[derive(Debug)]
pub struct TraceKernels {
    program: Program,
    /// By `mode_index`.
    pipelines: [wgpu::ComputePipeline; 4],
    /// Bound as the per-path counts of a trace that counts nothing.
    no_counts: wgpu::Buffer,
}

impl TraceKernels {
    /// Compiles the kernels with a stack for trees of `depth` levels.
    ///
    /// # Errors
    /// [`GpuError::TooDeep`] beyond 256 levels.
    pub fn new(device: &wgpu::Device, depth: usize) -> Result<Self, GpuError> {
        if depth > MAX_STACK {
            return Err(GpuError::TooDeep {
                depth,
                max: MAX_STACK,
            });
        }
        // A traversal holds at most depth - 1 entries; round up so that few variants exist.
        Ok(Self::compile(
            device,
            include_str!("traverse.wgsl"),
            depth.max(1).next_multiple_of(32),
        ))
    }

    /// Compiles the compressed wide tree's kernels (`traverse_wide.wgsl`) for a wide tree of
    /// `depth` levels.
    ///
    /// # Errors
    /// [`GpuError::TooDeep`] beyond 256 levels.
    pub fn wide(device: &wgpu::Device, depth: usize) -> Result<Self, GpuError> {
        if depth > MAX_STACK {
            return Err(GpuError::TooDeep {
                depth,
                max: MAX_STACK,
            });
        }
        // Each level leaves at most seven children on the stack.
        let stack = (7 * depth + 1).next_multiple_of(32);
        Ok(Self::compile(
            device,
            include_str!("traverse_wide.wgsl"),
            stack,
        ))
    }

    fn compile(device: &wgpu::Device, kernel: &str, stack: usize) -> Self {
        let source = [
            include_str!("ray.wgsl"),
            include_str!("traverse_common.wgsl"),
            kernel,
        ]
        .concat()
        .replace(
            "const STACK: u32 = 64u;",
            &format!("const STACK: u32 = {stack}u;"),
        );
        let program = Program::new(
            device,
            "traverse",
            source,
            &[READ, READ, READ, WRITE, WRITE, UNIFORM, WRITE],
        );
        let far_scale = f64::from(crate::slab::far_scale());
        let make = |mode: u32, label: &str| {
            program.pipeline_with(
                device,
                "main",
                label,
                wgpu::PipelineCompilationOptions {
                    constants: &[
                        ("MODE", f64::from(mode)),
                        ("BATCHES", f64::from(BATCHES)),
                        ("FAR_SCALE", far_scale),
                        ("CULL", f64::from(16.0 * crate::spawn::gamma(3))),
                    ],
                    zero_initialize_workgroup_memory: true,
                },
            )
        };
        Self {
            pipelines: [
                make(0, "cobalt closest-hit pipeline"),
                make(1, "cobalt any-hit pipeline"),
                make(2, "cobalt reduced-traversal pipeline"),
                make(3, "cobalt first-leaf reduced-traversal pipeline"),
            ],
            program,
            no_counts: storage(
                device,
                "cobalt no path counts",
                16,
                wgpu::BufferUsages::empty(),
            ),
        }
    }
}

/// A device with a tree uploaded and the trace kernels compiled for it: what every trace
/// needs, held by both GPU devices ([`super::GpuDevice`] and [`super::GpuRenderer`]).
#[derive(Debug)]
pub(crate) struct TraceDevice {
    pub(crate) ctx: GpuContext,
    pub(crate) kernels: TraceKernels,
    pub(crate) scene: SceneBuffers,
    /// The tree uploaded.
    pub(crate) layout: Layout,
}

impl TraceDevice {
    /// Uploads `bvh` as `layout` lays it out: the binary tree, or the compressed wide nodes
    /// made from [`Bvh::wide`]; and compiles that layout's kernels.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the tree exceeds a binding limit, [`GpuError::TooDeep`]
    /// beyond the deepest supported tree, [`GpuError::Compress`] for a wide tree with no
    /// compressed form.
    pub(crate) fn with_layout(
        ctx: GpuContext,
        bvh: &Bvh,
        layout: Layout,
    ) -> Result<Self, GpuError> {
        let (kernels, scene) = match layout {
            Layout::Binary => (
                TraceKernels::new(&ctx.device, bvh.depth())?,
                SceneBuffers::upload(&ctx, bvh)?,
            ),
            Layout::Wide => {
                let tree = super::wide::CompressedTree::new(bvh.wide())?;
                (
                    TraceKernels::wide(&ctx.device, bvh.wide().depth())?,
                    SceneBuffers::upload_wide(&ctx, &tree)?,
                )
            }
        };
        Ok(Self {
            kernels,
            scene,
            layout,
            ctx,
        })
    }
}

/// The binary tree uploaded beside a renderer's compressed wide one, for the thesis's walks
/// ([`Walk::Reduced`], [`Walk::FirstLeaf`]): they count the binary tree's nodes, as the host's
/// packets do, so that every device of a frame estimates its share alike (the wide kernel has
/// no first-leaf walk). Its kernels are compiled at the first such walk; renders never use it.
#[derive(Debug)]
pub(crate) struct BinaryWalks {
    ctx: GpuContext,
    depth: usize,
    /// The upload, or why it failed (told by the first walk that needs it).
    scene: Result<SceneBuffers, GpuError>,
    dev: std::sync::OnceLock<Result<TraceDevice, GpuError>>,
}

impl BinaryWalks {
    /// Uploads `bvh`'s binary tree to `ctx`'s device.
    pub(crate) fn new(ctx: &GpuContext, bvh: &Bvh) -> Self {
        Self {
            ctx: ctx.clone(),
            depth: bvh.depth(),
            scene: SceneBuffers::upload(ctx, bvh),
            dev: std::sync::OnceLock::new(),
        }
    }

    /// The binary tree with its kernels, compiled on the first call.
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when the binary tree exceeds a binding limit,
    /// [`GpuError::TooDeep`] beyond the deepest supported tree.
    pub(crate) fn device(&self) -> Result<&TraceDevice, GpuError> {
        let dev = self.dev.get_or_init(|| {
            let scene = self.scene.clone()?;
            Ok(TraceDevice {
                kernels: TraceKernels::new(&self.ctx.device, self.depth)?,
                scene,
                layout: Layout::Binary,
                ctx: self.ctx.clone(),
            })
        });
        dev.as_ref().map_err(Clone::clone)
    }
}

/// The timestamp writes of a pass: the start of a launch's `first` pass and the end of its
/// `last`. A pass in between gets none at all, since wgpu refuses writes that name neither
/// index (a large GPU's launch may take dozens of passes).
pub(crate) fn pass_timestamps(
    set: &wgpu::QuerySet,
    first: bool,
    last: bool,
) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
    (first || last).then_some(wgpu::ComputePassTimestampWrites {
        query_set: set,
        beginning_of_pass_write_index: first.then_some(0),
        end_of_pass_write_index: last.then_some(1),
    })
}

/// The error of a launch whose traversal loop `adapter` cut short.
pub(crate) fn loop_cut(adapter: &str) -> GpuError {
    GpuError::LoopCut {
        adapter: adapter.to_string(),
        batches: BATCHES,
    }
}

/// A two-dimensional grid of `workgroups` workgroups: one dimension holds at most
/// `max_compute_workgroups_per_dimension`.
pub(crate) fn grid(limits: &wgpu::Limits, workgroups: u32) -> (u32, u32) {
    let max = limits.max_compute_workgroups_per_dimension.max(1);
    let x = workgroups.clamp(1, max);
    (x, workgroups.div_ceil(x).max(1))
}

/// One trace's bind group, grid and first round of dispatches: its rays, results, queue and
/// parameters bound, and how many dispatches drain the queue when every workgroup runs its
/// loop to the end.
pub(crate) struct TraceRound {
    bind: wgpu::BindGroup,
    workgroups: u32,
    per_dispatch: u64,
    /// The queue head and the loop-cut flag, zeroed.
    pub(crate) queue: wgpu::Buffer,
    /// Dispatches of the first round.
    pub(crate) dispatches: u64,
    mode: usize,
}

impl TraceRound {
    /// Binds the first `n` rays of `rays` and their results in `out` for a trace in `mode`,
    /// with the queue (two words, zero) and the parameters (the ray count first) already on
    /// the device: nothing is uploaded. `counts` holds the per-path counts of a trace whose
    /// parameters ask for them.
    #[allow(clippy::too_many_arguments)] // the buffers and the choice of a trace
    pub(crate) fn bound(
        dev: &TraceDevice,
        rays: &wgpu::Buffer,
        out: &wgpu::Buffer,
        n: u32,
        mode: Walk,
        queue: wgpu::Buffer,
        params: wgpu::Buffer,
        counts: Option<&wgpu::Buffer>,
    ) -> Self {
        let (ctx, scene) = (&dev.ctx, &dev.scene);
        let device = &ctx.device;
        // Only the launch's rays and results are bound: a device's reused buffers are larger,
        // and wgpu tracks the initialisation of every byte a bind group covers.
        let first = |buffer, bytes| wgpu::BufferBinding {
            buffer,
            offset: 0,
            size: std::num::NonZeroU64::new(bytes),
        };
        let whole = wgpu::Buffer::as_entire_buffer_binding;
        let bind = dev.kernels.program.bind_ranges(
            device,
            "cobalt traverse bind group",
            &[
                whole(&scene.nodes),
                whole(&scene.tris),
                first(rays, u64::from(n) * size_of::<GpuRay>() as u64),
                first(out, u64::from(n) * RESULT_BYTES),
                whole(&queue),
                whole(&params),
                whole(counts.unwrap_or(&dev.kernels.no_counts)),
            ],
        );
        let batches = n.div_ceil(64);
        let max_wg = MAX_WORKGROUPS.min(ctx.limits.max_compute_workgroups_per_dimension);
        let workgroups = batches.div_ceil(BATCHES).clamp(1, max_wg);
        let per_dispatch = u64::from(workgroups) * u64::from(BATCHES) * 64;
        Self {
            bind,
            workgroups,
            per_dispatch,
            queue,
            dispatches: u64::from(n).div_ceil(per_dispatch),
            mode: mode_index(mode),
        }
    }

    /// Records `dispatches` passes of the trace into `encoder`, the first one's start and the
    /// last one's end timestamped into `timing` (queries 0 and 1) when given.
    pub(crate) fn record(
        &self,
        kernels: &TraceKernels,
        encoder: &mut wgpu::CommandEncoder,
        dispatches: u64,
        timing: Option<&wgpu::QuerySet>,
    ) {
        let pipeline = &kernels.pipelines[self.mode];
        for k in 0..dispatches {
            let timestamp_writes =
                timing.and_then(|set| pass_timestamps(set, k == 0, k + 1 == dispatches));
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("cobalt traverse pass"),
                timestamp_writes,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.bind, &[]);
            pass.dispatch_workgroups(self.workgroups, 1, 1);
        }
    }

    /// Whether the queue's state `[head, cut]` read after the trace of `n` rays says it is done; `Err` when a traversal loop was cut short, `Ok(Some(dispatches))` for
    /// the dispatches still needed.
    pub(crate) fn check(
        &self,
        adapter: &str,
        state: [u32; 2],
        n: u32,
    ) -> Result<Option<u64>, GpuError> {
        if state[1] != 0 {
            return Err(loop_cut(adapter));
        }
        if state[0] >= n {
            return Ok(None);
        }
        Ok(Some(
            u64::from(n - state[0]).div_ceil(self.per_dispatch).max(1),
        ))
    }
}

/// A query set of two timestamps and the buffer they resolve to, where the adapter has
/// timestamps.
pub(crate) fn timestamps(ctx: &GpuContext) -> Option<(wgpu::QuerySet, wgpu::Buffer)> {
    ctx.timestamps.then(|| {
        let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("cobalt traverse timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("cobalt timestamps resolved"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        (set, resolve)
    })
}

/// Seconds between two timestamps read back; a counter that went backwards (a reset) counts
/// as nothing.
pub(crate) fn stamp_seconds(ctx: &GpuContext, stamps: [u64; 2]) -> f64 {
    let period = f64::from(ctx.queue.get_timestamp_period());
    stamps[1].saturating_sub(stamps[0]) as f64 * period * 1e-9
}

/// Traces the first `n` rays of `rays` (a storage buffer of [`GpuRay`]s already on the device)
/// into `out` (`n` results of [`RESULT_BYTES`]), leaving the results on the device; returns
/// the kernels' GPU seconds where timestamps exist. Waits for the GPU after each round: only
/// the queue's state (8 bytes) and the timestamps are read back.
///
/// # Errors
/// [`GpuError::Readback`] when the GPU cannot be waited for or read, [`GpuError::LoopCut`]
/// when the implementation ended a traversal loop early.
pub(crate) fn trace_resident(
    dev: &TraceDevice,
    rays: &wgpu::Buffer,
    out: &wgpu::Buffer,
    n: u32,
    mode: Walk,
    traffic: &mut Traffic,
) -> Result<Option<f64>, GpuError> {
    let ctx = &dev.ctx;
    if n == 0 {
        return Ok(ctx.timestamps.then_some(0.0));
    }
    let device = &ctx.device;
    let name = ctx.info.name.as_str();
    let queue = init(
        device,
        "cobalt ray queue",
        bytemuck::cast_slice(&[0u32, 0]),
        wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    );
    let params = init(
        device,
        "cobalt launch parameters",
        bytemuck::cast_slice(&[n, 0, 0, 0]),
        wgpu::BufferUsages::UNIFORM,
    );
    // The queue's two words and the parameters.
    traffic.host_to_device_bytes += 8 + 16;
    let round = TraceRound::bound(dev, rays, out, n, mode, queue, params, None);
    let readback = readable(device, "cobalt queue state read-back", 8 + 16);
    let timing = timestamps(ctx);
    let mut gpu_seconds = 0.0;
    let mut dispatches = round.dispatches;
    loop {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("cobalt traverse commands"),
        });
        round.record(
            &dev.kernels,
            &mut encoder,
            dispatches,
            timing.as_ref().map(|t| &t.0),
        );
        encoder.copy_buffer_to_buffer(&round.queue, 0, &readback, 0, 8);
        if let Some((set, resolve)) = &timing {
            encoder.resolve_query_set(set, 0..2, resolve, 0);
            encoder.copy_buffer_to_buffer(resolve, 0, &readback, 8, 16);
        }
        ctx.queue.submit([encoder.finish()]);
        let bytes = read_back(device, name, &readback)?;
        traffic.device_to_host_bytes += bytes.len() as u64;
        traffic.host_waits += 1;
        let (status, stamps) = bytes.split_at(8);
        gpu_seconds += stamp_seconds(ctx, bytemuck::pod_read_unaligned(stamps));
        match round.check(name, bytemuck::pod_read_unaligned(status), n)? {
            None => return Ok(timing.is_some().then_some(gpu_seconds)),
            // Some workgroups stopped early: dispatch again for what is left.
            Some(left) => dispatches = left,
        }
    }
}
