//! The GPU devices: wgpu compute kernels in WGSL for closest-hit, any-hit and the
//! thesis's reduced traversal, over the binary tree's node and triangle arrays as the CPU
//! lays them out, or over compressed 8-wide nodes made from the CPU's wide tree.
//!
//! - [`context`]: which adapters exist and which are used (hardware only, unless software
//!   adapters such as Mesa's lavapipe are asked for), each opened with its own limits;
//! - [`buffers`]: the scene and ray buffers, checked against the binding-size limits;
//! - [`wide`]: the compressed 8-wide nodes that `traverse_wide.wgsl` walks (`--layout wide`),
//!   made from the CPU's wide tree;
//! - [`trace`]: the trace kernels (`traverse.wgsl`, `traverse_wide.wgsl`, both behind
//!   `traverse_common.wgsl`) and the host loop that re-dispatches the
//!   persistent threads until the ray queue is drained;
//! - `program`: a shader module with its bind group's layout, and the pipelines and dispatches
//!   every kernel family shares;
//! - `launch`, `header` and `resident`: a launch of path kernels recorded as one submission,
//!   its counts made on the device, and the buffers kept there across launches;
//! - [`GpuDevice`]: one adapter tracing batches of rays (`cobalt trace`), and counting an
//!   estimate's sample (`cobalt estimate`) under the host's estimator,
//!   [`crate::cost::ReducedTraversal`], equal to the CPU's counts;
//! - `paths/`, the path kernels: [`GpuRenderer`], ambient occlusion and Whitted shading
//!   rendered entirely on the device (ray generation in Morton order, traces on the compressed
//!   wide tree, AO probes or shadow and mirror rays, image), and an estimate's sample of its
//!   paths counted there.
//!
//! The path kernels import the rest of `gpu/`, never the other way.
//!
//! The kernels mirror the CPU's traversal operation for operation; they differ only where the
//! CPU re-evaluates an exactly-zero edge function in f64 (WGSL has no portable f64): a ray
//! through a shared edge or vertex may then report the neighbouring triangle at the same
//! distance. WGSL also lets implementations divide to 2.5 ulp; lavapipe divides exactly.

pub mod buffers;
pub mod context;
mod device;
mod header;
mod launch;
mod paths;
mod program;
mod resident;
mod staging;
#[cfg(test)]
pub(crate) mod tests;
pub mod trace;
pub mod wide;

pub use context::{GpuContext, GpuOptions, adapters_available};
pub use device::GpuDevice;
pub use paths::render::GpuRenderer;
pub use trace::TraceKernels;

/// Why a GPU could not be opened or could not trace. Each message names the missing piece or
/// the limit that was hit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter of the allowed backends (and kinds) exists.
    #[error(
        "no GPU adapter found on backends {backends}{skipped} (install a Vulkan driver, e.g. \
         Debian's mesa-vulkan-drivers, or set COBALT_GPU_SOFTWARE=1 to use a software one)"
    )]
    NoAdapter {
        /// The backends searched.
        backends: String,
        /// A note on the software adapters skipped, or empty.
        skipped: String,
    },
    /// `gpu:K` names an adapter that does not exist.
    #[error("no GPU adapter {index}: there are {count} on backends {backends}")]
    NoSuchAdapter {
        /// The index asked for.
        index: usize,
        /// Adapters found.
        count: usize,
        /// The backends searched.
        backends: String,
    },
    /// `WGPU_BACKEND` names a backend that does not exist or is not built in.
    #[error(
        "WGPU_BACKEND={value:?}: {item:?} is not a backend cobalt can use (expected a \
         comma-separated list of vulkan, metal, dx12)"
    )]
    BadBackend {
        /// The variable's value.
        value: String,
        /// The item that is wrong.
        item: String,
    },
    /// `gpu:K` names a software adapter while software adapters are not allowed.
    #[error(
        "GPU adapter {index} ({name}) is a software adapter; set COBALT_GPU_SOFTWARE=1 to use \
         software adapters"
    )]
    SoftwareAdapter {
        /// The index asked for.
        index: usize,
        /// The adapter's name.
        name: String,
    },
    /// The adapter refused to open a device.
    #[error("{adapter}: cannot open a device: {why}")]
    RequestDevice {
        /// The adapter's name.
        adapter: String,
        /// wgpu's reason.
        why: String,
    },
    /// A buffer would exceed one of the device's limits.
    #[error("{adapter}: the {what} need {bytes} bytes, beyond the device's {limit} of {max} bytes")]
    TooLarge {
        /// The adapter's name.
        adapter: String,
        /// What the buffer holds.
        what: &'static str,
        /// Bytes needed.
        bytes: u64,
        /// The limit's name in wgpu.
        limit: &'static str,
        /// The limit's value.
        max: u64,
    },
    /// The tree is deeper than the kernel's stack can ever be.
    #[error("the BVH is {depth} levels deep; the GPU kernels support at most {max}")]
    TooDeep {
        /// The tree's depth.
        depth: usize,
        /// The deepest supported.
        max: usize,
    },
    /// Waiting for the GPU or reading its results back failed.
    #[error("{adapter}: {what}: {why}")]
    Readback {
        /// The adapter's name.
        adapter: String,
        /// What was being done.
        what: &'static str,
        /// wgpu's reason.
        why: String,
    },
    /// The estimator was given a task it cannot sample (empty, beyond the batch, or a batch
    /// whose columns disagree).
    #[error("cannot estimate these tasks: {why}")]
    BadTasks {
        /// The cost module's reason, naming the task.
        why: String,
    },
    /// The GPU runs the reduced traversals only; the trace walk counts on the CPU.
    #[error("the GPU estimator runs the reduced and first-leaf walks, not `{walk}`")]
    WalkUnsupported {
        /// The walk's name.
        walk: &'static str,
    },
    /// A task's sampled counts exceed the 32 bits the device sums them in.
    #[error("{adapter}: the sampled counts of task {task} exceed 32 bits")]
    CountOverflow {
        /// The adapter's name.
        adapter: String,
        /// The task's index in the launch.
        task: usize,
    },
    /// The wide tree has no compressed form for the GPU.
    #[error("the compressed wide layout: {0}")]
    Compress(#[from] wide::CompressError),
    /// A walk the chosen GPU layout does not run.
    #[error("the GPU's {layout} layout does not run the `{walk}` walk")]
    LayoutUnsupported {
        /// The layout's name.
        layout: &'static str,
        /// The walk's name.
        walk: &'static str,
    },
    /// The implementation cut a traversal loop short (lavapipe's loop limit), so some results
    /// would be wrong.
    #[error(
        "{adapter}: a traversal loop was cut short by the implementation; lower the batches \
         per dispatch (now {batches})"
    )]
    LoopCut {
        /// The adapter's name.
        adapter: String,
        /// Batches per dispatch in the failed launch.
        batches: u32,
    },
}

impl From<crate::cost::CostError> for GpuError {
    fn from(e: crate::cost::CostError) -> Self {
        Self::BadTasks { why: e.to_string() }
    }
}
