//! The rays `cobalt estimate` cuts into tasks: one generation of camera or AO rays, every
//! generation of a Whitted render, or a ray file.

use std::path::Path;

use raytrace::shade::{CpuTracer, Recorder, RenderOptions, Shader, WhittedSettings, render};
use raytrace::{Bvh, Camera, RayBatch, RayKind, Scene, SceneNeeds, traverse};

use crate::args::Size;
use crate::error::CliError;

/// Seed of the AO rays' per-pixel scrambling: fixed, so runs are comparable.
const AO_SEED: u64 = 1;

/// Where the rays come from.
pub(super) enum RaySource {
    Primary,
    Ao,
    /// Every generation of a Whitted render: primary, shadow and reflection rays.
    Whitted,
    File(String, RayKind),
}

/// The rays of one run, one segment per generation: tasks never straddle two generations, and
/// each is traced with its own query (closest or any hit).
pub(super) struct Generations {
    /// Each generation's rays and their kind.
    pub(super) segments: Vec<(RayBatch, RayKind)>,
    /// The rays' kind as the report names it (`whitted` for a Whitted render's generations).
    pub(super) kind_name: &'static str,
    /// Whether the rays are coherent.
    pub(super) coherent: bool,
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
        let (segments, kind_name, coherent) = match self {
            Self::Primary => (
                vec![(camera.primary_rays(width, height).rays, RayKind::Primary)],
                RayKind::Primary.name(),
                true,
            ),
            Self::Ao => {
                let primary = camera.primary_rays(width, height).rays;
                let hits = traverse::closest_hits(bvh, &primary);
                let length = settings.ao_distance * scene.bounds().extent().length();
                let ao = raytrace::ao::ao_rays(
                    scene,
                    &primary,
                    &hits,
                    settings.ao_samples,
                    length,
                    AO_SEED,
                );
                (vec![(ao.rays, RayKind::Ao)], RayKind::Ao.name(), false)
            }
            Self::Whitted => {
                let mut rec = Recorder::new(CpuTracer::new(bvh));
                let options = RenderOptions::new(
                    width,
                    height,
                    camera,
                    Shader::Whitted(WhittedSettings::default()),
                );
                render(scene, &mut rec, &options);
                let gens = rec.generations.into_iter().map(|(k, r)| (r, k)).collect();
                (gens, "whitted", true)
            }
            Self::File(path, kind) => (
                vec![(crate::trace::read_rays(Path::new(&path))?, kind)],
                kind.name(),
                kind.is_coherent(),
            ),
        };
        Ok(Generations {
            segments,
            kind_name,
            coherent,
        })
    }
}
