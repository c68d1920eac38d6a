//! Spawning secondary rays without self-intersection, as pbrt-v4 does (Pharr, Jakob and
//! Humphreys, *Physically Based Rendering* 4th ed., section 6.8.6; the same idea as Wächter
//! and Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems
//! ch. 6): compute the hit point from barycentrics with a conservative bound on its rounding
//! error, push it along the geometric normal just past that bound, on the side the new ray
//! leaves to, and round the result away from the surface. The spawned ray then starts strictly
//! on its side of the triangle's plane and cannot hit that triangle again.

use glam::Vec3;

use crate::{Hit, Ray, Scene};

/// pbrt's `gamma(n) = n u / (1 - n u)` with `u` the unit roundoff: a bound on the relative
/// error of `n` chained floating-point operations.
#[inline]
pub fn gamma(n: i32) -> f32 {
    let u = f32::EPSILON * 0.5;
    n as f32 * u / (1.0 - n as f32 * u)
}

/// The smallest float greater than `v` (`+inf` stays).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == 0.0 { 0.0 } else { v }; // -0.0 becomes +0.0
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// The largest float smaller than `v` (`-inf` stays).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v }; // +0.0 becomes -0.0
    let bits = v.to_bits();
    f32::from_bits(if v <= 0.0 { bits + 1 } else { bits - 1 })
}

/// A point on a surface with the bound of its rounding error and the unit geometric normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// The computed point.
    pub p: Vec3,
    /// Per-axis bound on `|p - exact point|`.
    pub error: Vec3,
    /// Unit geometric normal (of the triangle's winding).
    pub normal: Vec3,
    /// How far from the triangle's plane a ray leaving the point must start so that the
    /// watertight test cannot find the triangle in front of it: a bound on that test's error
    /// in `t`, which for a sliver far exceeds `error` (see [`Scene::surface_point`]).
    pub reach: f32,
}

impl SurfacePoint {
    /// A ray from this point in direction `dir` over `(0, tmax]`, with the origin offset so the
    /// surface cannot be hit again.
    pub fn spawn_ray(&self, dir: Vec3, tmax: f32) -> Ray {
        Ray::with_range(offset_ray_origin(self, dir), dir, 0.0, tmax)
    }

    /// A ray towards `target` (a light), ending just short of it: `t = 1` is the target, and
    /// the range stops at `1 - shadow epsilon` as pbrt's `SpawnRayTo` does.
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        let o = offset_ray_origin(self, target - self.p);
        Ray::with_range(o, target - o, 0.0, 1.0 - 1e-4)
    }
}

/// The ray origin for leaving `sp` in direction `w`: `p` moved along the normal by
/// `dot(|n|, error)` to `w`'s side, then each coordinate rounded one float further away.
///
/// The offset is at least `gamma(8) * max |p_k|` (and a normal float): on a plane through 0
/// along an axis (the ground `y = 0`), `p` is exact on that axis, the error bound is 0 and the
/// point would stay *on* the plane, where our triangle test accepts `t = 0`. It is also at
/// least [`SurfacePoint::reach`], which keeps the triangle test's own error in `t` from bringing
/// the ray back to its triangle.
pub fn offset_ray_origin(sp: &SurfacePoint, w: Vec3) -> Vec3 {
    let n = sp.normal;
    let d = n
        .abs()
        .dot(sp.error)
        .max(gamma(8) * sp.p.abs().max_element())
        .max(sp.reach)
        .max(f32::MIN_POSITIVE);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = sp.p + offset;
    let (o, p) = (offset.to_array(), po.as_mut());
    for k in 0..3 {
        if o[k] > 0.0 {
            p[k] = next_float_up(p[k]);
        } else if o[k] < 0.0 {
            p[k] = next_float_down(p[k]);
        }
    }
    po
}

impl Scene {
    /// The hit point of `hit` from its barycentrics, with pbrt's error bound
    /// (`gamma(7) * sum |b_i p_i|`, one more `gamma` for `b0 = 1 - u - v`), the unit geometric
    /// normal and the reach.
    ///
    /// The reach follows pbrt's bound on the test's error in `t` (its `deltaT`) for a ray from
    /// the point in any direction `d`, with `r` the largest coordinate of a vertex relative to
    /// the point: the sheared coordinates are off by up to `3 gamma(5) r`, so the three edge
    /// functions by up to `96 gamma(5) r^2` together; the hit's barycentrics (edge functions
    /// over the determinant, `|cross . d|` over the shear's scale) move by twice that over the
    /// determinant, and `t` by that times the vertices' largest `|z|` (`r` over the shear's
    /// scale): `192 gamma(5) r^3 / |cross . d|`, doubled for the determinant's own error. The
    /// plane lies `reach |cross| / |cross . d|` behind the origin, so `384 gamma(5) r^3 /
    /// |cross|` covers every `d`; `256 gamma(8)` is a little larger and as cheap in WGSL. It
    /// grows as a sliver thins.
    pub fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        let [p0, p1, p2] = self.vertices(hit.prim as usize);
        let b0 = (1.0 - hit.u - hit.v).max(0.0);
        let (b1, b2) = (hit.u, hit.v);
        let p = b0 * p0 + b1 * p1 + b2 * p2;
        let abs_sum = (b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs();
        let error = gamma(8) * abs_sum;
        let cross = (p1 - p0).cross(p2 - p0);
        let r = ((p0 - p).abs().max((p1 - p).abs()))
            .max((p2 - p).abs())
            .max_element();
        // `r / |cross| * r` first, so that neither `r^3` nor `r^2` leaves the range of `f32`;
        // a degenerate triangle (never hit) would give infinity times its zero normal.
        let reach = (256.0 * gamma(8) * (r / cross.length() * r) * r).min(f32::MAX);
        let normal = cross.normalize_or_zero();
        SurfacePoint {
            p,
            error,
            normal,
            reach,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp_across_zero() {
        assert_eq!(next_float_up(0.0), f32::from_bits(1));
        assert_eq!(next_float_up(-0.0), f32::from_bits(1));
        assert_eq!(next_float_down(0.0), -f32::from_bits(1));
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(-1.0), -1.0 - f32::EPSILON);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
        assert!(next_float_down(1.0) < 1.0);
    }

    #[test]
    fn rays_leave_a_plane_through_the_origin() {
        use crate::builtin::MeshBuilder;
        use crate::{BuildPreset, Bvh, Rng, testkit};

        let mut m = MeshBuilder::default();
        m.quad(
            [(-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0)].map(|(x, z)| Vec3::new(x, 0.0, z)),
            0,
        );
        let scene = testkit::scene_of("plane", m).unwrap();
        let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
        let mut rng = Rng::new(testkit::seed(11));
        for _ in 0..2000 {
            let o = Vec3::new(rng.f32() - 0.5, 1.0, rng.f32() - 0.5);
            let hit = bvh.closest_hit(&Ray::new(o, -Vec3::Y)).unwrap();
            let sp = scene.surface_point(&hit);
            let mut out = Vec3::from(rng.unit_vector());
            out.y = out.y.abs();
            assert!(bvh.closest_hit(&sp.spawn_ray(out, 1.0)).is_none(), "{out}");
        }
    }

    #[test]
    fn gamma_bounds() {
        assert!(gamma(3) > 3.0 * f32::EPSILON * 0.5);
        assert!(gamma(3) < 2e-7);
    }
}
