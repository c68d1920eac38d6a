//! Lane kernels of the wide traversal: the conservative box test of a node's eight children
//! ([`Box8Ray::hit8`]), the watertight test of four or eight triangles
//! ([`Shear4::intersect4`], [`Shear4::intersect8`]; for a packet's rays, eight triangles whose
//! vertices less the rays' origin are taken once, [`Shear4::intersect8_rel`], and four
//! triangles by two rays, [`Shear4::intersect_two`]), and a leaf's triangles tested with them
//! ([`leaf_hits`]).
//!
//! Each lane does exactly what the scalar tests do ([`crate::slab`] and
//! [`crate::intersect_watertight`]): the same IEEE operations in the same order, with no fused
//! multiply-add, so every lane's result equals the scalar one bit for bit (tests below check
//! it). On x86_64 the box test is one AVX2 pass where the CPU has AVX2 (the caller detects it,
//! see [`avx2`]) and two SSE2 passes otherwise; the four-triangle test is SSE2 (part of the
//! x86_64 baseline, so it needs no detection), and the eight-triangle one, which tests a leaf's
//! two groups in one pass, AVX2. Elsewhere they are loops over arrays.
//!
//! The triangle tests leave the divisions to [`TriHits::hit`], lane by lane: only the lanes
//! that hit need their distance, and most groups have none or one, so dividing every lane
//! would cost two vector divisions per group for nothing.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::__m256;

use crate::bvh::wide::{Node8, Tri4, WIDTH};
use crate::ray::{Hit, Ray};
use crate::slab::far_scale;
use crate::traverse::closest::better;
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

/// Floats in a row of box planes.
const ROW: u32 = WIDTH as u32;

/// The per-ray part of the eight-box test: 64 bytes, two AVX2 stores
/// ([`Box8Ray::set8`] writes eight at a time).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(crate) struct Box8Ray {
    org: [f32; 3],
    inv: [f32; 3],
    /// Where the plane row of the near side starts per axis, in floats from the first row of
    /// [`Node8::planes`] (the row times [`WIDTH`]): the eight-lane test loads it at that offset
    /// without scaling the row first, once for each box test of each ray.
    near: [u32; 3],
    far: [u32; 3],
    scale: f32,
    pad: [f32; 3],
}

const _: () = assert!(size_of::<Box8Ray>() == 64);

/// The box test's answer: a bit per child whose box the ray meets, and each child's entry
/// distance (meaningful where the bit is set).
pub(crate) type Hits8 = (u32, [f32; WIDTH]);

impl Box8Ray {
    /// A placeholder, to be overwritten before it is read.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(crate) const ZERO: Self = Self {
        org: [0.0; 3],
        inv: [0.0; 3],
        near: [0; 3],
        far: [0; 3],
        scale: 0.0,
        pad: [0.0; 3],
    };

    #[inline(always)]
    pub(crate) fn new(r: &Ray) -> Self {
        let d = r.dir.to_array();
        let neg = d.map(f32::is_sign_negative);
        Self {
            org: r.origin.to_array(),
            inv: [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]],
            near: [0u32, 1, 2].map(|a| ROW * if neg[a as usize] { 3 + a } else { a }),
            far: [0u32, 1, 2].map(|a| ROW * if neg[a as usize] { a } else { 3 + a }),
            scale: far_scale(),
            pad: [0.0; 3],
        }
    }

    /// The set-ups [`Box8Ray::new`] makes of eight rays, from their parts by lane: the
    /// origins, `1 / dir`, and where each axis's near and far plane rows start, in floats
    /// (bits, in float lanes). `crate::traverse::lanes` makes them eight at a time; here they
    /// are turned from lanes into rays, two 8 × 8 transposes.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn set8(
        out: &mut [Box8Ray; 8],
        org: [__m256; 3],
        inv: [__m256; 3],
        near: [__m256; 3],
        far: [__m256; 3],
    ) {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { x86::set8_avx2(out, org, inv, near, far) }
    }

    /// Every field's bits, for tests that compare set-ups.
    #[cfg(test)]
    pub(crate) fn bits(&self) -> Vec<u32> {
        let f = self.org.iter().chain(&self.inv).chain([&self.scale]);
        let rows = self.near.iter().chain(&self.far).map(|&r| r / ROW);
        f.map(|x| x.to_bits()).chain(rows).collect()
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
                let n = (p[(self.near[a] / ROW) as usize][k] - self.org[a]) * self.inv[a];
                let f = (p[(self.far[a] / ROW) as usize][k] - self.org[a]) * self.inv[a];
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

/// A node's box planes less a point, by row as in [`Node8::planes`]: the first step of the
/// box test of every ray from that point, taken once for all of them ([`packet_node`]).
#[repr(C, align(32))]
pub(crate) struct Planes8([[f32; WIDTH]; 6]);

impl Planes8 {
    /// The rows, as [`Node8::planes`] holds a node's own.
    pub(crate) fn rows(&self) -> &[[f32; WIDTH]; 6] {
        &self.0
    }
}

/// `node`'s planes less `org` ([`Planes8`]).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn relative(node: &Node8, org: &[f32; 3]) -> Planes8 {
    // SAFETY: the caller has checked that the CPU has AVX2 (see `# Safety`).
    unsafe { x86::relative_avx2(node, org) }
}

/// A packet's test of one node's eight children: the children any ray hits (`kids`), the
/// rays that hit each (`cols[k]`, a bit per ray) and, where asked, each child's nearest entry
/// over those rays (`near`, as bits: non-negative floats order as their bits).
pub(crate) struct PacketHits {
    pub(crate) kids: u32,
    pub(crate) cols: [u32; WIDTH],
    pub(crate) near: [f32; WIDTH],
}

/// Every ray of `rays` (a bit per ray of `boxes`) tested against the eight boxes whose planes
/// are `p` (with `SUB`, a node's own planes; without, its planes less the rays' origin,
/// [`relative`]: with `APART`, `p[g]` for the rays of group `g` of eight lanes, else `p[0]` for
/// all), each with its own `[tmin, bound]`: each ray's [`Box8Ray::hit8`], bit for bit,
/// gathered by child in vector lanes instead of a mask per ray. `NEAR` folds the entries.
///
/// # Safety
/// The CPU must have AVX2; without `SUB`, the planes a ray reads must be taken from its
/// origin.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn packet_node<
    const SUB: bool,
    const APART: bool,
    const NEAR: bool,
    const N: usize,
    const G: usize,
