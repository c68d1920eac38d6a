//! The path kernels: whole paths rendered on the device, ambient occlusion (`render.rs`) or
//! Whitted shading (`whitted.rs`), and an estimate's sample of them counted (`sample.rs`).
//!
//! The renderer (`render.rs`) holds every kernel it launches; the Whitted and sampling
//! launches extend it from above, and what it holds of theirs (`whitted_kernels.rs`,
//! `sums.rs`, `shading.rs`) sits below it, so no two of these import each other.

pub(crate) mod render;
pub(crate) mod sample;
mod shading;
mod sums;
pub(crate) mod whitted;
mod whitted_kernels;
