//! Closest-hit rays that share an origin, walked through the wide tree together: a pinhole
//! camera's primary rays, taken a few neighbours (in Morton order) at a time.
//!
//! A primary ray's walk finds its nodes in the cache (its neighbour just walked them), so it
//! waits less on memory than on itself: each node's box test, the choice of the next child
//! and the stack make one dependent chain per ray. Neighbouring rays enter mostly the same
//! nodes; walked together, each node is visited once for all of them and their box tests,
//! which do not depend on each other, overlap.
//!
//! Each ray keeps its own range, nearest hit and culling bound. A node is entered with the
//! set of rays that hit its box in its parent's test (a byte of bits, one per ray), each of
//! which tests the node's eight children with its own bound; a leaf is tested by each ray
//! that entered it, every triangle of it. The answer does not depend on the order: the
//! closest hit is the smallest `(t, primitive id)` among the triangles the watertight test
//! accepts in the ray's `[tmin, tmax]` (see [`crate::traverse::wide`]), every box on the path
//! to that triangle passes the test with any bound at or beyond its distance, and the packet
//! drops a ray from a node only where the ray's own bound is nearer than the node's entry.
//! So each ray's hit is its single walk's, bit for bit, ties included.

use std::mem::MaybeUninit;

use crate::bvh::Bvh;
use crate::bvh::wide::{Tri4, WIDTH};
use crate::ray::{Hit, Ray};
use crate::traverse::closest::{better, cull_bound};
use crate::traverse::counts::Counts;
use crate::traverse::mode::{CLOSEST, COUNTED};
use crate::traverse::shared::{PACKET, nonzero_bytes, transpose8};
use crate::traverse::simd::{self, Box8Ray, Shear4};
use crate::triangle::RayShear;

