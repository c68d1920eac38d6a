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
    /// Wall time of the render on the device: uploads, kernels, the image's read-back.
    pub render_seconds: f64,
    /// Rendering efficiency: total rays over `render_seconds`.
    pub mrays_per_s: f64,
    /// Kernel time of the traces from timestamp queries, where the device has them.
    pub trace_gpu_seconds: Option<f64>,
}

/// Renders on the first usable adapter (software adapters only with
/// `COBALT_GPU_SOFTWARE=1`).
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

#[cfg(feature = "gpu")]
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    size: (u32, u32),
    camera: &Camera,
    shader: &Shader,
    threads: GpuThreadsArg,
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
    let r = match shader {
        Shader::Ao(ao) => renderer.render_ao(size.0, size.1, camera, ao),
        Shader::Whitted(w) => renderer.render_whitted(size.0, size.1, camera, w),
    }
    .map_err(gpu_err)?;
    let total_rays = r.primary_rays + r.secondary_rays;
    let run = GpuRun {
        adapter,
        gpu_threads: threads.name(),
        total_rays,
        primary_rays: r.primary_rays,
        secondary_rays: r.secondary_rays,
        render_seconds: r.seconds,
        mrays_per_s: total_rays as f64 / r.seconds.max(1e-12) / 1e6,
        trace_gpu_seconds: r.trace_gpu_seconds,
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
) -> Result<(Film, GpuRun), CliError> {
    Err(CliError::Arg {
        flag: "pipeline",
        value: "gpu".into(),
        message: "this cobalt was built without the `gpu` feature".into(),
    })
}
