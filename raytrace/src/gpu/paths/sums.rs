//! The kernel that adds an estimate's counts up per task on the device (`sums.wgsl`), so only
//! one pair of sums a task comes back. A renderer compiles it at its start; an estimate's
//! launch (`sample.rs`) runs it.

use crate::gpu::program::{Kernel, READ, WRITE};

/// The compiled `sums.wgsl`.
pub(super) fn sums_kernel(device: &wgpu::Device) -> Kernel {
    Kernel::new(
        device,
        "sums",
        include_str!("sums.wgsl"),
        &[READ, READ, READ, WRITE, READ],
    )
}