impl Bvh {
    /// Closest hits of `rays` (one to [`PACKET`] of them, which should share an origin for the
    /// walk to pay) into `out[..rays.len()]`, each `None` on a miss.
    ///
    /// # Safety
    /// The CPU must have AVX2, the stack hold `STACK` entries for this tree (as
    /// [`Bvh::wide_each`] sizes it), and every ray's `tmin` have its sign bit clear where its
    /// range is not empty (entry distances are then ordered by their bits, which the
    /// culling of a waiting node relies on).
    #[inline(always)]
    pub(crate) unsafe fn closest_shared<const STACK: usize>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>; PACKET],
        counted: Option<&mut [Counts; PACKET]>,
    ) {
        // Counts as the single walk keeps them: every node a ray enters, the root only if
        // one of its children's boxes is hit, and every triangle of the leaves it enters.
        let mut none = [Counts::default(); PACKET];
        let counting = counted.is_some();
        let counts = counted.unwrap_or(&mut none);
        let n = rays.len().min(PACKET);
        let wide = &self.wide;
        if wide.nodes.is_empty() || n == 0 {
            return;
        }
        // Rays past `n` repeat the first one and are never live. Loops, not `array::from_fn`:
        // its closures are not compiled for AVX2.
        let first = &rays[0];
        let mut boxes = [Box8Ray::new(first); PACKET];
        let mut shears: [Option<Shear4>; PACKET] = [None; PACKET];
        let mut tmin = [first.tmin; PACKET];
        let mut tmax = [first.tmax; PACKET];
        let mut live = 0u32;
        for (r, q) in rays.iter().enumerate().take(n) {
            boxes[r] = Box8Ray::new(q);
            (tmin[r], tmax[r]) = (q.tmin, q.tmax);
            // NaN-safe: a NaN or empty range traces nothing, as in the single walk.
            if q.tmin.partial_cmp(&q.tmax).is_some_and(|o| o.is_le()) {
                shears[r] = RayShear::new(q.origin, q.dir).map(Shear4::new);
            }
            live |= u32::from(shears[r].is_some()) << r;
        }
        let mut best: [Option<Hit>; PACKET] = [None; PACKET];
        let mut cull = tmax.map(cull_bound);
        let nodes = &wide.nodes[..];
        let groups = &wide.groups[..];
        // (inner node or first group, triangle count (0: inner), rays that entered it, their
        // nearest entry). Uninitialised as in the single walk; only entries below `sp` are
        // read.
        let mut stack = [const { MaybeUninit::<(u32, u32, u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let (mut child, mut count, mut m) = (0u32, 0u32, live);
        while m != 0 {
            if m & (m - 1) == 0 {
                // One ray left in this subtree: its own walk, from its nearest hit so far, is
                // cheaper than the packet's bookkeeping for one.
                let r = m.trailing_zeros() as usize;
                if let Some(s) = &shears[r] {
                    // SAFETY: the CPU has AVX2 (see `# Safety`), and `(child, count)` is the
                    // root or a child reference read from the tree.
                    let (hit, c) = unsafe {
                        if counting {
                            self.walk_from::<COUNTED, true, STACK>(
                                &boxes[r],
                                s,
                                tmin[r],
                                tmax[r],
                                best[r],
                                (child, count),
                            )
                        } else {
                            self.walk_from::<CLOSEST, true, STACK>(
                                &boxes[r],
                                s,
                                tmin[r],
                                tmax[r],
                                best[r],
                                (child, count),
                            )
                        }
                    };
                    if counting {
                        counts[r].nodes += c.nodes;
                        counts[r].tris += c.tris;
                    }
                    if let Some(h) = hit {
                        best[r] = Some(h);
                        cull[r] = cull_bound(h.t);
                    }
                }
            } else if count == 0 {
                // SAFETY: `child` is 0 or an inner child index written by `WideBvh::collapse`.
                let node = unsafe { nodes.get_unchecked(child as usize) };
                let mut rows = 0u64;
                // Each child's nearest entry over the rays that hit it: the order key, and
                // the bound a waiting child is culled by.
                let mut near = [f32::from_bits(u32::MAX); WIDTH];
                let mut each = m;
                while each != 0 {
                    let r = each.trailing_zeros() as usize;
                    each &= each - 1;
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    let (hit, t) = unsafe { boxes[r].hit8::<true>(node, tmin[r], cull[r]) };
                    rows |= u64::from(hit) << (8 * r);
                    if counting && (child != 0 || hit != 0) {
                        counts[r].nodes += 1;
                    }
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    unsafe { simd::min_entry(&mut near, hit, &t) };
                }
                let cols = transpose8(rows);
                let mut kids = nonzero_bytes(cols);
                if kids != 0 {
                    if counting {
                        // A counted packet is an estimate's sample: its children are cold.
                        wide.prefetch_children(node, kids);
                    }
                    // Nearest first, as in the single walk: the others wait, farthest
                    // pushed first. Keys are compared as bits, as `min_entry` made them.
                    let key = near.map(f32::to_bits);
                    let mut order = [0usize; WIDTH];
                    let mut len = 0;
                    while kids != 0 {
                        let k = kids.trailing_zeros() as usize;
                        kids &= kids - 1;
                        let mut j = len;
                        while j > 0 && key[order[j - 1]] > key[k] {
                            order[j] = order[j - 1];
                            j -= 1;
                        }
                        order[j] = k;
                        len += 1;
                    }
                    for &k in order[1..len].iter().rev() {
                        let rays = (cols >> (8 * k)) as u32 & 0xFF;
                        // The stack holds at most `WIDTH - 1` entries per wide level.
                        stack[sp].write((node.child[k], node.count[k], rays, near[k]));
                        sp += 1;
                    }
                    let k = order[0];
                    child = node.child[k];
                    count = node.count[k];
                    m = (cols >> (8 * k)) as u32 & 0xFF;
                    continue;
                }
            } else {
                let first = child as usize;
                let g = count.div_ceil(4) as usize;
                // SAFETY: a leaf's `ceil(count / 4)` groups from `child` were pushed by
                // `WideBvh::collapse` when it wrote the leaf.
                let leaf = unsafe { groups.get_unchecked(first..first + g) };
                let mut each = m;
                while each != 0 {
                    let r = each.trailing_zeros() as usize;
                    each &= each - 1;
                    let Some(s) = &shears[r] else { continue };
                    if counting {
                        counts[r].nodes += 1;
                        counts[r].tris += count;
                    }
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    if unsafe { leaf_closest(s, leaf, tmin[r], tmax[r], &mut best[r]) } {
                        cull[r] = cull_bound(best[r].map_or(tmax[r], |h| h.t));
                    }
                }
            }
            // Pop the next node with a ray whose nearest hit is not closer than the node.
            m = 0;
            while sp > 0 {
                sp -= 1;
                // SAFETY: entries below the old `sp` were written by a push.
                let (c, k, rays, t_near) = unsafe { stack[sp].assume_init() };
                // `t_near` is at most each of these rays' own entry (the ordering of bits is
                // that of the floats here, see `# Safety`).
                // SAFETY: the CPU has AVX2 (see `# Safety`).
                let keep = rays & unsafe { simd::within(t_near, &cull) };
                if keep != 0 {
                    (child, count, m) = (c, k, keep);
                    break;
                }
            }
        }
        out[..n].copy_from_slice(&best[..n]);
    }
}

/// Folds the hits of a leaf's triangles into `best` as the single walk does (the smallest
/// `(t, primitive id)`); whether `best` changed.
///
/// # Safety
/// The CPU must have AVX2.
#[inline(always)]
unsafe fn leaf_closest(
    s: &Shear4,
    leaf: &[Tri4],
    tmin: f32,
    tmax: f32,
    best: &mut Option<Hit>,
) -> bool {
    let mut changed = false;
    let mut take = |t: f32, prim: u32, u: f32, v: f32| {
        if better(t, prim, *best) {
            *best = Some(Hit { t, prim, u, v });
            changed = true;
        }
    };
    let mut j = 0;
    while j < leaf.len() {
        if j + 1 < leaf.len() {
            let (a, b) = (&leaf[j], &leaf[j + 1]);
            // SAFETY: the CPU has AVX2 (see `# Safety`).
            let h = unsafe { s.intersect8(a, b, tmin, tmax) };
            let mut m = h.mask;
            while m != 0 {
                let k = m.trailing_zeros() as usize;
                m &= m - 1;
                let prim = if k < 4 { a.prim[k] } else { b.prim[k - 4] };
                let (t, u, v) = h.hit(k);
                take(t, prim, u, v);
            }
            j += 2;
            continue;
        }
        let g = &leaf[j];
        let h = s.intersect4(g, tmin, tmax);
        let mut m = h.mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            let (t, u, v) = h.hit(k);
            take(t, g.prim[k], u, v);
        }
        j += 1;
    }
    changed
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::traverse::{Layout, closest_hits};
    use crate::{Ray, RayBatch, testkit, workload};

    /// Primary rays (one origin, Morton order) with runs of other rays mixed in: other
    /// origins, a zero direction, empty and NaN ranges, short ranges, a range that starts
    /// away from the origin or behind it, and rays aimed at a vertex (ties between
    /// triangles). The batch answer of each ray equals its single walk, bit for bit.
    #[test]
    fn rays_walked_together_hit_as_each_alone() {
        for scene in ["builtin:forest:0.05", "builtin:hairball:0.05"] {
            let (scene, bvh) = testkit::builtin_with_bvh(scene).unwrap();
            let primary = workload::orbit_primary(&scene, 40, 40, 0..2);
            let mut rng = crate::Rng::new(testkit::seed(31));
            let b = scene.bounds();
            let ext = (b.max - b.min).max_element();
            let mut rays = RayBatch::default();
            let mut next = 0;
            while next < primary.len() {
                // A run of primary rays, some shortened or emptied, then some other rays.
                for _ in 0..rng.below(40) {
                    if next == primary.len() {
                        break;
                    }
                    let mut r = primary.get(next);
                    next += 1;
                    match rng.below(16) {
                        0 => r.tmax = rng.range(0.0, 1.0) * ext,
                        1 => r.tmax = -1.0,
                        2 => r.tmax = f32::NAN,
                        3 => r.dir = Vec3::ZERO,
                        4 => r.tmin = rng.range(0.0, 1.0) * ext,
                        // Behind the origin: such rays walk alone.
                        5 => r.tmin = -0.0,
                        6 => r.tmin = -rng.range(0.0, 1.0) * ext,
                        _ => {}
                    }
                    rays.push(&r);
                }
                let o = b.min + (b.max - b.min) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
                for k in 0..rng.below(12) {
                    let r = if k % 3 == 2 {
                        // Aimed at a vertex: its triangles tie.
                        let v = scene.vertices(rng.below(scene.len() as u32) as usize)[0];
                        Ray::new(o, v - o)
                    } else {
                        Ray::new(o, Vec3::from(rng.unit_vector()))
                    };
                    rays.push(&r);
                }
            }
            // Empty and one-ray batches too.
            for len in [0, 1, rays.len()] {
                let mut part = RayBatch::default();
                for i in 0..len {
                    part.push(&rays.get(i));
                }
                let hits = closest_hits(&bvh, &part);
                let mut found = 0;
                for i in 0..len {
                    let r = part.get(i);
                    let alone = bvh.closest_hit_in(&r, Layout::Wide);
                    let got = hits.get(i);
                    assert_eq!(
                        got.map(|(t, p)| (t.to_bits(), p)),
                        alone.map(|h| (h.t.to_bits(), h.prim)),
                        "ray {i} {r:?}"
                    );
                    found += usize::from(got.is_some());
                }
                assert!(
                    len < 100 || (found > 100 && found < len - 100),
                    "{found} of {len}"
                );
            }
        }
    }
}
