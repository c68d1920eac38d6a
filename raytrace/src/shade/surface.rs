//! What shading needs at a hit: the spawnable surface point, the normals facing the incoming
//! ray, and the material.

use glam::Vec3;

use crate::spawn::SurfacePoint;
use crate::triangle::{RayShear, intersect_watertight};
use crate::{Hit, Material, Ray, Scene};

/// A hit, ready to shade.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shading {
    /// The point, its error bound and the unit geometric normal (of the winding).
    pub sp: SurfacePoint,
    /// Unit geometric normal on the side the ray came from.
    pub geometric: Vec3,
    /// Unit shading normal (interpolated if the scene has normals) on the same side.
    pub normal: Vec3,
    /// The triangle's material, or the default for scenes without materials.
    pub material: Material,
}

/// The full hit of `ray` on triangle `prim` at `t`. A [`crate::HitBatch`] keeps no
/// barycentrics; one more watertight test of that triangle gives exactly the traversal's
/// (the same vertices, bit for bit). Should it ever miss, the barycentrics of the point at `t`
/// stand in.
pub(crate) fn full_hit(scene: &Scene, ray: &Ray, t: f32, prim: u32) -> Hit {
    let [p0, p1, p2] = scene.vertices(prim as usize);
    let retest = RayShear::new(ray.origin, ray.dir).and_then(|s| {
        intersect_watertight(
            &s,
            &p0.to_array(),
            &p1.to_array(),
            &p2.to_array(),
            ray.tmin,
            ray.tmax.max(t),
        )
    });
    if let Some((t, u, v)) = retest {
        return Hit { t, prim, u, v };
    }
    let (e1, e2, d) = (p1 - p0, p2 - p0, ray.at(t) - p0);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let den = d11 * d22 - d12 * d12;
    let (u, v) = if den > 0.0 {
        let u = ((d22 * d.dot(e1) - d12 * d.dot(e2)) / den).clamp(0.0, 1.0);
        let v = ((d11 * d.dot(e2) - d12 * d.dot(e1)) / den).clamp(0.0, 1.0 - u);
        (u, v)
    } else {
        (1.0 / 3.0, 1.0 / 3.0)
    };
    Hit { t, prim, u, v }
}

/// Everything shading reads about the hit of `ray` on `prim` at `t`.
pub(crate) fn shading(scene: &Scene, ray: &Ray, t: f32, prim: u32) -> Shading {
    let hit = full_hit(scene, ray, t, prim);
    let sp = scene.surface_point(&hit);
    let geometric = if sp.normal.dot(ray.dir) > 0.0 {
        -sp.normal
    } else {
        sp.normal
    };
    let normal = match &scene.normals {
        Some(n) => {
            let [a, b, c] = scene.triangles[prim as usize].map(|k| n[k as usize]);
            let s = ((1.0 - hit.u - hit.v) * a + hit.u * b + hit.v * c).normalize_or(geometric);
            // Interpolated normals may lean past the surface; keep them on the ray's side.
            if s.dot(geometric) < 0.0 { -s } else { s }
        }
        None => geometric,
    };
    let material = scene
        .material_ids
        .get(prim as usize)
        .and_then(|&m| scene.materials.get(m as usize))
        .copied()
        .unwrap_or_default();
    Shading {
        sp,
        geometric,
        normal,
        material,
    }
}
