//! Lane kernels of the wide traversal: the conservative box test of a node's eight children
//! ([`Box8Ray::hit8`]) and the watertight test of four triangles ([`Shear4::intersect4`]).
//!
//! Each lane does exactly what the scalar tests do ([`crate::slab`] and
//! [`crate::intersect_watertight`]): the same IEEE operations in the same order, with no fused
//! multiply-add, so every lane's result equals the scalar one bit for bit (tests below check
//! it). On x86_64 the box test is one AVX2 pass where the CPU has AVX2 (the caller detects it,
//! see [`avx2`]) and two SSE2 passes otherwise; the triangle test is SSE2 (part of the x86_64
//! baseline, so it needs no detection). Elsewhere both are loops over arrays.

use crate::Ray;
use crate::bvh::wide::{Node8, Tri4, WIDTH};
use crate::slab::far_scale;
use crate::triangle::RayShear;

/// Whether this CPU runs the AVX2 box test; detected once (std caches the answer).
#[inline(always)]
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The per-ray part of the eight-box test.
#[derive(Clone, Copy)]
pub(crate) struct Box8Ray {
    org: [f32; 3],
    inv: [f32; 3],
    /// Plane row of the near side per axis ([`Node8::planes`]).
    near: [usize; 3],
    far: [usize; 3],
    scale: f32,
}

/// The box test's answer: a bit per child whose box the ray meets, and each child's entry
/// distance (meaningful where the bit is set).
pub(crate) type Hits8 = (u32, [f32; WIDTH]);

impl Box8Ray {
    #[inline(always)]
    pub(crate) fn new(r: &Ray) -> Self {
        let d = r.dir.to_array();
        let neg = d.map(f32::is_sign_negative);
        Self {
            org: r.origin.to_array(),
            inv: [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]],
            near: [0, 1, 2].map(|a| if neg[a] { 3 + a } else { a }),
            far: [0, 1, 2].map(|a| if neg[a] { a } else { 3 + a }),
            scale: far_scale(),
        }
    }

    /// The children whose boxes the ray meets within `[tmin, tmax]`. `AVX2` picks the AVX2
    /// kernel, which the caller must have detected ([`avx2`]) and must run in a function
    /// compiled with `#[target_feature(enable = "avx2")]` for the kernel to be inlined.
    ///
    /// # Safety
    /// With `AVX2`, the CPU must have AVX2.
    #[inline(always)]
    pub(crate) unsafe fn hit8<const AVX2: bool>(
        &self,
        node: &Node8,
        tmin: f32,
        tmax: f32,
    ) -> Hits8 {
        #[cfg(target_arch = "x86_64")]
        {
            if AVX2 {
                // SAFETY: the caller has checked that the CPU has AVX2 (see `# Safety`).
                unsafe { x86::hit8_avx2(self, node, tmin, tmax) }
            } else {
                x86::hit8_sse(self, node, tmin, tmax)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.hit8_scalar(node, tmin, tmax)
        }
    }

    /// [`Box8Ray::hit8`] lane by lane, as [`crate::slab`]'s scalar test does it.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(crate) fn hit8_scalar(&self, node: &Node8, tmin: f32, tmax: f32) -> Hits8 {
        let p = &node.planes;
        let (mut mask, mut near) = (0, [0f32; WIDTH]);
        for k in 0..WIDTH {
            let mut t0 = tmin;
            let mut t1 = f32::INFINITY;
            for a in 0..3 {
                let n = (p[self.near[a]][k] - self.org[a]) * self.inv[a];
                let f = (p[self.far[a]][k] - self.org[a]) * self.inv[a];
                // Keep the accumulator where the slab is NaN (as `maxps`/`minps` do).
                t0 = if n > t0 { n } else { t0 };
                t1 = if f < t1 { f } else { t1 };
            }
            let t1 = t1 * self.scale;
            let t1 = if t1 < tmax { t1 } else { tmax };
            near[k] = t0;
            mask |= u32::from(t0 <= t1) << k;
        }
        (mask, near)
    }
}

