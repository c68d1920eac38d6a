//! `builtin:forest`: large ground triangles and many small plants, so triangle sizes span about
//! five orders of magnitude in area, like the Fairy Forest benchmark.

use glam::Vec3;
use rayon::prelude::*;

use super::MeshBuilder;
use crate::Rng;
use crate::scene::Material;

const GROUND: u32 = 0;
const BARK: u32 = 1;
const LEAF: u32 = 2;
const GRASS: u32 = 3;
const PETAL: u32 = 4;

/// Half the side of the square ground.
const HALF: f32 = 100.0;

pub(super) fn materials() -> Vec<Material> {
    let m = |r, g, b, refl| Material {
        diffuse: Vec3::new(r, g, b),
        reflectance: refl,
        emission: Vec3::ZERO,
    };
    vec![
        m(0.35, 0.3, 0.2, 0.0),
        m(0.3, 0.2, 0.1, 0.0),
        m(0.2, 0.5, 0.15, 0.1),
        m(0.3, 0.6, 0.2, 0.0),
        m(0.9, 0.8, 0.3, 0.3),
    ]
}

fn height(x: f32, z: f32) -> f32 {
    2.0 * (x * 0.05).sin() * (z * 0.04).cos() + 0.8 * (x * 0.13 + z * 0.07).sin()
}

pub(super) fn generate(detail: f32) -> MeshBuilder {
    let mut m = MeshBuilder::default();
    // Ground: a 48 x 48 heightfield, triangles about 4 units across.
    let n = 48u32;
    let base = m.positions.len() as u32;
    for j in 0..=n {
        for i in 0..=n {
            let x = -HALF + 2.0 * HALF * i as f32 / n as f32;
            let z = -HALF + 2.0 * HALF * j as f32 / n as f32;
            m.vertex(Vec3::new(x, height(x, z), z));
        }
    }
    let at = |i: u32, j: u32| base + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            m.tri([at(i, j), at(i, j + 1), at(i + 1, j + 1)], GROUND);
            m.tri([at(i, j), at(i + 1, j + 1), at(i + 1, j)], GROUND);
        }
    }

    let trees = (80.0 * detail).round().max(1.0) as u64;
    let tufts = (3000.0 * detail).round().max(1.0) as u64;
    let flowers = (600.0 * detail).round().max(1.0) as u64;
    // Each plant has its own seed, so generation parallelises and stays deterministic.
    let parts: Vec<MeshBuilder> = (0..trees + tufts + flowers)
        .into_par_iter()
        .map(|k| {
            let mut rng = Rng::new(0xF0_4E57 + k);
            let x = rng.range(-0.95 * HALF, 0.95 * HALF);
            let z = rng.range(-0.95 * HALF, 0.95 * HALF);
            let ground = Vec3::new(x, height(x, z), z);
            let mut p = MeshBuilder::default();
            if k < trees {
                tree(&mut p, &mut rng, ground);
            } else if k < trees + tufts {
                tuft(&mut p, &mut rng, ground);
            } else {
                flower(&mut p, &mut rng, ground);
            }
            p
        })
        .collect();
    for p in parts {
        m.append(p);
    }
    m
}

/// A tapered trunk with a few branches and about 600 small leaves.
fn tree(m: &mut MeshBuilder, rng: &mut Rng, ground: Vec3) {
    let h = rng.range(6.0, 14.0);
    let r = h * 0.03;
    let trunk: Vec<Vec3> = (0..=6)
        .map(|i| ground + Vec3::new(0.0, h * i as f32 / 6.0, 0.0))
        .collect();
    m.tube(&trunk, r, 8, BARK);
    for _ in 0..4 {
        let start = ground + Vec3::Y * rng.range(0.5 * h, 0.85 * h);
        let d = (Vec3::from(rng.unit_vector()) * Vec3::new(1.0, 0.3, 1.0) + Vec3::Y * 0.4)
            .normalize_or(Vec3::Y);
        let len = rng.range(0.2, 0.4) * h;
        let path: Vec<Vec3> = (0..=3).map(|i| start + d * len * i as f32 / 3.0).collect();
        m.tube(&path, r * 0.4, 5, BARK);
    }
    let crown = ground + Vec3::Y * h * 0.85;
    let spread = h * 0.35;
    for _ in 0..600 {
        let c = crown + Vec3::from(rng.unit_vector()) * spread * rng.f32().cbrt();
        let s = rng.range(0.05, 0.3);
        let a = Vec3::from(rng.unit_vector());
        let b = a.any_orthonormal_vector();
        let e = a.cross(b);
        m.quad([c, c + b * s, c + (b + e) * s * 0.8, c + e * s], LEAF);
    }
}

/// Eight thin grass blades, one triangle each.
fn tuft(m: &mut MeshBuilder, rng: &mut Rng, ground: Vec3) {
    for _ in 0..8 {
        let off = Vec3::new(rng.range(-0.15, 0.15), 0.0, rng.range(-0.15, 0.15));
        let w = rng.range(0.01, 0.03);
        let h = rng.range(0.2, 0.6);
        let lean = Vec3::new(rng.range(-0.2, 0.2), 0.0, rng.range(-0.2, 0.2));
        let side = Vec3::new(rng.range(-1.0, 1.0), 0.0, rng.range(-1.0, 1.0)).normalize_or(Vec3::X);
        let p = ground + off;
        m.tri_points(p - side * w, p + side * w, p + Vec3::Y * h + lean, GRASS);
    }
}

/// A stem and five petals.
fn flower(m: &mut MeshBuilder, rng: &mut Rng, ground: Vec3) {
    let h = rng.range(0.2, 0.5);
    let top = ground + Vec3::Y * h;
    m.tube(&[ground, top], 0.005, 3, GRASS);
    let s = rng.range(0.02, 0.05);
    for i in 0..5 {
        let a = i as f32 / 5.0 * std::f32::consts::TAU;
        let d = Vec3::new(a.cos(), 0.15, a.sin());
        let e = Vec3::new(-a.sin(), 0.0, a.cos());
        m.tri_points(top, top + (d + e * 0.4) * s, top + (d - e * 0.4) * s, PETAL);
    }
}