>(
    boxes: &[Box8Ray; N],
    rays: u32,
    p: [&[[f32; WIDTH]; 6]; G],
    tmin: &[f32; N],
    bound: &[f32; N],
) -> PacketHits {
    const {
        assert!(
            N <= 32 && G * 8 >= N,
            "a bit per ray, a set of planes per eight"
        )
    };
    // SAFETY: as the caller states (see `# Safety`).
    unsafe { x86::packet_node_avx2::<SUB, APART, NEAR, N, G>(boxes, rays, p, tmin, bound) }
}

/// The slot of the nearest child among those `mask` sets (the first slot on a tie); `mask`
/// must not be empty. Where AVX2 runs, one pass over the eight entry distances: the scalar
/// loop's compares branch on the distances, which an incoherent ray mispredicts about once a
/// node.
///
/// # Safety
/// With `AVX2`, the CPU must have AVX2.
#[inline(always)]
pub(crate) unsafe fn nearest<const AVX2: bool>(mask: u32, near: &[f32; WIDTH]) -> usize {
    #[cfg(target_arch = "x86_64")]
    if AVX2 {
        // SAFETY: the caller has checked that the CPU has AVX2 (see `# Safety`).
        return unsafe { x86::nearest_avx2(mask, near) };
    }
    nearest_scalar(mask, near)
}

/// The lanes whose `bound` is at or beyond `t`, as a bit each: the rays of a packet whose
/// nearest hit so far does not rule out a node entered at `t`.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn within<const N: usize>(t: f32, bound: &[f32; N]) -> u32 {
    const {
        assert!(
            N <= 32 && N.is_multiple_of(8),
            "a bit per ray, eight lanes a step"
        )
    };
    // SAFETY: the caller has checked that the CPU has AVX2 (see `# Safety`).
    unsafe { x86::within_avx2(t, bound) }
}

/// [`nearest`] slot by slot.
#[inline(always)]
pub(crate) fn nearest_scalar(mask: u32, near: &[f32; WIDTH]) -> usize {
    let mut b = mask.trailing_zeros() as usize;
    let mut m = mask & (mask - 1);
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        if near[k] < near[b] {
            b = k;
        }
    }
    b
}

/// The per-ray part of the four-triangle test: [`RayShear`]'s axes and shear.
#[derive(Clone, Copy)]
pub(crate) struct Shear4 {
    /// Origin along `kx`, `ky`, `kz`.
    org: [f32; 3],
    /// `kx`, `ky`, `kz`; bytes, so that a packet's eight set-ups stay small.
    axis: [u8; 3],
    sx: f32,
    sy: f32,
    sz: f32,
}

/// Hits of `N` triangles: a bit per lane that hits, and what [`TriHits::hit`] needs to give the
/// distance and barycentrics of a lane (the scalar test's values before its divisions).
pub(crate) struct TriHits<const N: usize> {
    pub(crate) mask: u32,
    /// The scaled distance, its sign flipped where `det < 0`.
    t_scaled: [f32; N],
    det: [f32; N],
    /// The edge functions of the second and third vertex.
    v: [f32; N],
    w: [f32; N],
}

impl<const N: usize> TriHits<N> {
    const MISS: Self = Self {
        mask: 0,
        t_scaled: [0.0; N],
        det: [0.0; N],
        v: [0.0; N],
        w: [0.0; N],
    };

    /// `(t, u, v)` of lane `k`, whose bit is set: the scalar test's divisions, so the same bits.
    #[inline(always)]
    pub(crate) fn hit(&self, k: usize) -> (f32, f32, f32) {
        let det = self.det[k];
        let rcp = 1.0 / det;
        // `abs` is the scalar test's negation where `det < 0` (a hit's `det` is never zero or
        // NaN). `+ 0.0` turns a -0.0 distance into +0.0, as the scalar test does.
        (
            self.t_scaled[k] / det.abs() + 0.0,
            self.v[k] * rcp,
            self.w[k] * rcp,
        )
    }
}

/// Two triangle groups' vertices less one origin, by vertex, axis and lane (the first group in
/// lanes 0–3): the first step of the triangle test of every ray from that origin, taken once
/// for all of them ([`Shear4::intersect8_rel`]). The subtraction is the test's own, so each ray
/// gets the bits it would get alone.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Rel8 {
    rows: [[[f32; 8]; 3]; 3],
}

#[cfg(target_arch = "x86_64")]
impl Rel8 {
    /// The vertices of `a` and `b` less `org`.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[inline(always)]
    pub(crate) unsafe fn new(a: &Tri4, b: &Tri4, org: &[f32; 3]) -> Self {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { x86::rel8_avx2(a, b, org) }
    }
}

impl Shear4 {
    #[inline(always)]
    pub(crate) fn new(s: RayShear) -> Self {
        let (org, [kx, ky, kz], [sx, sy, sz]) = s.parts();
        Self {
            org: [org[kx], org[ky], org[kz]],
            axis: [kx, ky, kz].map(|k| k as u8),
            sx,
            sy,
            sz,
        }
    }

    /// The set-up [`Shear4::new`] makes, from its parts: the origin along `kx`, `ky`, `kz`,
    /// those axes, and `sx`, `sy`, `sz`.
    #[inline(always)]
    pub(crate) fn from_parts(org: [f32; 3], axis: [u32; 3], [sx, sy, sz]: [f32; 3]) -> Self {
        Self {
            org,
            axis: axis.map(|k| k as u8),
            sx,
            sy,
            sz,
        }
    }

    /// `kx`, `ky`, `kz` as indices below 3 (as they are), so that rows index without checks.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    #[inline(always)]
    fn axes(&self) -> [usize; 3] {
        self.axis.map(|k| usize::from(k).min(2))
    }

    /// Every field's bits, for tests that compare set-ups.
    #[cfg(test)]
    pub(crate) fn bits(&self) -> Vec<u32> {
        let f = self.org.iter().chain([&self.sx, &self.sy, &self.sz]);
        let axes = self.axis.iter().map(|&k| u32::from(k));
        f.map(|x| x.to_bits()).chain(axes).collect()
    }

    /// [`crate::intersect_watertight`] of the four triangles of `g`, lane by lane.
    #[inline(always)]
    pub(crate) fn intersect4(&self, g: &Tri4, tmin: f32, tmax: f32) -> TriHits<4> {
        #[cfg(target_arch = "x86_64")]
        {
            x86::intersect4(self, g, tmin, tmax)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.intersect4_scalar(g, tmin, tmax)
        }
    }

