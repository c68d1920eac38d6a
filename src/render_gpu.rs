//! How the command line opens a GPU for a flag that asks for one (`cobalt trace --device
//! gpu`, `cobalt estimate --on gpu`), and how a GPU error names that flag.

use crate::error::CliError;

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
