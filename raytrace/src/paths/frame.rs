//! What one frame renders ([`Frame`]): what every device, estimate and renderer of the engine
//! is handed.

use crate::shade::RenderOptions;
use crate::{Bvh, Scene};

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