    /// [`Shear4::intersect4`] of two groups at once, `a` in lanes 0–3 and `b` in lanes 4–7, in
    /// one AVX2 pass, inlined where the caller is compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn intersect8(&self, a: &Tri4, b: &Tri4, tmin: f32, tmax: f32) -> TriHits<8> {
        // SAFETY: the caller has checked that the CPU has AVX2 (see `# Safety`).
        unsafe { x86::intersect8_avx2(self, a, b, tmin, tmax) }
    }

    /// [`Shear4::intersect4`] of one group by two rays in one AVX2 pass: this ray's in lanes
    /// 0–3, `other`'s in 4–7, each with its own range (`tmin`, `tmax`: this ray's, then the
    /// other's).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn intersect_two(
        &self,
        other: &Shear4,
        g: &Tri4,
        tmin: [f32; 2],
        tmax: [f32; 2],
    ) -> TriHits<8> {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { x86::intersect_two_avx2(self, other, g, tmin, tmax) }
    }

    /// [`Shear4::intersect8`] of the groups whose vertices less this ray's origin are `rel`.
    ///
    /// # Safety
    /// The CPU must have AVX2, and `rel` be taken from this ray's origin, bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn intersect8_rel(&self, rel: &Rel8, tmin: f32, tmax: f32) -> TriHits<8> {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { x86::intersect8_rel_avx2(self, rel, tmin, tmax) }
    }

    /// [`Shear4::intersect4`] by calling the scalar test per lane.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    pub(crate) fn intersect4_scalar(&self, g: &Tri4, tmin: f32, tmax: f32) -> TriHits<4> {
        let mut h = TriHits::MISS;
        let axis = self.axis.map(usize::from);
        let mut org = [0f32; 3];
        for (j, &k) in axis.iter().enumerate() {
            org[k] = self.org[j];
        }
        let shear = RayShear::from_parts(org, axis, [self.sx, self.sy, self.sz]);
        let vert = |i: usize, k: usize| [g.v[i][0][k], g.v[i][1][k], g.v[i][2][k]];
        for k in 0..4 {
            let (a, b, c) = (vert(0, k), vert(1, k), vert(2, k));
            if let Some(p) = crate::triangle::intersect_parts(&shear, &a, &b, &c, tmin, tmax) {
                h.mask |= 1 << k;
                (h.t_scaled[k], h.det[k], h.v[k], h.w[k]) = p;
            }
        }
        h
    }
}

/// Tests a ray against a leaf's `count` triangles (its groups `leaf`) within `[tmin, tmax]`,
/// folding the hits into `best` as every walk does (the smallest `(t, primitive id)`; with
/// `any`, the first hit found, lowest group then lowest lane, ends the test). Returns whether
/// `best` changed, and the triangles tested (the walk's `T`: the groups tested, not the
/// repeats that fill the last one). With `AVX2`, two groups are tested in one eight-lane pass,
/// for the cost of one. A lane that hits pays for the divisions only if it is kept.
///
/// # Safety
/// With `AVX2`, the CPU must have AVX2.
#[inline(always)]
pub(crate) unsafe fn leaf_hits<const AVX2: bool>(
    any: bool,
    shear: &Shear4,
    leaf: &[Tri4],
    tmin: f32,
    tmax: f32,
    count: u32,
    best: &mut Option<Hit>,
) -> (bool, u32) {
    let (mut changed, mut tested) = (false, 0);
    let n = leaf.len();
    let mut j = 0;
    while j < n {
        #[cfg(target_arch = "x86_64")]
        if AVX2 && j + 1 < n {
            let (a, b) = (&leaf[j], &leaf[j + 1]);
            tested += (count - 4 * j as u32).min(8);
            // SAFETY: as the caller states (see `# Safety`).
            let h = unsafe { shear.intersect8(a, b, tmin, tmax) };
            if fold(any, &h, u32::MAX, |k| pair_prim(a, b, k), best) {
                changed = true;
                if any {
                    return (changed, tested);
                }
            }
            j += 2;
            continue;
        }
        let g = &leaf[j];
        tested += (count - 4 * j as u32).min(4);
        let h = shear.intersect4(g, tmin, tmax);
        if fold(any, &h, u32::MAX, |k| g.prim[k], best) {
            changed = true;
            if any {
                return (changed, tested);
            }
        }
        j += 1;
    }
    (changed, tested)
}

/// Folds the lanes of `h` among `lanes` that hit into `best` as every walk does (the smallest
/// `(t, primitive id)`, `prim` giving a lane's id; with `any`, the first hit, lowest lane,
/// ends it), and returns whether `best` changed. A lane pays for its divisions only here.
#[inline(always)]
pub(crate) fn fold<const N: usize>(
    any: bool,
    h: &TriHits<N>,
    lanes: u32,
    prim: impl Fn(usize) -> u32,
    best: &mut Option<Hit>,
) -> bool {
    let mut changed = false;
    let mut m = h.mask & lanes;
    while m != 0 {
        let k = m.trailing_zeros() as usize;
        m &= m - 1;
        let (t, u, v) = h.hit(k);
        let prim = prim(k);
        if better(t, prim, *best) {
            *best = Some(Hit { t, prim, u, v });
            changed = true;
            if any {
                break;
            }
        }
    }
    changed
}

