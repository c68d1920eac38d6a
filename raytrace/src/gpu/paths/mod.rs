//! The path kernels: whole paths rendered on the device, ambient occlusion (`render.rs`) or
//! Whitted shading (`whitted.rs`), and an estimate's sample of them counted (`sample.rs`).

pub(crate) mod render;
pub(crate) mod sample;
pub(crate) mod whitted;
