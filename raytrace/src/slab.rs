//! The ray/box (slab) test, conservative after Ize ("Robust BVH Ray Traversal", JCGT 2013):
//! the far distance is scaled by `1 + 2 gamma(3)` so rounding never culls a box the ray
//! touches. Zero direction components (either sign) give infinite inverse directions; where
//! that meets an origin exactly on a slab plane (`0 * inf = NaN`) the NaN is ignored, treating
//! the closed slab as containing the ray.
//!
//! Traversal tests a node's two children together ([`BoxRay::hit_pair`]); on x86_64 that is
//! one SSE2 pass over both boxes (SSE2 is part of the x86_64 baseline, so no detection is
//! needed), elsewhere two scalar tests. Both give bit-identical results: the same operations
//! in the same order, lane by lane.

use crate::spawn::gamma;
use crate::{Node, Ray};

/// Ize's scale of the far distance: `1 + 2 gamma(3)`.
pub(crate) fn far_scale() -> f32 {
    1.0 + 2.0 * gamma(3)
}

/// `max` that keeps `acc` when `x` is NaN (one `maxss` on x86, like `_mm_max_ps(x, acc)`).
#[inline(always)]
fn max_keep(acc: f32, x: f32) -> f32 {
    if x > acc { x } else { acc }
}

/// `min` that keeps `acc` when `x` is NaN.
#[inline(always)]
fn min_keep(acc: f32, x: f32) -> f32 {
    if x < acc { x } else { acc }
}

/// The per-ray part of the box test, computed once per ray.
#[derive(Clone, Copy)]
pub(crate) struct BoxRay {
    org: [f32; 3],
    inv: [f32; 3],
    /// Index of the near plane in a node viewed as `[f32; 8]` (`min` at 0..3, `max` at 4..7).
    near: [usize; 3],
    scale: f32,
    #[cfg(target_arch = "x86_64")]
    lanes: sse::Lanes,
}

impl BoxRay {
    #[inline(always)]
    pub(crate) fn new(r: &Ray) -> Self {
        let d = r.dir.to_array();
        let sel = |k: usize| if d[k].is_sign_negative() { 4 + k } else { k };
        let org = r.origin.to_array();
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        Self {
            org,
            inv,
            near: [sel(0), sel(1), sel(2)],
            scale: far_scale(),
            #[cfg(target_arch = "x86_64")]
            lanes: sse::Lanes::new(org, inv, d.map(f32::is_sign_negative), far_scale()),
        }
    }

    /// Entry distance if the ray meets the node's box within `[tmin, tmax]`.
    #[inline(always)]
    pub(crate) fn hit(&self, node: &Node, tmin: f32, tmax: f32) -> Option<f32> {
        let b: &[f32; 8] = bytemuck::cast_ref(node);
        let (o, inv, n) = (&self.org, &self.inv, &self.near);
        // `& 7` proves the index in bounds (it already is), so no check is emitted.
        let tx0 = (b[n[0] & 7] - o[0]) * inv[0];
        let ty0 = (b[n[1] & 7] - o[1]) * inv[1];
        let tz0 = (b[n[2] & 7] - o[2]) * inv[2];
        let t0 = max_keep(max_keep(max_keep(tmin, tx0), ty0), tz0);
        (t0 <= self.exit(node, tmax)).then_some(t0)
    }

    /// Where the ray leaves the node's box, clipped to `tmax`: [`BoxRay::hit`]'s far end (the
    /// first-leaf walk ends a ray there).
    #[inline(always)]
    pub(crate) fn exit(&self, node: &Node, tmax: f32) -> f32 {
        let b: &[f32; 8] = bytemuck::cast_ref(node);
        let (o, inv, n) = (&self.org, &self.inv, &self.near);
        // `n[k] ^ 4` flips from the near to the far plane of axis k.
        let tx1 = (b[(n[0] ^ 4) & 7] - o[0]) * inv[0];
        let ty1 = (b[(n[1] ^ 4) & 7] - o[1]) * inv[1];
        let tz1 = (b[(n[2] ^ 4) & 7] - o[2]) * inv[2];
        let t1 = min_keep(min_keep(min_keep(f32::INFINITY, tx1), ty1), tz1) * self.scale;
        if t1 < tmax { t1 } else { tmax }
    }

