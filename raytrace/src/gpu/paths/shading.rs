//! The shading helpers every path kernel is compiled with (`shading.wgsl`).

/// `shading.wgsl`, the helpers the shading kernels share, prepended to each of them.
pub(super) fn with_shading(kernels: &str) -> String {
    format!("{}{kernels}", include_str!("shading.wgsl"))
}
