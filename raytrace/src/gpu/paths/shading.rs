//! The shading helpers every path kernel is compiled with (`shading.wgsl`).

/// `shading.wgsl`, the helpers the shading kernels share, prepended to each of them after what
/// they share with the trace kernels (`gpu/ray.wgsl`).
pub(super) fn with_shading(kernels: &str) -> String {
    [
        include_str!("../ray.wgsl"),
        include_str!("shading.wgsl"),
        kernels,
    ]
    .concat()
}
