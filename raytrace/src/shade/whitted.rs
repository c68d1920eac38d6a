//! Whitted shading (Whitted 1980, as the thesis uses it for coherent rays): Lambertian direct
//! light from point lights behind shadow rays, plus mirror reflection, up to a fixed number of
//! bounces. Every step is one generation: primary, its shadow rays, the first reflection, its
//! shadow rays, and so on; a generation with no rays (no reflective hit, no light) is skipped.

use glam::Vec3;

use super::Tracer;
use super::generation::Generations;
use super::surface::shading;
use crate::RayKind;
use crate::{Film, Light, PrimaryRays, RayBatch, Scene};

/// Whitted settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WhittedSettings {
    /// Mirror bounces after the primary hit (the thesis uses 2).
    pub bounces: u32,
}

impl Default for WhittedSettings {
    fn default() -> Self {
        Self { bounces: 2 }
    }
}

/// Radiance of a ray that leaves the scene: a pale sky, so open scenes and mirrors facing out
/// are not black.
pub const SKY: Vec3 = Vec3::new(0.35, 0.45, 0.6);

/// Whitted's ambient term, times the diffuse colour: keeps shadowed surfaces readable.
pub const AMBIENT: f32 = 0.05;

/// A ray in flight: the pixel it adds to and the product of the reflectances along its way.
#[derive(Clone, Copy)]
struct Path {
    pixel: u32,
    weight: Vec3,
}

/// Shades `primary` into `film`.
pub(crate) fn render<T: Tracer + ?Sized>(
    scene: &Scene,
    gens: &mut Generations<'_, T>,
    primary: PrimaryRays,
    film: &mut Film,
    settings: WhittedSettings,
) {
    let mut paths: Vec<Path> = primary
        .pixels
        .iter()
        .map(|&pixel| Path {
            pixel,
            weight: Vec3::ONE,
        })
        .collect();
    let mut rays = primary.rays;
    for bounce in 0..=settings.bounces {
        let kind = if bounce == 0 {
            RayKind::Primary
        } else {
            RayKind::Reflection
        };
        let hits = gens.trace(kind, bounce, &rays);
        let mut shadow = RayBatch::default();
        // What each shadow ray adds to which pixel if nothing blocks it.
        let mut unblocked: Vec<(u32, Vec3)> = Vec::new();
        let mut next = RayBatch::default();
        let mut next_paths = Vec::new();
        for (i, path) in paths.iter().enumerate() {
            let pixel = path.pixel as usize;
            let Some((t, prim)) = hits.get(i) else {
                film.add(pixel, path.weight * SKY);
                continue;
            };
            let ray = rays.get(i);
            let s = shading(scene, &ray, t, prim);
            let m = s.material;
            film.add(pixel, path.weight * m.emission);
            // Light not mirrored is scattered diffusely.
            let kd = path.weight * m.diffuse * (1.0 - m.reflectance);
            if kd != Vec3::ZERO {
                film.add(pixel, kd * AMBIENT);
                for light in &scene.lights {
                    let Light::Point {
                        position,
                        intensity,
                    } = *light;
                    let to = position - s.sp.p;
                    let d2 = to.length_squared();
                    let l = to / d2.sqrt();
                    // Lights behind the surface (by either normal) cast no shadow ray.
                    let cos = s.normal.dot(l);
                    if !(d2 > 0.0 && cos > 0.0 && s.geometric.dot(l) > 0.0) {
                        continue;
                    }
                    shadow.push(&s.sp.spawn_ray_to(position));
                    unblocked.push((path.pixel, kd * intensity * (cos / d2)));
                }
            }
            if m.reflectance > 0.0 && bounce < settings.bounces {
                let d = ray.dir.normalize_or_zero();
                let mut r = reflect(d, s.normal);
                // A shading normal can mirror a ray into the surface; fall back to the true one.
                if r.dot(s.geometric) <= 0.0 {
                    r = reflect(d, s.geometric);
                }
                next.push(&s.sp.spawn_ray(r, f32::INFINITY));
                next_paths.push(Path {
                    pixel: path.pixel,
                    weight: path.weight * m.reflectance,
                });
            }
        }
        let blocked = gens.trace(RayKind::Shadow, bounce, &shadow);
        for (k, &(pixel, light)) in unblocked.iter().enumerate() {
            if blocked.get(k).is_none() {
                film.add(pixel as usize, light);
            }
        }
        if next.is_empty() {
            break;
        }
        rays = next;
        paths = next_paths;
    }
}

/// `d` mirrored about the plane with unit normal `n`.
fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}