/// The primitive id of lane `k` of two groups tested side by side, `a` in lanes 0–3.
#[inline(always)]
pub(crate) fn pair_prim(a: &Tri4, b: &Tri4, k: usize) -> u32 {
    if k < 4 { a.prim[k] } else { b.prim[k % 4] }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use x86::transpose8;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::{
        __m128, __m256, __m256i, _CMP_EQ_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm_add_ps,
        _mm_and_ps, _mm_andnot_ps, _mm_castsi128_ps, _mm_cmpeq_ps, _mm_cmpgt_ps, _mm_cmple_ps,
        _mm_cmplt_ps, _mm_load_ps, _mm_loadu_ps, _mm_max_ps, _mm_min_ps, _mm_movemask_ps,
        _mm_mul_ps, _mm_or_ps, _mm_set1_epi32, _mm_set1_ps, _mm_setzero_ps, _mm_storeu_ps,
        _mm_sub_ps, _mm_xor_ps, _mm256_add_ps, _mm256_and_ps, _mm256_and_si256, _mm256_andnot_ps,
        _mm256_andnot_si256, _mm256_castps_si256, _mm256_castsi256_ps, _mm256_cmp_ps,
        _mm256_cmpeq_epi32, _mm256_cvtsi256_si32, _mm256_load_ps, _mm256_loadu_ps,
        _mm256_loadu_si256, _mm256_max_ps, _mm256_min_epu32, _mm256_min_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_or_ps, _mm256_or_si256, _mm256_permute2f128_ps,
        _mm256_permute2x128_si256, _mm256_set_m128, _mm256_set1_epi32, _mm256_set1_ps,
        _mm256_setr_epi32, _mm256_setzero_ps, _mm256_setzero_si256, _mm256_shuffle_epi32,
        _mm256_shuffle_ps, _mm256_store_ps, _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_ps,
        _mm256_unpackhi_ps, _mm256_unpacklo_ps, _mm256_xor_ps,
    };

    use super::{Box8Ray, Hits8, PacketHits, Planes8, ROW, Rel8, Shear4, TriHits, WIDTH};
    use crate::bvh::wide::{Node8, Tri4};
    use crate::slab::far_scale;

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
                    let (near, far) = ((r.near[a] / ROW) as usize, (r.far[a] / ROW) as usize);
                    let n = _mm_load_ps(p[near % 6][lanes.clone()].as_ptr());
                    let f = _mm_load_ps(p[far % 6][lanes.clone()].as_ptr());
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
        // SAFETY: as the caller states (see `# Safety`).
        let (hit, t0) = unsafe { slab_lanes_avx2::<true>(r, &node.planes, tmin, tmax) };
        let mut near = [0f32; WIDTH];
        // SAFETY: `near` is eight writable floats.
        unsafe { _mm256_storeu_ps(near.as_mut_ptr(), t0) };
        (_mm256_movemask_ps(hit) as u32, near)
    }

    /// [`super::relative`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn relative_avx2(node: &Node8, org: &[f32; 3]) -> Planes8 {
        let mut rel = Planes8([[0.0; WIDTH]; 6]);
        for (row, (out, p)) in rel.0.iter_mut().zip(&node.planes).enumerate() {
            // SAFETY: both rows are 32-byte aligned runs of eight floats (`Node8` and
            // `Planes8` are aligned so).
            unsafe {
                let d = _mm256_sub_ps(_mm256_load_ps(p.as_ptr()), _mm256_set1_ps(org[row % 3]));
                _mm256_store_ps(out.as_mut_ptr(), d);
            }
        }
        rel
    }

    /// The slab test of eight boxes, their planes `p` by row as in [`Node8::planes`]: with
    /// `SUB` the planes themselves, less the ray's origin here; without, already less it.
    /// Returns the lanes hit (all ones) and the entry distances, in registers.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    unsafe fn slab_lanes_avx2<const SUB: bool>(
        r: &Box8Ray,
        p: &[[f32; WIDTH]; 6],
        tmin: f32,
        tmax: f32,
    ) -> (__m256, __m256) {
        let mut t0 = _mm256_set1_ps(tmin);
        let mut t1 = _mm256_set1_ps(f32::INFINITY);
        for a in 0..3 {
            let (o, inv) = (_mm256_set1_ps(r.org[a]), _mm256_set1_ps(r.inv[a]));
            // SAFETY: `Node8` and `Planes8` are aligned to 32 bytes or more and their rows are
            // 32 bytes each, so every row is a 32-byte aligned run of eight floats for
            // `_mm256_load_ps`. `Box8Ray` holds row starts (a row below 6 times `ROW`) only.
            // Unchecked rather than `% 6`: where the ray's part is not hoisted out of the walk
            // (rays walked together), the remainders were six multiplications a test.
            let (n, f) = unsafe {
                let first = p.as_ptr().cast::<f32>();
                (
                    _mm256_load_ps(first.add(r.near[a] as usize)),
                    _mm256_load_ps(first.add(r.far[a] as usize)),
                )
            };
            let (n, f) = if SUB {
                (_mm256_sub_ps(n, o), _mm256_sub_ps(f, o))
            } else {
                (n, f)
            };
            let n = _mm256_mul_ps(n, inv);
            let f = _mm256_mul_ps(f, inv);
            // As in the SSE test: NaN slabs leave the accumulators as they are.
            t0 = _mm256_max_ps(n, t0);
            t1 = _mm256_min_ps(f, t1);
        }
        let t1 = _mm256_min_ps(
            _mm256_mul_ps(t1, _mm256_set1_ps(r.scale)),
            _mm256_set1_ps(tmax),
        );
        (_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1), t0)
    }

    /// Eight rows of eight lanes turned into eight rows of eight: `out[i]` holds lane `i` of
    /// every row, in row order.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
        let t = [
            _mm256_unpacklo_ps(r[0], r[1]),
            _mm256_unpackhi_ps(r[0], r[1]),
            _mm256_unpacklo_ps(r[2], r[3]),
            _mm256_unpackhi_ps(r[2], r[3]),
            _mm256_unpacklo_ps(r[4], r[5]),
            _mm256_unpackhi_ps(r[4], r[5]),
            _mm256_unpacklo_ps(r[6], r[7]),
            _mm256_unpackhi_ps(r[6], r[7]),
        ];
        let u = [
            _mm256_shuffle_ps::<0x44>(t[0], t[2]),
            _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
            _mm256_shuffle_ps::<0x44>(t[1], t[3]),
            _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
            _mm256_shuffle_ps::<0x44>(t[4], t[6]),
            _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
            _mm256_shuffle_ps::<0x44>(t[5], t[7]),
            _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
        ];
        [
            _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
            _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
            _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
            _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
            _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
        ]
    }

    /// [`Box8Ray::set8`].
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn set8_avx2(
        out: &mut [Box8Ray; 8],
        org: [__m256; 3],
        inv: [__m256; 3],
        near: [__m256; 3],
        far: [__m256; 3],
    ) {
        let scale = _mm256_set1_ps(far_scale());
        let zero = _mm256_setzero_ps();
        // The first 32 bytes of each ray (`org`, `inv`, two `near` rows), then the rest.
        let lo = transpose8([
            org[0], org[1], org[2], inv[0], inv[1], inv[2], near[0], near[1],
        ]);
        let hi = transpose8([near[2], far[0], far[1], far[2], scale, zero, zero, zero]);
        for (b, (lo, hi)) in out.iter_mut().zip(lo.into_iter().zip(hi)) {
            let at = (b as *mut Box8Ray).cast::<f32>();
            // SAFETY: `Box8Ray` is `repr(C)`, 64 bytes aligned to 32, of plain 4-byte fields in
            // this order, so its two aligned halves take any bits.
            unsafe {
                _mm256_store_ps(at, lo);
                _mm256_store_ps(at.add(8), hi);
            }
        }
    }

    /// [`super::packet_node`].
    ///
    /// # Safety
    /// As [`super::packet_node`] states.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn packet_node_avx2<
        const SUB: bool,
        const APART: bool,
        const NEAR: bool,
        const N: usize,
        const G: usize,
    >(
        boxes: &[Box8Ray; N],
        rays: u32,
        p: [&[[f32; WIDTH]; 6]; G],
        tmin: &[f32; N],
        bound: &[f32; N],
    ) -> PacketHits {
        let mut cols = _mm256_setzero_si256();
        let mut near = _mm256_set1_epi32(-1);
        let mut each = rays;
        while each != 0 {
            let r = each.trailing_zeros() as usize;
            each &= each - 1;
            // Rays of one origin read one set of planes, not one per group.
            let p = if APART { p[r / 8] } else { p[0] };
            // SAFETY: `r` is a lane of the packet; the caller vouches for the CPU and `p`.
            let (hit, t0) = unsafe {
                slab_lanes_avx2::<SUB>(
                    boxes.get_unchecked(r),
                    p,
                    *tmin.get_unchecked(r),
                    *bound.get_unchecked(r),
                )
            };
            let hit = _mm256_castps_si256(hit);
            cols = _mm256_or_si256(cols, _mm256_and_si256(hit, _mm256_set1_epi32(1 << r)));
            if NEAR {
                // Non-negative floats order as their bits; lanes missed keep the accumulator.
                let t = _mm256_or_si256(
                    _mm256_castps_si256(t0),
                    _mm256_andnot_si256(hit, _mm256_set1_epi32(-1)),
                );
                near = _mm256_min_epu32(near, t);
            }
        }
        // Every lane is a set of rays; a lane not empty is a child hit (a set with the top bit
        // is negative, so not a signed compare against zero).
        let empty = _mm256_cmpeq_epi32(cols, _mm256_setzero_si256());
        let kids = !(_mm256_movemask_ps(_mm256_castsi256_ps(empty)) as u32) & 0xFF;
        let mut out = PacketHits {
            kids,
            cols: [0; WIDTH],
            near: [0.0; WIDTH],
        };
        // SAFETY: both arrays are eight writable words.
        unsafe {
            _mm256_storeu_si256(out.cols.as_mut_ptr().cast(), cols);
            _mm256_storeu_si256(out.near.as_mut_ptr().cast(), near);
        }
        out
    }

    /// [`super::nearest`] in 256-bit registers: each lane's distance as an integer key, its
    /// low three bits replaced by the lane's slot and lanes not in `mask` the largest key, and
    /// the least key found in three integer steps. Non-negative floats order as their bits do,
    /// so this is the nearest slot to within eight units in the last place (ties, and those
    /// nearer still, go to the lower slot); negative distances (only where `tmin < 0`) sort
    /// after all others. Either way the choice depends on the distances alone.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn nearest_avx2(mask: u32, near: &[f32; WIDTH]) -> usize {
        let slot = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let set = lanes(mask);
        // SAFETY: `near` is eight readable floats.
        let t = unsafe { _mm256_loadu_si256(near.as_ptr().cast()) };
        let key = _mm256_or_si256(_mm256_andnot_si256(_mm256_set1_epi32(7), t), slot);
        let key = _mm256_or_si256(key, _mm256_andnot_si256(set, _mm256_set1_epi32(-1)));
        let m = _mm256_min_epu32(key, _mm256_permute2x128_si256::<1>(key, key));
        let m = _mm256_min_epu32(m, _mm256_shuffle_epi32::<0b01_00_11_10>(m));
        let m = _mm256_min_epu32(m, _mm256_shuffle_epi32::<0b10_11_00_01>(m));
        (_mm256_cvtsi256_si32(m) & 7) as usize
    }

    /// The lanes of `mask` as all-ones lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn lanes(mask: u32) -> __m256i {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(mask as i32), bits), bits)
    }

    /// [`super::within`].
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) unsafe fn within_avx2<const N: usize>(t: f32, bound: &[f32; N]) -> u32 {
        let mut m = 0;
        for h in (0..bound.len()).step_by(8) {
            // SAFETY: lanes `h..h + 8` of `bound` are readable.
            let b = unsafe { _mm256_loadu_ps(bound[h..h + 8].as_ptr()) };
            m |=
                (_mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_set1_ps(t), b)) as u32) << h;
        }
        m
    }

    /// The lane operations of the watertight kernel at one width, each compiled for the
    /// kernel's instruction set so that it inlines into the kernel, which alone calls them.
    macro_rules! lane_ops {
        (
            $feature:literal, $v:ty, $n:literal, $set1:path, $zero:path, $cast:path,
            $set1i:path, $sub:path, $add:path, $mul:path, $or:path, $and:path,
            $andnot:path, $xor:path, $eq:path, $lt:path, $gt:path, $movemask:path,
            $loadu:path, $storeu:path
        ) => {
            pub(super) type V = $v;
            pub(super) const N: usize = $n;
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn splat(x: f32) -> V {
                $set1(x)
            }
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn zero() -> V {
                $zero()
            }
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn sign() -> V {
                $cast($set1i(i32::MIN))
            }
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn ones() -> V {
                $cast($set1i(-1))
            }
            lane_ops!(@binary $feature, sub $sub, add $add, mul $mul, or $or, and $and,
                andnot $andnot, xor $xor, eq $eq, lt $lt, gt $gt);
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn movemask(a: V) -> u32 {
                $movemask(a) as u32
            }
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn load(a: &[f32; N]) -> V {
                // SAFETY: `a` is `N` readable floats, and the lanes' instructions are enabled.
                unsafe { $loadu(a.as_ptr()) }
            }
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn store(v: V) -> [f32; N] {
                let mut a = [0f32; N];
                // SAFETY: `a` is `N` writable floats, and the lanes' instructions are enabled.
                unsafe { $storeu(a.as_mut_ptr(), v) };
                a
            }
            /// A vertex less the origin (rows `x`, `y`, `z` along `kx`, `ky`, `kz`) sheared:
            /// its `x` and `y` in ray space.
            #[target_feature(enable = $feature)]
            #[inline]
            pub(super) fn shear(x: V, y: V, z: V, sx: V, sy: V) -> (V, V) {
                (sub(x, mul(sx, z)), sub(y, mul(sy, z)))
            }
        };
        (@binary $feature:literal, $($name:ident $op:path),*) => {
            $(
                #[target_feature(enable = $feature)]
                #[inline]
                pub(super) fn $name(a: V, b: V) -> V {
                    $op(a, b)
                }
            )*
        };
    }

    /// The four-lane operations, on SSE2 (the x86_64 baseline).
    mod l4 {
        use super::*;
        lane_ops!(
            "sse2",
            __m128,
            4,
            _mm_set1_ps,
            _mm_setzero_ps,
            _mm_castsi128_ps,
            _mm_set1_epi32,
            _mm_sub_ps,
            _mm_add_ps,
            _mm_mul_ps,
            _mm_or_ps,
            _mm_and_ps,
            _mm_andnot_ps,
            _mm_xor_ps,
            _mm_cmpeq_ps,
            _mm_cmplt_ps,
            _mm_cmpgt_ps,
            _mm_movemask_ps,
            _mm_loadu_ps,
            _mm_storeu_ps
        );
        /// Row `axis` of vertex `i` of `g`.
        #[target_feature(enable = "sse2")]
        #[inline]
        pub(super) fn vert(g: &Tri4, i: usize, axis: usize) -> V {
            load(&g.v[i][axis])
        }
    }

    /// The eight-lane operations, on AVX2.
    mod l8 {
        use super::*;
        lane_ops!(
            "avx2",
            __m256,
            8,
            _mm256_set1_ps,
            _mm256_setzero_ps,
            _mm256_castsi256_ps,
            _mm256_set1_epi32,
            _mm256_sub_ps,
            _mm256_add_ps,
            _mm256_mul_ps,
            _mm256_or_ps,
            _mm256_and_ps,
            _mm256_andnot_ps,
            _mm256_xor_ps,
            _mm256_cmp_ps::<_CMP_EQ_OQ>,
            _mm256_cmp_ps::<_CMP_LT_OQ>,
            _mm256_cmp_ps::<_CMP_GT_OQ>,
            _mm256_movemask_ps,
            _mm256_loadu_ps,
            _mm256_storeu_ps
        );
        /// Two groups' rows side by side: `lo` in lanes 0–3, `hi` in 4–7.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn load2(lo: &[f32; 4], hi: &[f32; 4]) -> V {
            _mm256_set_m128(super::l4::load(hi), super::l4::load(lo))
        }
        /// `lo` in lanes 0–3 and `hi` in 4–7.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn halves(lo: f32, hi: f32) -> V {
            _mm256_set_m128(_mm_set1_ps(hi), _mm_set1_ps(lo))
        }
        /// Row `axis` of vertex `i` of `a` and then `b`.
        #[target_feature(enable = "avx2")]
        #[inline]
        pub(super) fn vert(a: &Tri4, b: &Tri4, i: usize, axis: usize) -> V {
            load2(&a.v[i][axis], &b.v[i][axis])
        }
    }

    /// The watertight test of `$l::N` triangles, one per lane: [`crate::triangle::intersect_parts`]
    /// operation for operation. One ray's vertices come either as the groups `$g` (`$l::vert`
    /// loads their rows, less the ray's origin) or as [`Rel8`] rows, already less the origin;
    /// or two rays test one group, the first in lanes 0–3. Written once for both lane widths
    /// and every source, so that they cannot drift apart.
    macro_rules! watertight {
        ($l:ident, $s:expr, groups ($($g:expr),+), $tmin:expr, $tmax:expr) => {{
            use $l as l;
            let s: &Shear4 = $s;
            let [kx, ky, kz] = s.axes();
            let o = [l::splat(s.org[0]), l::splat(s.org[1]), l::splat(s.org[2])];
            // Vertex minus origin along kx, ky, kz, as the scalar test does. No closures: they
            // would not be compiled for the lane width's target features, and the lane
            // operations would not inline into them.
            let row = [
                [
                    l::sub(l::vert($($g),+, 0, kx), o[0]),
                    l::sub(l::vert($($g),+, 0, ky), o[1]),
                    l::sub(l::vert($($g),+, 0, kz), o[2]),
                ],
                [
                    l::sub(l::vert($($g),+, 1, kx), o[0]),
                    l::sub(l::vert($($g),+, 1, ky), o[1]),
                    l::sub(l::vert($($g),+, 1, kz), o[2]),
                ],
                [
                    l::sub(l::vert($($g),+, 2, kx), o[0]),
                    l::sub(l::vert($($g),+, 2, ky), o[1]),
                    l::sub(l::vert($($g),+, 2, kz), o[2]),
                ],
            ];
            let shear = [l::splat(s.sx), l::splat(s.sy), l::splat(s.sz)];
            watertight!(@sheared $l, shear, row, l::splat($tmin), l::splat($tmax))
        }};
        ($l:ident, $s:expr, rows $r:expr, $tmin:expr, $tmax:expr) => {{
            use $l as l;
            let s: &Shear4 = $s;
            let r: &Rel8 = $r;
            let [kx, ky, kz] = s.axes();
            // Written out, not mapped: a closure would not inline the lane operations.
            let row = [
                [l::load(&r.rows[0][kx]), l::load(&r.rows[0][ky]), l::load(&r.rows[0][kz])],
                [l::load(&r.rows[1][kx]), l::load(&r.rows[1][ky]), l::load(&r.rows[1][kz])],
                [l::load(&r.rows[2][kx]), l::load(&r.rows[2][ky]), l::load(&r.rows[2][kz])],
            ];
            let shear = [l::splat(s.sx), l::splat(s.sy), l::splat(s.sz)];
            watertight!(@sheared $l, shear, row, l::splat($tmin), l::splat($tmax))
        }};
        (two ($a:expr, $b:expr), $g:expr, ($tmin_a:expr, $tmin_b:expr),
            ($tmax_a:expr, $tmax_b:expr)) => {{
            use l8 as l;
            let (a, b, g): (&Shear4, &Shear4, &Tri4) = ($a, $b, $g);
            let ([ax, ay, az], [bx, by, bz]) = (a.axes(), b.axes());
            let o = [
                l::halves(a.org[0], b.org[0]),
                l::halves(a.org[1], b.org[1]),
                l::halves(a.org[2], b.org[2]),
            ];
            // Each ray's rows in its half.
            let row = [
                [
                    l::sub(l::load2(&g.v[0][ax], &g.v[0][bx]), o[0]),
                    l::sub(l::load2(&g.v[0][ay], &g.v[0][by]), o[1]),
                    l::sub(l::load2(&g.v[0][az], &g.v[0][bz]), o[2]),
                ],
                [
                    l::sub(l::load2(&g.v[1][ax], &g.v[1][bx]), o[0]),
                    l::sub(l::load2(&g.v[1][ay], &g.v[1][by]), o[1]),
                    l::sub(l::load2(&g.v[1][az], &g.v[1][bz]), o[2]),
                ],
                [
                    l::sub(l::load2(&g.v[2][ax], &g.v[2][bx]), o[0]),
                    l::sub(l::load2(&g.v[2][ay], &g.v[2][by]), o[1]),
                    l::sub(l::load2(&g.v[2][az], &g.v[2][bz]), o[2]),
                ],
            ];
            let shear = [l::halves(a.sx, b.sx), l::halves(a.sy, b.sy), l::halves(a.sz, b.sz)];
            let (tmin, tmax) = (l::halves($tmin_a, $tmin_b), l::halves($tmax_a, $tmax_b));
            watertight!(@sheared l8, shear, row, tmin, tmax)
        }};
        (@sheared $l:ident, $shear:expr, $row:expr, $tmin:expr, $tmax:expr) => {{
            use $l as l;
            let [sx, sy, sz] = $shear;
            let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = $row;
            let (ax, ay) = l::shear(ax, ay, az, sx, sy);
            let (bx, by) = l::shear(bx, by, bz, sx, sy);
            let (cx, cy) = l::shear(cx, cy, cz, sx, sy);
            let mut u = l::sub(l::mul(cx, by), l::mul(cy, bx));
            let mut v = l::sub(l::mul(ax, cy), l::mul(ay, cx));
            let mut w = l::sub(l::mul(bx, ay), l::mul(by, ax));
            let zero = l::zero();
            let on_edge = l::or(l::or(l::eq(u, zero), l::eq(v, zero)), l::eq(w, zero));
            let edge_lanes = l::movemask(on_edge);
            if edge_lanes != 0 {
                // Rare: redo the lanes with a zero edge function in f64, exactly as the
                // scalar test.
                let (ax, ay, bx, by, cx, cy) = (
                    l::store(ax),
                    l::store(ay),
                    l::store(bx),
                    l::store(by),
                    l::store(cx),
                    l::store(cy),
                );
                let (mut uu, mut vv, mut ww) = (l::store(u), l::store(v), l::store(w));
                let d = |p: f32, q: f32, r: f32, t: f32| {
                    (p as f64 * q as f64 - r as f64 * t as f64) as f32
                };
                for k in 0..l::N {
                    if edge_lanes & (1 << k) != 0 {
                        uu[k] = d(cx[k], by[k], cy[k], bx[k]);
                        vv[k] = d(ax[k], cy[k], ay[k], cx[k]);
                        ww[k] = d(bx[k], ay[k], by[k], ax[k]);
                    }
                }
                (u, v, w) = (l::load(&uu), l::load(&vv), l::load(&ww));
            }
            let neg = l::or(l::or(l::lt(u, zero), l::lt(v, zero)), l::lt(w, zero));
            let pos = l::or(l::or(l::gt(u, zero), l::gt(v, zero)), l::gt(w, zero));
            let det = l::add(l::add(u, v), w);
            let mut reject = l::or(l::and(neg, pos), l::eq(det, zero));
            let all = (1u32 << l::N) - 1;
            if l::movemask(reject) == all {
                return TriHits::MISS;
            }
            let (az, bz, cz) = (l::mul(sz, az), l::mul(sz, bz), l::mul(sz, cz));
            let t_scaled = l::add(l::add(l::mul(u, az), l::mul(v, bz)), l::mul(w, cz));
            // Where det < 0, negate both (flip the sign bit, exactly the scalar negation).
            let sign = l::and(l::lt(det, zero), l::sign());
            let t_scaled = l::xor(t_scaled, sign);
            let det_abs = l::xor(det, sign);
            reject = l::or(
                reject,
                l::or(
                    l::lt(t_scaled, l::mul($tmin, det_abs)),
                    l::gt(t_scaled, l::mul($tmax, det_abs)),
                ),
            );
            let mask = l::movemask(l::andnot(reject, l::ones())) & all;
            if mask == 0 {
                return TriHits::MISS;
            }
            TriHits {
                mask,
                t_scaled: l::store(t_scaled),
                det: l::store(det),
                v: l::store(v),
                w: l::store(w),
            }
        }};
    }

    #[inline(always)]
    pub(super) fn intersect4(s: &Shear4, g: &Tri4, tmin: f32, tmax: f32) -> TriHits<4> {
        // SAFETY: the four-lane operations need SSE2, part of the x86_64 baseline. The kernel
        // is expanded here rather than called, so that it inlines into the traversal.
        unsafe { watertight!(l4, s, groups(g), tmin, tmax) }
    }

    /// # Safety
    /// The CPU must have AVX2. Inlined into a caller compiled for AVX2, the lane operations
    /// inline too.
    #[inline(always)]
    pub(super) unsafe fn intersect8_avx2(
        s: &Shear4,
        a: &Tri4,
        b: &Tri4,
        tmin: f32,
        tmax: f32,
    ) -> TriHits<8> {
        // SAFETY: the eight-lane operations need AVX2, which the caller has checked.
        unsafe { watertight!(l8, s, groups(a, b), tmin, tmax) }
    }

    /// # Safety
    /// The CPU must have AVX2.
    #[inline(always)]
    pub(super) unsafe fn intersect_two_avx2(
        a: &Shear4,
        b: &Shear4,
        g: &Tri4,
        tmin: [f32; 2],
        tmax: [f32; 2],
    ) -> TriHits<8> {
        // SAFETY: the eight-lane operations need AVX2, which the caller has checked.
        unsafe { watertight!(two(a, b), g, (tmin[0], tmin[1]), (tmax[0], tmax[1])) }
    }

    /// # Safety
    /// The CPU must have AVX2, and `r` be taken from the ray's origin.
    #[inline(always)]
    pub(super) unsafe fn intersect8_rel_avx2(
        s: &Shear4,
        r: &Rel8,
        tmin: f32,
        tmax: f32,
    ) -> TriHits<8> {
        // SAFETY: the eight-lane operations need AVX2, which the caller has checked.
        unsafe { watertight!(l8, s, rows r, tmin, tmax) }
    }

    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn rel8_avx2(a: &Tri4, b: &Tri4, org: &[f32; 3]) -> Rel8 {
        let mut rows = [[[0f32; 8]; 3]; 3];
        for (i, vertex) in rows.iter_mut().enumerate() {
            for (axis, row) in vertex.iter_mut().enumerate() {
                *row = l8::store(l8::sub(l8::vert(a, b, i, axis), l8::splat(org[axis])));
            }
        }
        Rel8 { rows }
    }
}

