//! The reduced traversal of eight rays at once, one ray per AVX2 lane.
//!
//! The reduced traversal never shortens a ray (it fetches no triangle), so the nodes a ray
//! enters depend on that ray alone: it enters the root if it hits the root's box, and a child
//! if it entered the parent and hits the child's box. Eight rays can therefore walk the tree
//! together, each node carrying the mask of the lanes that entered it, and every lane's counts
//! are exactly those of [`Bvh::reduced_traversal`] of that ray alone: the per-lane arithmetic
//! is the scalar slab test's, operation for operation. Coherent rays (Morton-ordered primary
//! rays, the Halton probes of one pixel) share most of their nodes, so one box test serves up
//! to eight rays. This is what makes estimation cheap on a CPU, where, unlike the thesis's
//! GPU, fetching triangles is not what dominates a trace. Without AVX2, rays walk one by one.
//!
//! The first-leaf walk ([`Walk::FirstLeaf`]) does shorten rays, so there the order of the
//! walk matters. It takes children in an order set by the direction's signs
//! ([`crate::traverse::walk::near_child_first`]), the same for every lane of a packet whose lanes
//! share their signs; each lane keeps its own `tmax`, and a popped node keeps only the lanes
//! whose entry distance is still within it, which is the scalar walk's pop rule.

use crate::bvh::Bvh;
use crate::ray::RayBatch;
use crate::traverse::counts::Counts;
use crate::traverse::walk::Walk;

