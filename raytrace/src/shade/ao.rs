//! Ambient occlusion (the thesis's diffuse workload): primary hits, then `samples` Halton
//! cosine-weighted probes per hit ([`crate::ao::ao_rays`]) in one any-hit generation; a pixel
//! is the fraction of its probes that escape within the length limit.

use super::Tracer;
use super::generation::Generations;
use crate::RayKind;
use crate::{Film, PrimaryRays, Scene};

/// Ambient-occlusion settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoSettings {
    /// Probes per primary hit (the thesis uses 32).
    pub samples: u32,
    /// Probe length; `None` is [`AoSettings::DISTANCE_FRACTION`] of the scene's diagonal.
    pub max_distance: Option<f32>,
    /// Seed of the per-pixel scrambling of the Halton points.
    pub seed: u64,
}

impl Default for AoSettings {
    fn default() -> Self {
        Self {
            samples: 32,
            max_distance: None,
            seed: 0,
        }
    }
}

impl AoSettings {
    /// Default probe length as a fraction of the bounding box diagonal: long enough to darken
    /// creases and contacts, short enough that open ground stays white.
    pub const DISTANCE_FRACTION: f32 = 0.05;

    /// The probe length used for `scene`, in the scene's units (`max_distance` is in the
    /// source's, see [`Scene::unit`]).
    pub fn distance(&self, scene: &Scene) -> f32 {
        self.probe_length(scene.bounds().extent().length(), scene.unit)
    }

    /// The probe length for a scene of bounding-box diagonal `diagonal` whose source was
    /// scaled by `2^-unit`.
    pub(crate) fn probe_length(&self, diagonal: f32, unit: i32) -> f32 {
        self.max_distance
            .map_or(Self::DISTANCE_FRACTION * diagonal, |d| {
                crate::scene::scaled_length(d, -unit)
            })
    }
}

/// Shades `primary` into `film`: grey `1` is unoccluded (and the sky, where primaries miss).
/// `settings` come with their probe length in the scene's units ([`AoSettings::distance`]).
/// `ranks` are the primary rays' paths, which seed their probes (`None`: ray `i` is path `i`).
pub(crate) fn render<T: Tracer + ?Sized>(
    scene: &Scene,
    gens: &mut Generations<'_, T>,
    primary: PrimaryRays,
    film: &mut Film,
    (settings, distance): (AoSettings, f32),
    ranks: Option<&[u32]>,
) {
    let pixels = &primary.pixels;
    let hits = gens.trace(RayKind::Primary, 0, &primary.rays, &|i| pixels[i]);
    let probes = crate::ao::ao_rays_of_paths(
        scene,
        &primary.rays,
        &hits,
        settings.samples,
        distance,
        settings.seed,
        ranks,
    );
    let source = &probes.source;
    let blocked = gens.trace(RayKind::Ao, 1, &probes.rays, &|k| {
        pixels[source[k] as usize]
    });
    let n = primary.rays.len();
    let (mut sent, mut open) = (vec![0u32; n], vec![0u32; n]);
    for (k, &src) in probes.source.iter().enumerate() {
        sent[src as usize] += 1;
        if blocked.get(k).is_none() {
            open[src as usize] += 1;
        }
    }
    for (i, &pixel) in primary.pixels.iter().enumerate() {
        // A miss, or a hit that spawned no probe, sees the whole sky.
        let value = if sent[i] == 0 {
            1.0
        } else {
            open[i] as f32 / sent[i] as f32
        };
        film.set(pixel as usize, glam::Vec3::splat(value));
    }
}
