//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013: shear the triangle into ray space, evaluate the three 2D edge
//! functions (in f64 when one is exactly zero, so the sign at shared edges and vertices is
//! decided exactly), and accept a hit when all three have the same sign. Two triangles sharing
//! an edge compute the same edge function with opposite signs, bit for bit, so no ray slips
//! between them.

use glam::Vec3;

/// The per-ray part of the test: the axis permutation and shear, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    org: [f32; 3],
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl RayShear {
    /// `None` when the ray cannot hit anything: a zero direction, or a non-finite origin or
    /// direction.
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Option<Self> {
        if !origin.is_finite() || !dir.is_finite() {
            return None;
        }
        let a = dir.abs();
        // The dominant axis by arithmetic rather than branches: incoherent rays (AO, bounces)
        // would mispredict them, once or twice a ray.
        let x_wins = (a.x >= a.y) & (a.x >= a.z);
        let y_wins = a.y >= a.z;
        let kz = usize::from(!x_wins) * (1 + usize::from(!y_wins));
        let d = dir.to_array();
        let dz = d[kz % 3];
        if dz == 0.0 {
            return None;
        }
        let (kx, ky) = ([1, 2, 0][kz % 3], [2, 0, 1][kz % 3]);
        // Keep the winding (and so the sign of the edge functions) independent of the axis.
        let (kx, ky) = if dz < 0.0 { (ky, kx) } else { (kx, ky) };
        Some(Self {
            org: origin.to_array(),
            kx,
            ky,
            kz,
            sx: d[kx] / dz,
            sy: d[ky] / dz,
            sz: 1.0 / dz,
        })
    }

    /// The shear [`RayShear::parts`] took apart.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(crate) fn from_parts(
        org: [f32; 3],
        [kx, ky, kz]: [usize; 3],
        [sx, sy, sz]: [f32; 3],
    ) -> Self {
        Self {
            org,
            kx,
            ky,
            kz,
            sx,
            sy,
            sz,
        }
    }

    /// The origin, the axes `kx, ky, kz` and the shear `sx, sy, sz`, for the four-lane test.
    #[inline(always)]
    pub(crate) fn parts(&self) -> ([f32; 3], [usize; 3], [f32; 3]) {
        (
            self.org,
            [self.kx, self.ky, self.kz],
            [self.sx, self.sy, self.sz],
        )
    }
}

/// Intersects the ray described by `s` with triangle `(v0, v1, v2)`, accepting
/// `tmin <= t <= tmax`. Returns `(t, u, v)` with `u`, `v` the barycentric weights of `v1`, `v2`.
/// Degenerate triangles never hit (their determinant is zero).
#[inline(always)]
pub fn intersect_watertight(
    s: &RayShear,
    v0: &[f32; 3],
    v1: &[f32; 3],
    v2: &[f32; 3],
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let (t_scaled, det, v, w) = intersect_parts(s, v0, v1, v2, tmin, tmax)?;
    let rcp = 1.0 / det;
    // `abs` is the negation of a negative `det` (a hit's is never zero or NaN). `+ 0.0` turns a
    // -0.0 distance (origin on the triangle) into +0.0.
    let t = t_scaled / det.abs() + 0.0;
    Some((t, v * rcp, w * rcp))
}

/// [`intersect_watertight`] up to its divisions: on a hit, the scaled distance (its sign
/// flipped where `det < 0`), `det` and the edge functions `v`, `w`. The lane kernels
/// (`simd.rs`) leave the divisions to the lanes that hit, and are checked against this.
#[inline(always)]
pub(crate) fn intersect_parts(
    s: &RayShear,
    v0: &[f32; 3],
    v1: &[f32; 3],
    v2: &[f32; 3],
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32, f32)> {
    let (kx, ky, kz) = (s.kx, s.ky, s.kz);
    let o = &s.org;
    // Four lanes so that `k & 3` indexing needs no bounds check (k < 3 by construction).
    let (kx, ky, kz) = (kx & 3, ky & 3, kz & 3);
    let a = [v0[0] - o[0], v0[1] - o[1], v0[2] - o[2], 0.0];
    let b = [v1[0] - o[0], v1[1] - o[1], v1[2] - o[2], 0.0];
    let c = [v2[0] - o[0], v2[1] - o[1], v2[2] - o[2], 0.0];
    let ax = a[kx] - s.sx * a[kz];
    let ay = a[ky] - s.sy * a[kz];
    let bx = b[kx] - s.sx * b[kz];
    let by = b[ky] - s.sy * b[kz];
    let cx = c[kx] - s.sx * c[kz];
    let cy = c[ky] - s.sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // f32 products are exact in f64, so these differences are correctly rounded and a
        // zero now means the point is on the edge.
        let d = |p: f32, q: f32, r: f32, t: f32| (p as f64 * q as f64 - r as f64 * t as f64) as f32;
        u = d(cx, by, cy, bx);
        v = d(ax, cy, ay, cx);
        w = d(bx, ay, by, ax);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = s.sz * a[kz];
    let bz = s.sz * b[kz];
    let cz = s.sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let (t_scaled, det_abs) = if det < 0.0 {
        (-t_scaled, -det)
    } else {
        (t_scaled, det)
    };
    if t_scaled < tmin * det_abs || t_scaled > tmax * det_abs {
        return None;
    }
    Some((t_scaled, det, v, w))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(o: Vec3, d: Vec3, t: [[f32; 3]; 3]) -> Option<(f32, f32, f32)> {
        let s = RayShear::new(o, d)?;
        intersect_watertight(&s, &t[0], &t[1], &t[2], 0.0, f32::INFINITY)
    }

    const TRI: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    #[test]
    fn hits_inside_misses_outside_both_sides() {
        let h = hit(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0), TRI).unwrap();
        assert_eq!(h.0, 1.0);
        assert!((h.1 - 0.25).abs() < 1e-6 && (h.2 - 0.25).abs() < 1e-6);
        assert!(hit(Vec3::new(0.25, 0.25, -1.0), Vec3::Z, TRI).is_some());
        assert!(hit(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z, TRI).is_none());
        // Behind the origin.
        assert!(hit(Vec3::new(0.25, 0.25, 1.0), Vec3::Z, TRI).is_none());
    }

    #[test]
    fn edges_and_vertices_count_as_hits() {
        for p in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.5, 0.0, 1.0),
            Vec3::new(0.5, 0.5, 1.0),
        ] {
            for d in [
                -Vec3::Z,
                Vec3::new(-0.0, 0.0, -1.0),
                Vec3::new(0.0, -0.0, -1.0),
            ] {
                assert!(hit(p, d, TRI).is_some(), "{p} {d}");
            }
        }
    }

    #[test]
    fn degenerate_and_zero_direction_never_hit() {
        let line = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let point = [[0.5, 0.5, 0.0]; 3];
        for t in [line, point] {
            for d in [-Vec3::Z, Vec3::new(0.1, 0.2, -1.0), -Vec3::Y, Vec3::X] {
                assert!(hit(Vec3::new(0.5, 0.5, 1.0), d, t).is_none());
                assert!(hit(Vec3::new(1.0, 0.0, 1.0), d, t).is_none());
            }
        }
        assert!(RayShear::new(Vec3::ZERO, Vec3::ZERO).is_none());
        assert!(RayShear::new(Vec3::NAN, Vec3::X).is_none());
    }

    #[test]
    fn in_plane_ray_misses() {
        assert!(hit(Vec3::new(-1.0, 0.25, 0.0), Vec3::X, TRI).is_none());
    }
}
