//! Any-hit rays that share an origin, walked through the wide tree together: the AO rays of one
//! hit point, or any run of occlusion rays from one place.
//!
//! Short rays that mostly miss (AO rays reach a few percent of the scene and most find
//! nothing) spend their time proving that nothing is there: each waits on one node after
//! another, and the rays of one hit point wait on the same nodes near their origin. Walked
//! together, a node is fetched once for all of them and their box tests, which do not depend
//! on each other, overlap.
//!
//! Each ray still makes exactly the box tests it makes alone: a node is entered with the set
//! of rays that hit its box in its parent's test (a byte of bits, one per ray), and each of
//! those tests the node's eight children. A ray leaves every set once it has found a hit. So
//! the packet's answer for each ray, hit or miss, is the single walk's; which triangle an
//! occluded ray reports may differ, since the order differs, as any-hit queries allow.

use std::mem::MaybeUninit;

use crate::bvh::Bvh;
use crate::bvh::wide::{Tri4, WIDTH};
use crate::ray::{Hit, Ray};
use crate::traverse::closest::cull_bound;
use crate::traverse::counts::Counts;
use crate::traverse::mode::{ANY, ANY_COUNTED};
use crate::traverse::shared::{PACKET, nonzero_bytes, transpose8};
use crate::traverse::simd::{self, Box8Ray, Shear4};
use crate::triangle::RayShear;

