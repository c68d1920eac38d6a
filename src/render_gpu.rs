//! `cobalt render --pipeline gpu`: ambient occlusion or Whitted shading rendered entirely on
//! one GPU ([`raytrace::gpu::GpuRenderer`]): primary rays generated in Morton order, traced,
//! AO probes (or shadow and mirror rays) generated and traced, and the image accumulated on the
//! device; only the image comes back.
//! Nothing is scheduled, so `--devices`, `--policy`, `--mode`, `--task-size` and
//! `--sample-rate` do not apply.

use serde::Serialize;

use raytrace::shade::Shader;
use raytrace::{Bvh, Camera, Film, Scene};

use crate::error::CliError;

/// How the GPU hands rays to invocations (`--gpu-threads`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum GpuThreadsArg {
    /// Persistent workgroups taking batches of rays from a queue.
    Persistent,
    /// One invocation per ray.
    PerRay,
}

/// What the GPU pipeline reports beside the image.
#[derive(Debug, Serialize)]
pub struct GpuRun {
    /// The adapter's name.
    pub adapter: String,
    /// `persistent` or `per-ray`.
    pub gpu_threads: &'static str,
    /// Primary rays plus the secondary ray slots traced.
    pub total_rays: usize,
    pub primary_rays: usize,
    pub secondary_rays: usize,
    /// Renders timed (`--gpu-repeats`); the figures below are the fastest one's.
    pub repeats: u32,
    /// Wall time of the first render, the driver's warm-up included.
    pub first_render_seconds: f64,
    /// Wall time of the render on the device: uploads, kernels, the image's read-back.
    pub render_seconds: f64,
    /// Rendering efficiency: total rays over `render_seconds`.
    pub mrays_per_s: f64,
    /// Kernel time of the traces from timestamp queries, where the device has them.
    pub trace_gpu_seconds: Option<f64>,
    /// Total rays over `trace_gpu_seconds`: the traversal kernels' own rate.
    pub trace_mrays_per_s: Option<f64>,
}

/// How a GPU error reads on the command line: it names the flag (`--flag gpu`) that asked
/// for the GPU.
#[cfg(feature = "gpu")]
pub fn gpu_err(flag: &'static str) -> impl Fn(raytrace::gpu::GpuError) -> CliError + Copy {
    move |e| CliError::Arg {
        flag,
        value: "gpu".into(),
        message: e.to_string(),
    }
}

/// The first GPU found (`COBALT_GPU_*` options from the environment), for `--flag gpu`.
#[cfg(feature = "gpu")]
pub fn first_gpu(flag: &'static str) -> Result<raytrace::gpu::GpuContext, CliError> {
    use raytrace::devices::GpuSelect;
    use raytrace::gpu::{GpuContext, GpuOptions};
    Ok(GpuContext::open(GpuSelect::All, GpuOptions::from_env())
        .map_err(gpu_err(flag))?
        .swap_remove(0))
}

/// Renders on the first usable adapter (software adapters only with
/// `COBALT_GPU_SOFTWARE=1`), `repeats` times, keeping the fastest render.
#[cfg(feature = "gpu")]
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    size: (u32, u32),
    camera: &Camera,
    shader: &Shader,
    threads: GpuThreadsArg,
    repeats: u32,
) -> Result<(Film, GpuRun), CliError> {
    use raytrace::gpu::{GpuRenderer, Threads};
    let gpu_err = gpu_err("pipeline");
    let ctx = first_gpu("pipeline")?;
    let adapter = ctx.info.name.clone();
    let threads = match threads {
        GpuThreadsArg::Persistent => Threads::Persistent,
        GpuThreadsArg::PerRay => Threads::PerRay,
    };
    let renderer = GpuRenderer::new(ctx, scene, bvh)
        .map_err(gpu_err)?
        .with_threads(threads);
    let once = || {
        match shader {
            Shader::Ao(ao) => renderer.render_ao(size.0, size.1, camera, ao),
            Shader::Whitted(w) => renderer.render_whitted(size.0, size.1, camera, w),
        }
        .map_err(gpu_err)
    };
    let mut r = once()?;
    let first_render_seconds = r.seconds;
    for _ in 1..repeats {
        let next = once()?;
        if next.seconds < r.seconds {
            r = next;
        }
    }
    let total_rays = r.primary_rays + r.secondary_rays;
    let rate = |seconds: f64| total_rays as f64 / seconds.max(1e-12) / 1e6;
    let run = GpuRun {
        adapter,
        gpu_threads: threads.name(),
        total_rays,
        primary_rays: r.primary_rays,
        secondary_rays: r.secondary_rays,
        repeats,
        first_render_seconds,
        render_seconds: r.seconds,
        mrays_per_s: rate(r.seconds),
        trace_gpu_seconds: r.trace_gpu_seconds,
        trace_mrays_per_s: r.trace_gpu_seconds.map(rate),
    };
    Ok((r.film, run))
}

/// Without the `gpu` feature, `--pipeline gpu` is refused.
#[cfg(not(feature = "gpu"))]
pub fn render(
    _: &Scene,
    _: &Bvh,
    _: (u32, u32),
    _: &Camera,
    _: &Shader,
    _: GpuThreadsArg,
    _: u32,
) -> Result<(Film, GpuRun), CliError> {
    Err(CliError::Arg {
        flag: "pipeline",
        value: "gpu".into(),
        message: "this cobalt was built without the `gpu` feature".into(),
    })
}