/// The per-ray part of the four-triangle test: [`RayShear`]'s axes and shear.
#[derive(Clone, Copy)]
pub(crate) struct Shear4 {
    /// Origin along `kx`, `ky`, `kz`.
    org: [f32; 3],
    /// `kx`, `ky`, `kz`.
    axis: [usize; 3],
    sx: f32,
    sy: f32,
    sz: f32,
    shear: RayShear,
}

/// Hits of four triangles: a bit per lane that hits, and `t`, `u`, `v` by lane.
pub(crate) struct Hits4 {
    pub(crate) mask: u32,
    pub(crate) t: [f32; 4],
    pub(crate) u: [f32; 4],
    pub(crate) v: [f32; 4],
}

impl Shear4 {
    #[inline(always)]
    pub(crate) fn new(s: RayShear) -> Self {
        let (org, [kx, ky, kz], [sx, sy, sz]) = s.parts();
        Self {
            org: [org[kx], org[ky], org[kz]],
            axis: [kx, ky, kz],
            sx,
            sy,
            sz,
            shear: s,
        }
    }

    /// [`crate::intersect_watertight`] of the four triangles of `g`, lane by lane.
    #[inline(always)]
    pub(crate) fn intersect4(&self, g: &Tri4, tmin: f32, tmax: f32) -> Hits4 {
        #[cfg(target_arch = "x86_64")]
        {
            x86::intersect4(self, g, tmin, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.intersect4_scalar(g, tmin, tmax)
        }
    }

    /// [`Shear4::intersect4`] by calling the scalar test per lane.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(crate) fn intersect4_scalar(&self, g: &Tri4, tmin: f32, tmax: f32) -> Hits4 {
        let mut h = Hits4 {
            mask: 0,
            t: [0.0; 4],
            u: [0.0; 4],
            v: [0.0; 4],
        };
        let vert = |i: usize, k: usize| [g.v[i][0][k], g.v[i][1][k], g.v[i][2][k]];
        for k in 0..4 {
            let (a, b, c) = (vert(0, k), vert(1, k), vert(2, k));
            if let Some((t, u, v)) =
                crate::intersect_watertight(&self.shear, &a, &b, &c, tmin, tmax)
            {
                h.mask |= 1 << k;
                (h.t[k], h.u[k], h.v[k]) = (t, u, v);
            }
        }
        h
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m128, _CMP_LE_OQ, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_castsi128_ps, _mm_cmpeq_ps,
        _mm_cmpgt_ps, _mm_cmple_ps, _mm_cmplt_ps, _mm_div_ps, _mm_load_ps, _mm_loadu_ps,
        _mm_max_ps, _mm_min_ps, _mm_movemask_ps, _mm_mul_ps, _mm_or_ps, _mm_set1_epi32,
        _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps, _mm_xor_ps, _mm256_cmp_ps,
        _mm256_load_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps,
        _mm256_set1_ps, _mm256_storeu_ps, _mm256_sub_ps,
    };

    use super::{Box8Ray, Hits4, Hits8, Shear4, WIDTH};
    use crate::bvh::wide::{Node8, Tri4};

    #[inline(always)]
    fn load(a: &[f32; 4]) -> __m128 {
        // SAFETY: SSE2 is part of the x86_64 baseline, and `a` is four readable floats.
        unsafe { _mm_loadu_ps(a.as_ptr()) }
    }