impl Bvh {
    /// Any hits of `rays` (one to [`PACKET`] of them, which should share an origin for the
    /// walk to pay) into `out[..rays.len()]`.
    ///
    /// # Safety
    /// The CPU must have AVX2, and the stack hold `STACK` entries for this tree (as
    /// [`Bvh::wide_each`] sizes it).
    #[inline(always)]
    pub(crate) unsafe fn any_shared<const STACK: usize>(
        &self,
        rays: &[Ray],
        out: &mut [Option<Hit>; PACKET],
        counted: Option<&mut [Counts; PACKET]>,
    ) {
        // Counts as the single walk keeps them: every node a ray enters, the root only if
        // one of its children's boxes is hit, and the triangles it tests until its hit.
        let mut none = [Counts::default(); PACKET];
        let counting = counted.is_some();
        let counts = counted.unwrap_or(&mut none);
        let n = rays.len().min(PACKET);
        let wide = &self.wide;
        if wide.nodes.is_empty() || n == 0 {
            return;
        }
        // Rays past `n` repeat the first one and are never live. Loops, not `array::from_fn`:
        // its closures are not compiled for AVX2, and were called once per ray.
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
        let cull = tmax.map(cull_bound);
        let nodes = &wide.nodes[..];
        let groups = &wide.groups[..];
        // (inner node or first group, triangle count (0: inner), rays that entered it).
        // Uninitialised as in the single walk; only entries below `sp` are read.
        let mut stack = [const { MaybeUninit::<(u32, u32, u32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let (mut child, mut count, mut m) = (0u32, 0u32, live);
        while m != 0 {
            if m & (m - 1) == 0 {
                // One ray left in this subtree: its own walk, nearest first, is cheaper than
                // the packet's bookkeeping for one.
                let r = m.trailing_zeros() as usize;
                if let Some(s) = &shears[r] {
                    // SAFETY: the CPU has AVX2 (see `# Safety`), and `(child, count)` is the
                    // root or a child reference read from the tree.
                    let (hit, c) = unsafe {
                        if counting {
                            self.walk_from::<ANY_COUNTED, true, STACK>(
                                &boxes[r],
                                s,
                                tmin[r],
                                tmax[r],
                                None,
                                (child, count),
                            )
                        } else {
                            self.walk_from::<ANY, true, STACK>(
                                &boxes[r],
                                s,
                                tmin[r],
                                tmax[r],
                                None,
                                (child, count),
                            )
                        }
                    };
                    if counting {
                        counts[r].nodes += c.nodes;
                        counts[r].tris += c.tris;
                    }
                    if let Some(hit) = hit {
                        out[r] = Some(hit);
                        live &= !(1 << r);
                        if live == 0 {
                            return;
                        }
                    }
                }
            } else if count == 0 {
                // SAFETY: `child` is 0 or an inner child index written by `WideBvh::collapse`.
                let node = unsafe { nodes.get_unchecked(child as usize) };
                let mut rows = 0u64;
                // Each child's nearest entry over the rays that hit it, as an order key.
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
                let kids = nonzero_bytes(cols);
                if kids != 0 {
                    if counting {
                        // A counted packet is an estimate's sample: its children are cold.
                        wide.prefetch_children(node, kids);
                    }
                    // The child nearest to the rays next, as in the single walk, the others
                    // pushed unsorted.
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    let first = unsafe { simd::nearest::<true>(kids, &near) };
                    let mut rest = kids & !(1 << first);
                    while rest != 0 {
                        let k = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        let rays = (cols >> (8 * k)) as u32 & 0xFF;
                        // The stack holds at most `WIDTH - 1` entries per wide level.
                        stack[sp].write((node.child[k], node.count[k], rays));
                        sp += 1;
                    }
                    child = node.child[first];
                    count = node.count[first];
                    m = (cols >> (8 * first)) as u32 & 0xFF;
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
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    let (found, tested) = unsafe { leaf_any(s, leaf, tmin[r], tmax[r], count) };
                    if counting {
                        counts[r].nodes += 1;
                        counts[r].tris += tested;
                    }
                    if let Some(hit) = found {
                        out[r] = Some(hit);
                        live &= !(1 << r);
                    }
                }
                if live == 0 {
                    return;
                }
            }
            // Pop the next node that a live ray entered.
            m = 0;
            while sp > 0 {
                sp -= 1;
                // SAFETY: entries below the old `sp` were written by a push.
                let (c, k, rays) = unsafe { stack[sp].assume_init() };
                if rays & live != 0 {
                    (child, count, m) = (c, k, rays & live);
                    break;
                }
            }
        }
    }
}

/// The first hit among a leaf's `count` triangles (lowest group, then lowest lane), as the
/// single any-hit walk takes it, and how many triangles were tested to find it (the single
/// walk's `T`: the groups tested, not the repeats that fill the last one).
///
/// # Safety
/// The CPU must have AVX2.
#[inline(always)]
unsafe fn leaf_any(
    s: &Shear4,
    leaf: &[Tri4],
    tmin: f32,
    tmax: f32,
    count: u32,
) -> (Option<Hit>, u32) {
    let mut tested = 0;
    let mut j = 0;
    while j < leaf.len() {
        if j + 1 < leaf.len() {
            let (a, b) = (&leaf[j], &leaf[j + 1]);
            tested += (count - 4 * j as u32).min(8);
            // SAFETY: the CPU has AVX2 (see `# Safety`).
            let h = unsafe { s.intersect8(a, b, tmin, tmax) };
            if h.mask != 0 {
                let k = h.mask.trailing_zeros() as usize;
                let prim = if k < 4 { a.prim[k] } else { b.prim[k - 4] };
                let (t, u, v) = h.hit(k);
                return (Some(Hit { t, prim, u, v }), tested);
            }
            j += 2;
            continue;
        }
        let g = &leaf[j];
        tested += (count - 4 * j as u32).min(4);
        let h = s.intersect4(g, tmin, tmax);
        if h.mask != 0 {
            let k = h.mask.trailing_zeros() as usize;
            let (t, u, v) = h.hit(k);
            let hit = Hit {
                t,
                prim: g.prim[k],
                u,
                v,
            };
            return (Some(hit), tested);
        }
        j += 1;
    }
    (None, tested)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::traverse::{Layout, any_hits};
    use crate::{intersect_watertight, testkit, workload};

    /// AO rays (eight from each hit point, so runs that share an origin) and runs with one
    /// origin mixing ranges, a zero direction and an empty range: the packets give each ray
    /// the single walk's answer, hit or miss, and every hit they report is a real one.
    #[test]
    fn rays_walked_together_answer_as_each_alone() {
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").unwrap();
        let mut rays = workload::orbit_ao(&scene, &bvh, 48, 48, 0, 8).rays;
        let mut rng = crate::Rng::new(testkit::seed(29));
        let b = scene.bounds();
        let ext = (b.max - b.min).max_element();
        for _ in 0..300 {
            let o = b.min + (b.max - b.min) * Vec3::new(rng.f32(), rng.f32(), rng.f32());
            for k in 0..1 + rng.below(12) {
                let d = Vec3::from(rng.unit_vector());
                let r = match k % 5 {
                    0 => Ray::new(o, d),
                    1 => Ray::with_range(o, d, 0.0, rng.range(0.0, 0.2) * ext),
                    2 => Ray::new(o, Vec3::ZERO),
                    3 => Ray::with_range(o, d, 0.5 * ext, 0.1 * ext),
                    _ => Ray::with_range(o, d, rng.range(0.0, 0.05) * ext, 0.3 * ext),
                };
                rays.push(&r);
            }
        }
        let any = any_hits(&bvh, &rays);
        let mut hits = 0;
        for i in 0..rays.len() {
            let r = rays.get(i);
            let alone = bvh.any_hit_in(&r, Layout::Wide);
            assert_eq!(any.get(i).is_some(), alone.is_some(), "ray {i} {r:?}");
            if let Some((t, prim)) = any.get(i) {
                hits += 1;
                let [a, b, c] = scene.vertices(prim as usize);
                let shear = RayShear::new(r.origin, r.dir).unwrap();
                let again = intersect_watertight(
                    &shear,
                    &a.to_array(),
                    &b.to_array(),
                    &c.to_array(),
                    r.tmin,
                    r.tmax,
                );
                assert_eq!(again.map(|h| h.0.to_bits()), Some(t.to_bits()), "ray {i}");
            }
        }
        assert!(
            hits > 200 && hits < rays.len() - 200,
            "{hits} of {}",
            rays.len()
        );
    }

    #[test]
    fn the_transpose_moves_every_bit_and_the_byte_flags_match() {
        let mut rng = crate::Rng::new(crate::testkit::seed(23));
        for _ in 0..2_000 {
            let x = rng.next_u64();
            let y = transpose8(x);
            for r in 0..8 {
                for k in 0..8 {
                    assert_eq!((x >> (8 * r + k)) & 1, (y >> (8 * k + r)) & 1, "{x:#x}");
                }
                assert_eq!(nonzero_bytes(x) >> r & 1 != 0, (x >> (8 * r)) & 0xFF != 0);
            }
        }
    }
}