#[cfg(test)]
mod tests {
    use bytemuck::Zeroable;
    use glam::Vec3;

    use super::*;
    use crate::Rng;

    /// Lanes 0–3 of `h8` are `lo`'s four and lanes 4–7 `hi`'s, hit for hit and bit for bit.
    fn halves_are(h8: &TriHits<8>, lo: &TriHits<4>, hi: &TriHits<4>, what: &str) {
        let bits = |(t, u, v): (f32, f32, f32)| [t, u, v].map(f32::to_bits);
        for (half, four) in [(0, lo), (4, hi)] {
            for k in 0..4 {
                let hit = four.mask & (1 << k) != 0;
                assert_eq!(h8.mask & (1 << (half + k)) != 0, hit, "{what}");
                if hit {
                    assert_eq!(bits(h8.hit(half + k)), bits(four.hit(k)), "{what}");
                }
            }
        }
    }

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
        let bits = |(t, u, v): (f32, f32, f32)| [t, u, v].map(f32::to_bits);
        let mut prev = Tri4::zeroed();
        // The previous ray that can hit anything, its shear and range.
        let mut prev_ray: Option<(Shear4, f32, f32)> = None;
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
                // A packet of this ray in every lane, as wide as `traverse::lanes` makes one,
                // testing the node's planes and the planes less the ray's origin (one set, and
                // one a group): each lane's bits and entries are the ray's own.
                const PACKET: usize = 32;
                const GROUPS: usize = PACKET / 8;
                let (tmin, tmax) = ([ray.tmin; PACKET], [ray.tmax; PACKET]);
                let all = ((1u64 << PACKET) - 1) as u32;
                // SAFETY: as above; the planes are taken from every ray's origin.
                let packets = unsafe {
                    let rel = relative(&node, &ray.origin.to_array());
                    let (p, r) = ([&node.planes; GROUPS], [rel.rows(); GROUPS]);
                    [
                        packet_node::<true, false, true, PACKET, GROUPS>(
                            &[br; PACKET],
                            all,
                            p,
                            &tmin,
                            &tmax,
                        ),
                        packet_node::<false, false, true, PACKET, GROUPS>(
                            &[br; PACKET],
                            all,
                            r,
                            &tmin,
                            &tmax,
                        ),
                        packet_node::<false, true, true, PACKET, GROUPS>(
                            &[br; PACKET],
                            all,
                            r,
                            &tmin,
                            &tmax,
                        ),
                    ]
                };
                for p in packets {
                    let m = (0..WIDTH).fold(0, |m, k| m | u32::from(p.cols[k] != 0) << k);
                    assert_eq!(p.kids, m);
                    assert!(p.cols.iter().all(|&c| c == 0 || c == all));
                    kernels.push((m, p.near));
                }
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
            let scalar = |k: usize| {
                let vert = |i: usize| [g.v[i][0][k], g.v[i][1][k], g.v[i][2][k]];
                crate::intersect_watertight(
                    &shear,
                    &vert(0),
                    &vert(1),
                    &vert(2),
                    ray.tmin,
                    ray.tmax,
                )
                .map(|(t, u, v)| [t, u, v].map(f32::to_bits))
            };
            let lane = |h: &TriHits<4>, k: usize| {
                (h.mask & (1 << k) != 0).then(|| {
                    let (t, u, v) = h.hit(k);
                    [t, u, v].map(f32::to_bits)
                })
            };
            for k in 0..4 {
                assert_eq!(lane(&h, k), scalar(k), "{ray:?} {g:?} (COBALT_SEED={seed})");
                assert_eq!(
                    lane(&hs, k),
                    scalar(k),
                    "{ray:?} {g:?} (COBALT_SEED={seed})"
                );
            }
            #[cfg(target_arch = "x86_64")]
            if avx2() {
                // The eight-lane test of this group beside the previous one: each half is the
                // four-lane test of its group.
                // SAFETY: AVX2 was just detected.
                let h8 = unsafe { s.intersect8(&prev, &g, ray.tmin, ray.tmax) };
                // The same pass from the vertices less the origin, taken beforehand.
                // SAFETY: as above; the rows are taken from the ray's origin.
                let hr = unsafe {
                    let rel = Rel8::new(&prev, &g, &ray.origin.to_array());
                    s.intersect8_rel(&rel, ray.tmin, ray.tmax)
                };
                assert_eq!(hr.mask, h8.mask, "{ray:?} {prev:?} {g:?}");
                for k in 0..8 {
                    if h8.mask & (1 << k) != 0 {
                        assert_eq!(bits(hr.hit(k)), bits(h8.hit(k)), "{ray:?} {g:?}");
                    }
                }
                let hp = s.intersect4(&prev, ray.tmin, ray.tmax);
                halves_are(&h8, &hp, &h, &format!("{ray:?} {prev:?} {g:?}"));
            }
            #[cfg(target_arch = "x86_64")]
            if let (true, Some((p, pmin, pmax))) = (avx2(), prev_ray) {
                // Two rays testing this group in one pass: each half is its ray's four-lane
                // test.
                // SAFETY: AVX2 was just detected.
                let two = unsafe { s.intersect_two(&p, &g, [ray.tmin, pmin], [ray.tmax, pmax]) };
                let hp = p.intersect4(&g, pmin, pmax);
                halves_are(&two, &h, &hp, &format!("{ray:?} {g:?}"));
            }
            prev_ray = Some((s, ray.tmin, ray.tmax));
            prev = g;
            tri_hits += h.mask.count_ones();
        }
        // Both outcomes are exercised, not just misses.
        assert!(
            box_hits > 10_000 && tri_hits > 2_000,
            "{box_hits} {tri_hits}"
        );
    }
}
