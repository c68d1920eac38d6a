//! `builtin:hairball`: a dense tangle of thin tubes inside a unit sphere. Many long, thin,
//! overlapping triangles make it the hard case for BVH quality and ray coherence.

use glam::Vec3;
use rayon::prelude::*;

use super::MeshBuilder;
use crate::Rng;

const SIDES: u32 = 6;
const SEGMENTS: usize = 42;

pub(super) fn generate(detail: f32) -> MeshBuilder {
    // 2 * SIDES * SEGMENTS = 504 triangles per strand: 2000 strands is about 1M triangles.
    let strands = (2000.0 * detail).round().max(1.0) as u64;
    let parts: Vec<MeshBuilder> = (0..strands)
        .into_par_iter()
        .map(|k| {
            let mut rng = Rng::new(0x4A1_2BA11 + k);
            let mut p = Vec3::from(rng.unit_vector()) * rng.f32().cbrt();
            let mut d = Vec3::from(rng.unit_vector());
            let mut path = Vec::with_capacity(SEGMENTS + 1);
            path.push(p);
            for _ in 0..SEGMENTS {
                d = (d + 0.35 * Vec3::from(rng.unit_vector())).normalize_or(d);
                if p.length() > 1.0 {
                    // Steer back inside so the ball stays a ball.
                    d = (d - 0.5 * p).normalize_or(-p);
                }
                p += 0.05 * d;
                path.push(p);
            }
            let mut m = MeshBuilder::default();
            m.tube(&path, 0.004, SIDES, 0);
            m
        })
        .collect();
    let mut m = MeshBuilder::default();
    for p in parts {
        m.append(p);
    }
    m
}
