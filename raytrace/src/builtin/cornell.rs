//! `builtin:cornell`: the Cornell box (open at +z) with a mirror sphere, a diffuse sphere, an
//! emissive ceiling panel and a point light just under it.

use glam::Vec3;

use super::MeshBuilder;
use crate::scene::{Light, Material};

const WHITE: u32 = 0;
const RED: u32 = 1;
const GREEN: u32 = 2;
const MIRROR: u32 = 3;
const BLUE: u32 = 4;
const LAMP: u32 = 5;

pub(super) fn materials() -> Vec<Material> {
    let m = |d: Vec3, r, e: Vec3| Material {
        diffuse: d,
        reflectance: r,
        emission: e,
    };
    vec![
        m(Vec3::splat(0.75), 0.0, Vec3::ZERO),
        m(Vec3::new(0.75, 0.15, 0.15), 0.0, Vec3::ZERO),
        m(Vec3::new(0.15, 0.75, 0.15), 0.0, Vec3::ZERO),
        m(Vec3::splat(0.05), 0.95, Vec3::ZERO),
        m(Vec3::new(0.2, 0.3, 0.8), 0.1, Vec3::ZERO),
        m(Vec3::ONE, 0.0, Vec3::splat(10.0)),
    ]
}

pub(super) fn generate(detail: f32) -> (MeshBuilder, Vec<Light>) {
    let mut m = MeshBuilder::default();
    // Walls: the box [-1, 1]^3, each wall a grid (more cells with more detail).
    let n = (8.0 * detail.sqrt()).round().clamp(1.0, 64.0) as u32;
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let lo = Vec3::splat(-1.0);
    m.grid(lo, z, x, n, WHITE); // floor, facing +y
    m.grid(Vec3::new(-1.0, 1.0, -1.0), x, z, n, WHITE); // ceiling, facing -y
    m.grid(lo, x, y, n, WHITE); // back, facing +z
    m.grid(lo, y, z, n, RED); // left, facing +x
    m.grid(Vec3::new(1.0, -1.0, -1.0), z, y, n, GREEN); // right, facing -x
    // Lamp panel just below the ceiling, facing down.
    let h = 0.999;
    m.quad(
        [
            Vec3::new(-0.25, h, -0.25),
            Vec3::new(0.25, h, -0.25),
            Vec3::new(0.25, h, 0.25),
            Vec3::new(-0.25, h, 0.25),
        ],
        LAMP,
    );
    // Spheres: level 4 (5120 triangles each) at detail 1.
    let level = (4.0 + detail.log2() / 2.0).round().clamp(1.0, 7.0) as u32;
    m.icosphere(Vec3::new(-0.45, -0.55, -0.35), 0.45, level, MIRROR);
    m.icosphere(Vec3::new(0.45, -0.6, 0.3), 0.4, level, BLUE);
    let lights = vec![Light::Point {
        position: Vec3::new(0.0, 0.95, 0.0),
        intensity: Vec3::splat(1.0),
    }];
    (m, lights)
}
