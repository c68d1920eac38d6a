//! Which rays `cobalt estimate` cuts into tasks (`--rays`): one generation of camera or AO
//! rays, every generation of a Whitted render, or a ray file.

use std::path::Path;

use raytrace::estimate::Generations;
use raytrace::{Bvh, Camera, RayKind, Scene, SceneNeeds};

use crate::args::Size;
use crate::error::CliError;

/// Where the rays come from.
pub(super) enum RaySource {
    Primary,
    Ao,
    /// Every generation of a Whitted render: primary, shadow and reflection rays.
    Whitted,
    File(String, RayKind),
}

/// How the camera and AO rays are made.
pub(super) struct RaySettings {
    /// The image of the camera rays.
    pub(super) size: Size,
    /// AO rays per primary hit.
    pub(super) ao_samples: u32,
    /// AO ray length as a fraction of the scene's bounding-box diagonal.
    pub(super) ao_distance: f32,
}

impl RaySource {
    /// `--rays` with `--ray-kind`, which only a ray file needs.
    pub(super) fn parse(rays: &str, kind: RayKind) -> Self {
        match rays {
            "primary" => Self::Primary,
            "ao" => Self::Ao,
            "whitted" => Self::Whitted,
            path => Self::File(path.into(), kind),
        }
    }

    /// What the scene must provide for these rays (a Whitted render needs materials).
    pub(super) fn needs(&self) -> SceneNeeds {
        if matches!(self, Self::Whitted) {
            SceneNeeds::WHITTED
        } else {
            SceneNeeds::AO
        }
    }

    /// The rays, made in the scene or read from the file.
    pub(super) fn generations(
        self,
        scene: &Scene,
        bvh: &Bvh,
        camera: Camera,
        settings: &RaySettings,
    ) -> Result<Generations, CliError> {
        let Size { width, height } = settings.size;
        Ok(match self {
            Self::Primary => Generations::primary(&camera, width, height),
            Self::Ao => Generations::ao(
                (scene, bvh),
                &camera,
                (width, height),
                settings.ao_samples,
                settings.ao_distance,
            ),
            Self::Whitted => Generations::whitted((scene, bvh), camera, width, height),
            Self::File(path, kind) => {
                let mut rays = crate::trace::read_rays(Path::new(&path))?;
                scene.rays_to_scene(&mut rays);
                Generations::of(rays, kind)
            }
        })
    }
}
