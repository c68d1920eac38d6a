//! What every render report opens with, whichever pipeline rendered it: the scene, the image,
//! the camera and the shader.

use raytrace::shade::Shader;
use raytrace::{BuildPreset, Bvh, Camera, Scene};
use serde::Serialize;

use crate::args::Size;

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

/// What a render drew: the scene as given and as loaded, its tree, and the view.
pub struct Drawn<'a> {
    pub source: &'a str,
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub preset: BuildPreset,
    pub load_seconds: f64,
    pub shader: &'a Shader,
    pub size: Size,
    pub camera: &'a Camera,
    pub camera_index: Option<usize>,
}

impl Header {
    /// The header of a render of `d`.
    pub fn new(d: &Drawn<'_>) -> Self {
        let (ao, whitted) = match d.shader {
            Shader::Ao(s) => {
                let distance = d.scene.length_to_source(s.distance(d.scene));
                (Some((s.samples, distance)), None)
            }
            Shader::Whitted(s) => (None, Some(s.bounces)),
        };
        Self {
            scene: d.source.to_string(),
            triangles: d.scene.len(),
            shader: d.shader.name(),
            size: d.size.to_string(),
            width: d.size.width,
            height: d.size.height,
            camera: d.camera_index,
            eye: d.scene.to_source(d.camera.eye).to_array(),
            at: d.scene.to_source(d.camera.at).to_array(),
            preset: d.preset.name().to_string(),
            ao_samples: ao.map(|(samples, _)| samples),
            ao_distance: ao.map(|(_, distance)| distance),
            bounces: whitted,
            load_seconds: d.load_seconds,
            build_seconds: d.bvh.report().build_seconds,
        }
    }

    /// The summary's opening words: shader, size, scene and its triangles.
    pub fn what(&self) -> String {
        format!(
            "{} {} of {} ({} triangles)",
            self.shader, self.size, self.scene, self.triangles
        )
    }
}
