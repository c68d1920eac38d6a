//! What one frame renders ([`Frame`]): what every device, estimate and renderer of the engine
//! is handed.

use crate::shade::RenderOptions;
use crate::{Aabb, Bvh, Scene};

/// What one frame renders: the scene, its BVH and the image, camera and shader.
#[derive(Clone, Copy)]
pub struct Frame<'a> {
    /// The scene, for shading.
    pub scene: &'a Scene,
    /// Its BVH, for tracing.
    pub bvh: &'a Bvh,
    /// The image, camera and shader.
    pub options: &'a RenderOptions,
}

impl Frame<'_> {
    /// Paths in the image: one per pixel.
    pub fn paths(&self) -> usize {
        self.options.width as usize * self.options.height as usize
    }
}

/// What tells one frame's paths from another's: its scene and tree (by address, and the tree
/// by its size and bounds too, so that a tree rebuilt in the same place for moved geometry
/// is told apart) and its options.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FrameKey {
    scene: usize,
    bvh: usize,
    nodes: usize,
    bounds: Aabb,
    options: RenderOptions,
}

impl FrameKey {
    /// `frame`'s key.
    pub(super) fn of(frame: &Frame<'_>) -> Self {
        Self {
            scene: std::ptr::from_ref(frame.scene).addr(),
            bvh: std::ptr::from_ref(frame.bvh).addr(),
            nodes: frame.bvh.nodes().len(),
            bounds: frame.bvh.bounds(),
            options: *frame.options,
        }
    }
}