/// Counts of the rays `lane_of(0), lane_of(1), …` of `rays` into `out`, one per entry, with
/// packets of 8 rays where AVX2 runs, else ray by ray.
/// `lane_of` maps an entry of `out` to a ray of `rays`: a range, or a compacted sample's ray
/// indices, read in place without copying the sample out.
///
/// [`Walk::FirstLeaf`] walks in packets only where the packet's directions share their signs
/// (its child order follows them); other packets run ray by ray.
#[inline]
pub(crate) fn reduced_lanes(
    bvh: &Bvh,
    rays: &RayBatch,
    walk: Walk,
    lane_of: impl Fn(usize) -> usize,
    out: &mut [Counts],
) {
    // A real trace shortens each ray at its own hits: its lanes would part at once.
    if let Walk::Trace { .. } = walk {
        for (j, c) in out.iter_mut().enumerate() {
            *c = bvh.walk(&rays.get(lane_of(j)), walk);
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        for (k, part) in out.chunks_mut(8).enumerate() {
            let idx: [usize; 8] = std::array::from_fn(|j| lane_of(8 * k + j.min(part.len() - 1)));
            // SAFETY: AVX2 is available, as just checked.
            let got = unsafe { avx2::reduced8(bvh, rays, walk, &idx, part.len()) };
            part.copy_from_slice(&got[..part.len()]);
        }
        return;
    }
    for (j, c) in out.iter_mut().enumerate() {
        *c = bvh.walk(&rays.get(lane_of(j)), walk);
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::{
        __m256, __m256i, _CMP_LE_OQ, _mm256_add_epi32, _mm256_and_ps, _mm256_and_si256,
        _mm256_blendv_ps, _mm256_castps_si256, _mm256_castsi256_ps, _mm256_cmp_ps,
        _mm256_cmpeq_epi32, _mm256_div_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps,
        _mm256_movemask_ps, _mm256_mul_ps, _mm256_set1_epi32, _mm256_set1_ps, _mm256_setr_epi32,
        _mm256_setzero_si256, _mm256_srai_epi32, _mm256_storeu_si256, _mm256_sub_epi32,
        _mm256_sub_ps, _mm256_xor_ps,
    };

    use std::mem::MaybeUninit;

    use crate::bvh::node::Node;
    use crate::bvh::{Bvh, MAX_DEPTH};
    use crate::ray::RayBatch;
    use crate::slab::far_scale;
    use crate::traverse::counts::Counts;
    use crate::traverse::lanes::traced;
    use crate::traverse::walk::{Walk, near_child_first};

    /// Eight rays in lanes.
    #[derive(Clone, Copy)]
    struct Rays8 {
        org: [__m256; 3],
        inv: [__m256; 3],
        /// All ones where the direction's sign bit is set: the near plane is the max.
        swap: [__m256; 3],
        /// When every traced lane's direction has the same sign on each axis (the usual case
        /// for neighbouring camera rays): the index of each axis's near plane in a node seen
        /// as `[f32; 8]`, so the planes are picked once per node instead of swapped per lane.
        near: [usize; 3],
        tmin: __m256,
        tmax: __m256,
        scale: __m256,
    }

    impl Rays8 {
        /// Bit `k` set when lane `k`'s ray hits `node`'s box. `UNIFORM` uses `near` instead
        /// of the per-lane swap; both compute the same values bit for bit.
        #[inline]
        #[target_feature(enable = "avx2")]
        fn hit<const UNIFORM: bool>(&self, node: &Node) -> i32 {
            self.entry::<UNIFORM>(node).0
        }

        /// [`Rays8::hit`]'s bits, and each lane's entry distance.
        #[inline]
        #[target_feature(enable = "avx2")]
        fn entry<const UNIFORM: bool>(&self, node: &Node) -> (i32, __m256) {
            let (near, far) = self.slab::<UNIFORM>(node);
            // Ordered, non-signalling `<=`: false on NaN, like the scalar comparison.
            (
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)),
                near,
            )
        }

        /// Each lane's entry and exit distance of `node`'s box, the exit clipped to `tmax`:
        /// the scalar `BoxRay::hit`'s `t0`, `t1` (and `BoxRay::exit`), lane by lane.
        #[inline]
        #[target_feature(enable = "avx2")]
        fn slab<const UNIFORM: bool>(&self, node: &Node) -> (__m256, __m256) {
            let b: &[f32; 8] = bytemuck::cast_ref(node);
            let mut near = self.tmin;
            let mut far = _mm256_set1_ps(f32::INFINITY);
            for a in 0..3 {
                let t = |plane: f32| {
                    _mm256_mul_ps(
                        _mm256_sub_ps(_mm256_set1_ps(plane), self.org[a]),
                        self.inv[a],
                    )
                };
                let (tn, tf) = if UNIFORM {
                    // `& 7`: in bounds by construction, and no bounds check is emitted.
                    let n = self.near[a];
                    (t(b[n & 7]), t(b[(n ^ 4) & 7]))
                } else {
                    let (lo, hi) = (t(node.min[a]), t(node.max[a]));
                    // Swap min and max planes where the direction is negative, bit for bit.
                    let x = _mm256_and_ps(_mm256_xor_ps(lo, hi), self.swap[a]);
                    (_mm256_xor_ps(lo, x), _mm256_xor_ps(hi, x))
                };
                // `max_ps(t, acc)` keeps `acc` where `t` is NaN, like the scalar
                // `max_keep(acc, t)`, and in the same order (x, then y, then z).
                near = _mm256_max_ps(tn, near);
                far = _mm256_min_ps(tf, far);
            }
            (
                near,
                _mm256_min_ps(_mm256_mul_ps(far, self.scale), self.tmax),
            )
        }
    }

    /// Lane masks (all ones where bit `k` of `bits` is set), as integers.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes_of(bits: i32) -> __m256i {
        let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        _mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(bits), lane_bits),
            lane_bits,
        )
    }

    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn reduced8(
        bvh: &Bvh,
        rays: &RayBatch,
        walk: Walk,
        idx: &[usize; 8],
        n: usize,
    ) -> [Counts; 8] {
        if bvh.depth() <= 64 {
            walk_packet::<64>(bvh, rays, walk, idx, n)
        } else {
            walk_packet::<{ MAX_DEPTH }>(bvh, rays, walk, idx, n)
        }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn walk_packet<const STACK: usize>(
        bvh: &Bvh,
        rays: &RayBatch,
        walk: Walk,
        idx: &[usize; 8],
        n: usize,
    ) -> [Counts; 8] {
        let mut out = [Counts::default(); 8];
        if n == 0 || bvh.triangles().is_empty() {
            return out;
        }
        let lane = |k: usize| idx[k];
        let col = |c: &[f32]| -> [f32; 8] { std::array::from_fn(|k| c[lane(k)]) };
        // SAFETY: each load reads eight `f32`s from a local array of eight.
        let load = |a: &[f32; 8]| unsafe { _mm256_loadu_ps(a.as_ptr()) };
        let d = [
            load(&col(&rays.dx)),
            load(&col(&rays.dy)),
            load(&col(&rays.dz)),
        ];
        let one = _mm256_set1_ps(1.0);
        let sign = |v: __m256| _mm256_castsi256_ps(_mm256_srai_epi32(_mm256_castps_si256(v), 31));
        let mut lanes = Rays8 {
            org: [
                load(&col(&rays.ox)),
                load(&col(&rays.oy)),
                load(&col(&rays.oz)),
            ],
            inv: [
                _mm256_div_ps(one, d[0]),
                _mm256_div_ps(one, d[1]),
                _mm256_div_ps(one, d[2]),
            ],
            swap: [sign(d[0]), sign(d[1]), sign(d[2])],
            near: [0, 1, 2],
            tmin: load(&col(&rays.tmin)),
            tmax: load(&col(&rays.tmax)),
            scale: _mm256_set1_ps(far_scale()),
        };
        let ok = traced(&lanes.org, &d, lanes.tmin, lanes.tmax);
        let valid = _mm256_movemask_ps(ok) & ((1i32 << n) - 1);
        // Per axis, the traced lanes whose direction has its sign bit set: none or all of
        // them on every axis makes the packet uniform.
        let neg = d.map(|v| _mm256_movemask_ps(v) & valid);
        let uniform = neg.iter().all(|&m| m == 0 || m == valid);
        if uniform {
            lanes.near = std::array::from_fn(|a| if neg[a] == valid { 4 + a } else { a });
        }
        match (walk, uniform) {
            (Walk::Reduced, true) => traverse::<STACK, true>(bvh, &lanes, valid, n),
            (Walk::Reduced, false) => traverse::<STACK, false>(bvh, &lanes, valid, n),
            (Walk::FirstLeaf, true) => {
                let negative = std::array::from_fn(|a| neg[a] == valid && valid != 0);
                first_leaf::<STACK>(bvh, lanes, negative, valid, n)
            }
            (Walk::FirstLeaf, false) | (Walk::Trace { .. }, _) => {
                // Lanes that disagree on a sign may disagree on the child order (and a real
                // trace, which `reduced_lanes` never sends here, shortens each lane its way).
                for (k, c) in out.iter_mut().enumerate().take(n) {
                    *c = bvh.walk(&rays.get(lane(k)), walk);
                }
                out
            }
        }
    }

    /// [`traverse`] for [`Walk::FirstLeaf`], on a uniform packet (`lanes.near` set, and
    /// `negative` its direction's signs). Each lane's `tmax` shrinks to the exit of the first
    /// leaf it enters; a popped node keeps the lanes whose entry is still within their range,
    /// which is the scalar walk's `t_near <= best_t` on the same entry distances.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn first_leaf<const STACK: usize>(
        bvh: &Bvh,
        mut lanes: Rays8,
        negative: [bool; 3],
        valid: i32,
        n: usize,
    ) -> [Counts; 8] {
        let nodes = bvh.nodes();
        let (root, near0) = lanes.entry::<true>(&nodes[0]);
        let root = root & valid;
        if root == 0 {
            return [Counts::default(); 8];
        }
        // Entry distances beside the stack, uninitialised: a zeroed stack of (node, bits,
        // entry) would be 4 KiB to clear for every packet of eight rays.
        let mut stack = [(0u32, 0i32); STACK];
        let mut entries = [MaybeUninit::<__m256>::uninit(); STACK];
        stack[0] = (0, root);
        entries[0].write(near0);
        let mut sp = 1usize;
        let (mut b, mut t): (__m256i, __m256i) = (_mm256_setzero_si256(), _mm256_setzero_si256());
        while sp > 0 {
            sp -= 1;
            let (i, pushed) = stack[sp];
            // SAFETY: every push below writes `entries[sp]` with `stack[sp]`, and so did the
            // root's, so the entry popped with a stack slot was written with it.
            let entry = unsafe { entries[sp].assume_init() };
            let bits = pushed & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(entry, lanes.tmax));
            if bits == 0 {
                continue;
            }
            let node = &nodes[i as usize];
            let m = lanes_of(bits);
            b = _mm256_sub_epi32(b, m);
            if node.is_leaf() {
                t = _mm256_add_epi32(t, _mm256_and_si256(m, _mm256_set1_epi32(node.count as i32)));
                let (_, exit) = lanes.slab::<true>(node);
                lanes.tmax = _mm256_blendv_ps(lanes.tmax, exit, _mm256_castsi256_ps(m));
                continue;
            }
            let l = node.index as usize;
            let (first, second) = if near_child_first(&[nodes[l], nodes[l + 1]], negative) {
                (l, l + 1)
            } else {
                (l + 1, l)
            };
            for child in [second, first] {
                let (hit, near) = lanes.entry::<true>(&nodes[child]);
                let hit = hit & bits;
                if hit != 0 {
                    stack[sp] = (child as u32, hit);
                    entries[sp].write(near);
                    sp += 1;
                }
            }
        }
        counts_of(b, t, n)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn traverse<const STACK: usize, const UNIFORM: bool>(
        bvh: &Bvh,
        lanes: &Rays8,
        valid: i32,
        n: usize,
    ) -> [Counts; 8] {
        let out = [Counts::default(); 8];
        let nodes = bvh.nodes();
        let root = lanes.hit::<UNIFORM>(&nodes[0]) & valid;
        if root == 0 {
            return out;
        }
        let mut stack = [(0u32, 0i32); STACK];
        stack[0] = (0, root);
        let mut sp = 1usize;
        let (mut b, mut t): (__m256i, __m256i) = (_mm256_setzero_si256(), _mm256_setzero_si256());
        while sp > 0 {
            sp -= 1;
            let (i, bits) = stack[sp];
            let node = &nodes[i as usize];
            // A set lane is all ones, i.e. -1 as an integer, so subtracting counts one.
            let m = lanes_of(bits);
            b = _mm256_sub_epi32(b, m);
            if node.is_leaf() {
                t = _mm256_add_epi32(t, _mm256_and_si256(m, _mm256_set1_epi32(node.count as i32)));
                continue;
            }
            let l = node.index as usize;
            for child in [l + 1, l] {
                let hit = lanes.hit::<UNIFORM>(&nodes[child]) & bits;
                if hit != 0 {
                    // Depth-first, both children pushed: at most `depth` entries.
                    stack[sp] = (child as u32, hit);
                    sp += 1;
                }
            }
        }
        counts_of(b, t, n)
    }

    /// The first `n` lanes' counts.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn counts_of(b: __m256i, t: __m256i, n: usize) -> [Counts; 8] {
        let (mut bs, mut ts) = ([0u32; 8], [0u32; 8]);
        // SAFETY: each store writes 32 bytes into a local `[u32; 8]`.
        unsafe {
            _mm256_storeu_si256(bs.as_mut_ptr().cast(), b);
            _mm256_storeu_si256(ts.as_mut_ptr().cast(), t);
        }
        std::array::from_fn(|k| {
            if k < n {
                Counts {
                    nodes: bs[k],
                    tris: ts[k],
                }
            } else {
                Counts::default()
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::{BuildPreset, Camera, Ray, Rng, SceneNeeds, SceneSource, testkit};

    /// Every lane's counts equal the scalar reduced traversal of its ray, for coherent camera
    /// rays, random rays (some with zero, negative-zero and NaN components, empty ranges), and
    /// batch lengths that are not a multiple of eight.
    #[test]
    fn packets_count_exactly_like_single_rays() {
        let scene = SceneSource::parse("builtin:forest:0.05")
            .unwrap()
            .load(SceneNeeds::AO)
            .unwrap();
        let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
        let b = scene.bounds();
        let mut rays = Camera::orbit(&b, 1).primary_rays(37, 29).rays;
        let mut rng = Rng::new(testkit::seed(5));
        let c = b.center();
        for k in 0..3001 {
            let o = c + Vec3::from(rng.unit_vector()) * b.extent().length() * rng.f32();
            let mut d = Vec3::from(rng.unit_vector());
            match k % 7 {
                0 => d.x = 0.0,
                1 => d.y = -0.0,
                2 => d = Vec3::new(0.0, -1.0, 0.0),
                3 => d.z = f32::NAN,
                _ => {}
            }
            let (tmin, tmax) = if k % 11 == 0 {
                (2.0, 1.0)
            } else {
                (0.0, rng.range(0.1, 100.0))
            };
            rays.push(&Ray::with_range(o, d, tmin, tmax));
        }
        let mut nonzero = 0;
        let mut all = vec![Counts::default(); rays.len()];
        reduced_lanes(&bvh, &rays, Walk::Reduced, |j| j, &mut all);
        for (i, g) in all.iter().enumerate() {
            assert_eq!(*g, bvh.reduced_traversal(&rays.get(i)), "ray {i}");
            nonzero += usize::from(g.nodes > 1);
        }
        // Many rays go deeper than the root (the rest miss or are rejected, as they should).
        assert!(nonzero > rays.len() / 5, "{nonzero} of {}", rays.len());
        // From any offset too.
        for first in [0, 3] {
            let mut wide = vec![Counts::default(); rays.len() - first];
            reduced_lanes(&bvh, &rays, Walk::Reduced, |j| first + j, &mut wide);
            for (k, w) in wide.iter().enumerate() {
                assert_eq!(
                    *w,
                    bvh.reduced_traversal(&rays.get(first + k)),
                    "ray {}",
                    first + k
                );
            }
        }
        // And so does a scattered index list, read in place, for either walk (the first-leaf
        // walk orders children by direction signs, so camera packets stay packets).
        let index: Vec<usize> = (0..rays.len()).rev().step_by(3).collect();
        for walk in [Walk::Reduced, Walk::FirstLeaf] {
            let mut scattered = vec![Counts::default(); index.len()];
            reduced_lanes(&bvh, &rays, walk, |j| index[j], &mut scattered);
            for (w, &i) in scattered.iter().zip(&index) {
                assert_eq!(*w, bvh.walk(&rays.get(i), walk), "ray {i}, {walk:?}");
            }
            for first in [0, 5] {
                let mut wide = vec![Counts::default(); rays.len() - first];
                reduced_lanes(&bvh, &rays, walk, |j| first + j, &mut wide);
                for (k, w) in wide.iter().enumerate() {
                    let want = bvh.walk(&rays.get(first + k), walk);
                    assert_eq!(*w, want, "ray {}, {walk:?}", first + k);
                }
            }
        }
    }
}
