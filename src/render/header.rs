//! What every render report opens with, whichever pipeline rendered it: the scene, the image,
//! the camera and the shader.

use serde::Serialize;

/// The opening fields of a render report.
#[derive(Debug, Serialize)]
pub struct Header {
    pub scene: String,
    pub triangles: usize,
    pub shader: &'static str,
    pub size: String,
    pub width: u32,
    pub height: u32,
    /// The orbit camera's index; null for `--eye`/`--at`.
    pub camera: Option<usize>,
    pub eye: [f32; 3],
    pub at: [f32; 3],
    pub preset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_samples: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ao_distance: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bounces: Option<u32>,
    pub load_seconds: f64,
    pub build_seconds: f64,
}

impl Header {
    /// The summary's opening words: shader, size, scene and its triangles.
    pub fn what(&self) -> String {
        format!(
            "{} {} of {} ({} triangles)",
            self.shader, self.size, self.scene, self.triangles
        )
    }
}
