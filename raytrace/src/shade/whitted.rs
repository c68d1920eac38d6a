//! Whitted shading (Whitted 1980, as the thesis uses it for coherent rays): Lambertian direct
//! light from point lights behind shadow rays, plus mirror reflection, up to a fixed number of
//! bounces. Every step is one generation: primary, its shadow rays, the first reflection, its
//! shadow rays, and so on; a generation with no rays (no reflective hit, no light) is skipped.

use glam::Vec3;
use rayon::prelude::*;

use super::Tracer;
use super::generation::Generations;
use super::surface::shading;
use crate::RayKind;
use crate::{Film, HitBatch, Light, PrimaryRays, RayBatch, Scene};

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

/// Paths one parallel job shades: enough to amortise the job, few enough that a small
/// generation still spreads over every thread.
const CHUNK: usize = 1024;

/// What shading a run of paths produced, in path order.
#[derive(Default)]
struct Shaded {
    /// Radiance added to pixels now, in the order a sequential loop would add it (a pixel's
    /// sum must not depend on the threads: the image is the same on any of them).
    adds: Vec<(u32, Vec3)>,
    shadow: RayBatch,
    /// What each shadow ray adds to which pixel if nothing blocks it.
    unblocked: Vec<(u32, Vec3)>,
    next: RayBatch,
    next_paths: Vec<Path>,
}

impl Shaded {
    fn append(&mut self, other: Shaded) {
        self.adds.extend(other.adds);
        self.shadow.extend(&other.shadow);
        self.unblocked.extend(other.unblocked);
        self.next.extend(&other.next);
        self.next_paths.extend(other.next_paths);
    }
}

/// Shades `primary` into `film`. Each bounce's shading runs in the caller's rayon pool, in
/// chunks of paths joined in order, so the rays and the image are the same on any number of
/// threads (on one thread, shading took 45 % of a 2-core Whitted render of Conference).
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
        let hits = gens.trace(kind, bounce, &rays, &|i| paths[i].pixel);
        let reflect_more = bounce < settings.bounces;
        let parts: Vec<Shaded> = paths
            .par_chunks(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let mut out = Shaded::default();
                for (k, path) in chunk.iter().enumerate() {
                    let i = c * CHUNK + k;
                    shade(scene, &rays, &hits, i, path, reflect_more, &mut out);
                }
                out
            })
            .collect();
        let mut all = Shaded::default();
        for part in parts {
            all.append(part);
        }
        for &(pixel, value) in &all.adds {
            film.add(pixel as usize, value);
        }
        let blocked = gens.trace(RayKind::Shadow, bounce, &all.shadow, &|k| {
            all.unblocked[k].0
        });
        for (k, &(pixel, light)) in all.unblocked.iter().enumerate() {
            if blocked.get(k).is_none() {
                film.add(pixel as usize, light);
            }
        }
        if all.next.is_empty() {
            break;
        }
        rays = all.next;
        paths = all.next_paths;
    }
}

/// Shades path `i` (ray `i` of `rays`, hit `i` of `hits`) into `out`.
fn shade(
    scene: &Scene,
    rays: &RayBatch,
    hits: &HitBatch,
    i: usize,
    path: &Path,
    reflect_more: bool,
    out: &mut Shaded,
) {
    let Some((t, prim)) = hits.get(i) else {
        out.adds.push((path.pixel, path.weight * SKY));
        return;
    };
    let ray = rays.get(i);
    let s = shading(scene, &ray, t, prim);
    let m = s.material;
    out.adds.push((path.pixel, path.weight * m.emission));
    // Light not mirrored is scattered diffusely.
    let kd = path.weight * m.diffuse * (1.0 - m.reflectance);
    if kd != Vec3::ZERO {
        out.adds.push((path.pixel, kd * AMBIENT));
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
            out.shadow.push(&s.sp.spawn_ray_to(position));
            out.unblocked
                .push((path.pixel, kd * intensity * (cos / d2)));
        }
    }
    if m.reflectance > 0.0 && reflect_more {
        let d = ray.dir.normalize_or_zero();
        let mut r = reflect(d, s.normal);
        // A shading normal can mirror a ray into the surface; fall back to the true one.
        if r.dot(s.geometric) <= 0.0 {
            r = reflect(d, s.geometric);
        }
        out.next.push(&s.sp.spawn_ray(r, f32::INFINITY));
        out.next_paths.push(Path {
            pixel: path.pixel,
            weight: path.weight * m.reflectance,
        });
    }
}

/// `d` mirrored about the plane with unit normal `n`.
fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

#[cfg(test)]
mod tests {
    use super::super::{CpuTracer, RenderOptions, Shader, render};
    use super::*;
    use crate::{Camera, testkit};

    /// Shading in chunks on three threads makes the image of one thread, bit for bit, with
    /// mirror bounces and shadow rays (Cornell's box has both), across chunk boundaries.
    #[test]
    fn the_image_is_the_same_on_any_number_of_threads() {
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:cornell:0.2").expect("scene");
        let (w, h) = (72, 40);
        assert!((w * h) as usize > 2 * CHUNK);
        let options = RenderOptions::new(
            w,
            h,
            Camera::orbit(&scene.bounds(), 2),
            Shader::Whitted(WhittedSettings::default()),
        );
        let make = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| render(&scene, &mut CpuTracer::new(&bvh), &options))
        };
        let (one, three) = (make(1), make(3));
        let bits = |r: &super::super::Rendering| -> Vec<[u32; 3]> {
            r.film
                .pixels()
                .iter()
                .map(|p| p.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(bits(&one), bits(&three));
        assert!(one.generations.len() >= 3, "{:?}", one.generations);
    }
}