    /// Sign bits of the ray's direction, per axis.
    #[inline(always)]
    pub(crate) fn negative(&self) -> [bool; 3] {
        self.near.map(|n| n >= 4)
    }

    /// [`BoxRay::hit`] of two sibling nodes.
    #[inline(always)]
    pub(crate) fn hit_pair(&self, pair: &[Node; 2], tmin: f32, tmax: f32) -> [Option<f32>; 2] {
        #[cfg(target_arch = "x86_64")]
        {
            self.lanes.hit_pair(pair, tmin, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            [
                self.hit(&pair[0], tmin, tmax),
                self.hit(&pair[1], tmin, tmax),
            ]
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod sse {
    use std::arch::x86_64::{
        __m128, _mm_and_ps, _mm_castsi128_ps, _mm_cmple_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps,
        _mm_movehl_ps, _mm_movemask_ps, _mm_mul_ps, _mm_set_epi32, _mm_set_ps, _mm_set1_ps,
        _mm_storeu_ps, _mm_sub_ps, _mm_unpackhi_ps, _mm_unpacklo_ps, _mm_xor_ps,
    };

    use crate::Node;

    /// The ray in SSE lanes `(x, y, z, 0)`.
    #[derive(Clone, Copy)]
    pub(super) struct Lanes {
        org: __m128,
        inv: __m128,
        /// All ones in the lanes whose direction has its sign bit set: there the near plane is
        /// the box's max, so min and max swap.
        swap: __m128,
        /// All ones in lanes x, y, z: lane 3 holds a node's index or count, whose bits are
        /// mostly denormal floats, and arithmetic on denormals is microcoded (~100× slower).
        xyz: __m128,
        scale: __m128,
    }

    impl Lanes {
        #[inline(always)]
        pub(super) fn new(org: [f32; 3], inv: [f32; 3], negative: [bool; 3], scale: f32) -> Self {
            let m = |b: bool| if b { -1 } else { 0 };
            // SAFETY: SSE2 is part of the x86_64 baseline; these only build registers.
            unsafe {
                Self {
                    org: _mm_set_ps(0.0, org[2], org[1], org[0]),
                    inv: _mm_set_ps(0.0, inv[2], inv[1], inv[0]),
                    swap: _mm_castsi128_ps(_mm_set_epi32(
                        0,
                        m(negative[2]),
                        m(negative[1]),
                        m(negative[0]),
                    )),
                    xyz: _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1)),
                    scale: _mm_set1_ps(scale),
                }
            }
        }

        #[inline(always)]
        pub(super) fn hit_pair(&self, pair: &[Node; 2], tmin: f32, tmax: f32) -> [Option<f32>; 2] {
            let p = pair.as_ptr().cast::<f32>();
            // SAFETY: SSE2 is part of the x86_64 baseline. `pair` is 64 bytes of `f32`-sized
            // Pod fields (`Node` is `repr(C)`: min, index, max, count), and the four unaligned
            // loads read bytes 0..16, 16..32, 32..48 and 48..64 of it.
            unsafe {
                let m = self.xyz;
                let (lo_l, hi_l) = (_mm_loadu_ps(p), _mm_loadu_ps(p.add(4)));
                let (lo_l, hi_l) = (_mm_and_ps(lo_l, m), _mm_and_ps(hi_l, m));
                let (lo_r, hi_r) = (_mm_loadu_ps(p.add(8)), _mm_loadu_ps(p.add(12)));
                let (lo_r, hi_r) = (_mm_and_ps(lo_r, m), _mm_and_ps(hi_r, m));
                // near = swap ? max : min, far = swap ? min : max, by xor-ing in the difference.
                let xl = _mm_and_ps(_mm_xor_ps(lo_l, hi_l), self.swap);
                let xr = _mm_and_ps(_mm_xor_ps(lo_r, hi_r), self.swap);
                let tn_l = _mm_mul_ps(_mm_sub_ps(_mm_xor_ps(lo_l, xl), self.org), self.inv);
                let tf_l = _mm_mul_ps(_mm_sub_ps(_mm_xor_ps(hi_l, xl), self.org), self.inv);
                let tn_r = _mm_mul_ps(_mm_sub_ps(_mm_xor_ps(lo_r, xr), self.org), self.inv);
                let tf_r = _mm_mul_ps(_mm_sub_ps(_mm_xor_ps(hi_r, xr), self.org), self.inv);
                // `max_ps(x, acc)` returns `acc` where `x` is NaN: NaN slabs are ignored, as in
                // the scalar `max_keep`/`min_keep`.
                let (lo, inf) = (_mm_set1_ps(tmin), _mm_set1_ps(f32::INFINITY));
                let (tn_l, tn_r) = (_mm_max_ps(tn_l, lo), _mm_max_ps(tn_r, lo));
                let (tf_l, tf_r) = (_mm_min_ps(tf_l, inf), _mm_min_ps(tf_r, inf));
                // Reduce x, y, z of each box: left in lane 0, right in lane 1.
                let n01 = _mm_unpacklo_ps(tn_l, tn_r); // lx rx ly ry
                let n2 = _mm_unpackhi_ps(tn_l, tn_r); // lz rz . .
                let near = _mm_max_ps(_mm_max_ps(n01, _mm_movehl_ps(n01, n01)), n2);
                let f01 = _mm_unpacklo_ps(tf_l, tf_r);
                let f2 = _mm_unpackhi_ps(tf_l, tf_r);
                let far = _mm_min_ps(_mm_min_ps(f01, _mm_movehl_ps(f01, f01)), f2);
                let far = _mm_min_ps(_mm_mul_ps(far, self.scale), _mm_set1_ps(tmax));
                let mask = _mm_movemask_ps(_mm_cmple_ps(near, far));
                let mut t = [0f32; 4];
                _mm_storeu_ps(t.as_mut_ptr(), near);
                [
                    (mask & 1 != 0).then_some(t[0]),
                    (mask & 2 != 0).then_some(t[1]),
                ]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::Rng;

    fn node(min: [f32; 3], max: [f32; 3]) -> Node {
        Node {
            min,
            index: 2,
            max,
            count: 0,
        }
    }

    /// The paired (SSE) test equals two scalar tests bit for bit, including zero and negative
    /// zero directions and origins on slab planes.
    #[test]
    fn pair_test_equals_scalar_test() {
        let mut rng = Rng::new(crate::testkit::seed(7));
        let mut pick = Rng::new(crate::testkit::seed(7) ^ 1);
        let mut c = |k: u32| -> f32 {
            // Small integers make origins land exactly on planes; zeros of both signs appear.
            match rng.below(4) {
                0 => 0.0,
                1 => -0.0,
                _ => (rng.below(2 * k + 1) as f32 - k as f32) * 0.5,
            }
        };
        let mut hits = 0;
        for _ in 0..20_000 {
            let a = [c(4), c(4), c(4)];
            let b = [c(4), c(4), c(4)];
            let (lo, hi) = (
                [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])],
                [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])],
            );
            let pair = [node(lo, hi), node([c(2), c(2), c(2)], [c(3).abs(); 3])];
            let ray = Ray::with_range(
                Vec3::new(c(4), c(4), c(4)),
                Vec3::new(c(2), c(2), c(2)),
                c(2).abs(),
                [f32::INFINITY, 3.0][pick.below(2) as usize],
            );
            let br = BoxRay::new(&ray);
            let want = [
                br.hit(&pair[0], ray.tmin, ray.tmax),
                br.hit(&pair[1], ray.tmin, ray.tmax),
            ];
            let got = br.hit_pair(&pair, ray.tmin, ray.tmax);
            hits += got.iter().flatten().count();
            assert_eq!(
                want.map(|o| o.map(f32::to_bits)),
                got.map(|o| o.map(f32::to_bits)),
                "{ray:?} {pair:?}"
            );
        }
        // Both outcomes are exercised, not just misses.
        assert!(
            (5_000..35_000).contains(&hits),
            "{hits} hits of 40000 tests"
        );
    }
}