    #[inline(always)]
    fn store(v: __m128) -> [f32; 4] {
        let mut a = [0f32; 4];
        // SAFETY: SSE2 is part of the x86_64 baseline, and `a` is four writable floats.
        unsafe { _mm_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    /// The eight boxes as two four-lane halves.
    #[inline(always)]
    pub(super) fn hit8_sse(r: &Box8Ray, node: &Node8, tmin: f32, tmax: f32) -> Hits8 {
        let p = &node.planes;
        let (mut mask, mut near) = (0, [0f32; WIDTH]);
        for half in 0..2 {
            let lanes = 4 * half..4 * half + 4;
            // SAFETY: SSE2 is part of the x86_64 baseline. `Node8` is 64-byte aligned and its
            // rows are 32 bytes each, so each half row is a 16-byte aligned run of four floats
            // for `_mm_load_ps`; `% 6` keeps the row indices in bounds (they already are).
            let (m, t0) = unsafe {
                let mut t0 = _mm_set1_ps(tmin);
                let mut t1 = _mm_set1_ps(f32::INFINITY);
                for a in 0..3 {
                    let (o, inv) = (_mm_set1_ps(r.org[a]), _mm_set1_ps(r.inv[a]));
                    let n = _mm_load_ps(p[r.near[a] % 6][lanes.clone()].as_ptr());
                    let f = _mm_load_ps(p[r.far[a] % 6][lanes.clone()].as_ptr());
                    let n = _mm_mul_ps(_mm_sub_ps(n, o), inv);
                    let f = _mm_mul_ps(_mm_sub_ps(f, o), inv);
                    // `max_ps(x, acc)` returns `acc` where `x` is NaN: NaN slabs are ignored.
                    t0 = _mm_max_ps(n, t0);
                    t1 = _mm_min_ps(f, t1);
                }
                let t1 = _mm_min_ps(_mm_mul_ps(t1, _mm_set1_ps(r.scale)), _mm_set1_ps(tmax));
                (_mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32, store(t0))
            };
            mask |= m << (4 * half);
            near[lanes].copy_from_slice(&t0);
        }
        (mask, near)
    }

    /// The eight boxes in one pass of 256-bit registers.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn hit8_avx2(r: &Box8Ray, node: &Node8, tmin: f32, tmax: f32) -> Hits8 {
        let p = &node.planes;
        let mut t0 = _mm256_set1_ps(tmin);
        let mut t1 = _mm256_set1_ps(f32::INFINITY);
        for a in 0..3 {
            let (o, inv) = (_mm256_set1_ps(r.org[a]), _mm256_set1_ps(r.inv[a]));
            // SAFETY: `Node8` is 64-byte aligned and its rows are 32 bytes each, so every row
            // is a 32-byte aligned run of eight floats for `_mm256_load_ps`; `% 6` keeps the
            // row indices in bounds (they already are).
            let (n, f) = unsafe {
                (
                    _mm256_load_ps(p[r.near[a] % 6].as_ptr()),
                    _mm256_load_ps(p[r.far[a] % 6].as_ptr()),
                )
            };
            let n = _mm256_mul_ps(_mm256_sub_ps(n, o), inv);
            let f = _mm256_mul_ps(_mm256_sub_ps(f, o), inv);
            // As in the SSE test: NaN slabs leave the accumulators as they are.
            t0 = _mm256_max_ps(n, t0);
            t1 = _mm256_min_ps(f, t1);
        }
        let t1 = _mm256_min_ps(
            _mm256_mul_ps(t1, _mm256_set1_ps(r.scale)),
            _mm256_set1_ps(tmax),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32;
        let mut near = [0f32; WIDTH];
        // SAFETY: `near` is eight writable floats.
        unsafe { _mm256_storeu_ps(near.as_mut_ptr(), t0) };
        (mask, near)
    }

    #[inline(always)]
    pub(super) fn intersect4(s: &Shear4, g: &Tri4, tmin: f32, tmax: f32) -> Hits4 {
        // SAFETY: SSE2 is part of the x86_64 baseline; the only memory accesses are `load` and
        // `store` of whole `[f32; 4]`s.
        unsafe { intersect4_sse(s, g, tmin, tmax) }
    }

    #[inline(always)]
    /// # Safety
    /// SSE2 must be available (it is on every x86_64 CPU).
    unsafe fn intersect4_sse(s: &Shear4, g: &Tri4, tmin: f32, tmax: f32) -> Hits4 {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe {
            let [kx, ky, kz] = s.axis.map(|k| k % 3);
            let (ox, oy, oz) = (
                _mm_set1_ps(s.org[0]),
                _mm_set1_ps(s.org[1]),
                _mm_set1_ps(s.org[2]),
            );
            let (sx, sy, sz) = (_mm_set1_ps(s.sx), _mm_set1_ps(s.sy), _mm_set1_ps(s.sz));
            let v = &g.v;
            // Vertex minus origin along kx, ky, kz, then sheared, as the scalar test does.
            let rel = |i: usize| {
                let x = _mm_sub_ps(load(&v[i][kx]), ox);
                let y = _mm_sub_ps(load(&v[i][ky]), oy);
                let z = _mm_sub_ps(load(&v[i][kz]), oz);
                (
                    _mm_sub_ps(x, _mm_mul_ps(sx, z)),
                    _mm_sub_ps(y, _mm_mul_ps(sy, z)),
                    z,
                )
            };
            let (ax, ay, az) = rel(0);
            let (bx, by, bz) = rel(1);
            let (cx, cy, cz) = rel(2);
            let mut u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let mut w_v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let mut w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zero = _mm_setzero_ps();
            let on_edge = _mm_or_ps(
                _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(w_v, zero)),
                _mm_cmpeq_ps(w, zero),
            );
            let edge_lanes = _mm_movemask_ps(on_edge);
            if edge_lanes != 0 {
                // Rare: redo the lanes with a zero edge function in f64, exactly as the scalar test.
                let (ax, ay, bx, by, cx, cy) = (
                    store(ax),
                    store(ay),
                    store(bx),
                    store(by),
                    store(cx),
                    store(cy),
                );
                let (mut uu, mut vv, mut ww) = (store(u), store(w_v), store(w));
                let d = |p: f32, q: f32, r: f32, t: f32| {
                    (p as f64 * q as f64 - r as f64 * t as f64) as f32
                };
                for k in 0..4 {
                    if edge_lanes & (1 << k) != 0 {
                        uu[k] = d(cx[k], by[k], cy[k], bx[k]);
                        vv[k] = d(ax[k], cy[k], ay[k], cx[k]);
                        ww[k] = d(bx[k], ay[k], by[k], ax[k]);
                    }
                }
                (u, w_v, w) = (load(&uu), load(&vv), load(&ww));
            }
            let v = w_v;
            let neg = _mm_or_ps(
                _mm_or_ps(_mm_cmplt_ps(u, zero), _mm_cmplt_ps(v, zero)),
                _mm_cmplt_ps(w, zero),
            );
            let pos = _mm_or_ps(
                _mm_or_ps(_mm_cmpgt_ps(u, zero), _mm_cmpgt_ps(v, zero)),
                _mm_cmpgt_ps(w, zero),
            );
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let mut reject = _mm_or_ps(_mm_and_ps(neg, pos), _mm_cmpeq_ps(det, zero));
            if _mm_movemask_ps(reject) == 0xF {
                return Hits4 {
                    mask: 0,
                    t: [0.0; 4],
                    u: [0.0; 4],
                    v: [0.0; 4],
                };
            }
            let (az, bz, cz) = (_mm_mul_ps(sz, az), _mm_mul_ps(sz, bz), _mm_mul_ps(sz, cz));
            let t_scaled = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
                _mm_mul_ps(w, cz),
            );
            // Where det < 0, negate both (flip the sign bit, exactly the scalar negation).
            let sign = _mm_and_ps(
                _mm_cmplt_ps(det, zero),
                _mm_castsi128_ps(_mm_set1_epi32(i32::MIN)),
            );
            let t_scaled = _mm_xor_ps(t_scaled, sign);
            let det_abs = _mm_xor_ps(det, sign);
            reject = _mm_or_ps(
                reject,
                _mm_or_ps(
                    _mm_cmplt_ps(t_scaled, _mm_mul_ps(_mm_set1_ps(tmin), det_abs)),
                    _mm_cmpgt_ps(t_scaled, _mm_mul_ps(_mm_set1_ps(tmax), det_abs)),
                ),
            );
            let mask = (_mm_movemask_ps(_mm_andnot_ps(
                reject,
                _mm_castsi128_ps(_mm_set1_epi32(-1)),
            )) & 0xF) as u32;
            let rcp = _mm_div_ps(_mm_set1_ps(1.0), det);
            // `+ 0.0` turns a -0.0 distance into +0.0, as the scalar test does.
            let t = _mm_add_ps(_mm_div_ps(t_scaled, det_abs), zero);
            Hits4 {
                mask,
                t: store(t),
                u: store(_mm_mul_ps(v, rcp)),
                v: store(_mm_mul_ps(w, rcp)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use bytemuck::Zeroable;
    use glam::Vec3;

    use super::*;
    use crate::Rng;

    /// The SIMD lanes equal the scalar tests bit for bit, on small-integer coordinates that put
    /// origins on planes and rays through edges and vertices, with zeros of both signs.
    #[test]
    fn lanes_equal_the_scalar_tests() {
        let seed = crate::testkit::seed(11);
        let mut rng = Rng::new(seed);
        let mut c = |k: u32| -> f32 {
            match rng.below(5) {
                0 => 0.0,
                1 => -0.0,
                _ => (rng.below(2 * k + 1) as f32 - k as f32) * 0.5,
            }
        };
        let (mut box_hits, mut tri_hits) = (0, 0);
        for _ in 0..20_000 {
            let mut node = Node8::zeroed();
            for k in 0..WIDTH {
                for a in 0..3 {
                    let (x, y) = (c(4), c(4));
                    node.planes[a][k] = x.min(y);
                    node.planes[3 + a][k] = x.max(y);
                }
            }
            let mut g = Tri4::zeroed();
            for vertex in 0..3 {
                for axis in 0..3 {
                    for lane in 0..4 {
                        g.v[vertex][axis][lane] = c(3);
                    }
                }
            }
            let ray = Ray::with_range(
                Vec3::new(c(4), c(4), c(4)),
                Vec3::new(c(2), c(2), c(2)),
                c(2).abs(),
                if c(1) == 0.0 { 3.0 } else { f32::INFINITY },
            );
            let br = Box8Ray::new(&ray);
            let (ms, ts) = br.hit8_scalar(&node, ray.tmin, ray.tmax);
            // SAFETY: the SSE kernel needs nothing beyond the baseline.
            let mut kernels = vec![unsafe { br.hit8::<false>(&node, ray.tmin, ray.tmax) }];
            if avx2() {
                // SAFETY: AVX2 was just detected.
                kernels.push(unsafe { br.hit8::<true>(&node, ray.tmin, ray.tmax) });
            }
            for (m, t) in kernels {
                assert_eq!(m, ms, "{ray:?} {node:?} (COBALT_SEED={seed})");
                for k in 0..WIDTH {
                    if m & (1 << k) != 0 {
                        assert_eq!(t[k].to_bits(), ts[k].to_bits(), "{ray:?} {node:?}");
                    }
                }
            }
            box_hits += ms.count_ones();
            let Some(shear) = RayShear::new(ray.origin, ray.dir) else {
                continue;
            };
            let s = Shear4::new(shear);
            let h = s.intersect4(&g, ray.tmin, ray.tmax);
            let hs = s.intersect4_scalar(&g, ray.tmin, ray.tmax);
            assert_eq!(h.mask, hs.mask, "{ray:?} {g:?} (COBALT_SEED={seed})");
            for k in 0..4 {
                if h.mask & (1 << k) != 0 {
                    let bits = |h: &Hits4| [h.t[k], h.u[k], h.v[k]].map(f32::to_bits);
                    assert_eq!(bits(&h), bits(&hs), "{ray:?} {g:?} (COBALT_SEED={seed})");
                }
            }
            tri_hits += h.mask.count_ones();
        }
        // Both outcomes are exercised, not just misses.
        assert!(
            box_hits > 10_000 && tri_hits > 2_000,
            "{box_hits} {tri_hits}"
        );
    }
}
