//! Traversal of the 4-wide tree ([`crate::bvh::wide`]): the closest-hit, any-hit and counted
//! queries of [`crate::traverse`], four child boxes and four triangles per step.
//!
//! The closest hit is the smallest `(t, primitive id)` among the triangles the watertight test
//! accepts in `[tmin, tmax]`; neither the tree's shape nor the order the nodes are visited in
//! changes it, so the wide and the binary traversal return the same hit, bit for bit.
//!
//! Children hit are visited nearest first; the others wait on a stack with their entry
//! distance and are dropped when the nearest hit so far is closer.
//!
//! `B` counts nodes entered as in the binary traversal: the root, if one of its children's
//! boxes is hit, and every child (inner or leaf) taken from the stack, whose boxes are the
//! binary tree's; `T` counts the
//! triangles of the leaves tested (not the repeats that fill a leaf's last group).

use std::mem::MaybeUninit;

use crate::bvh::Bvh;
use crate::simd4::{Box4Ray, Shear4};
use crate::traverse::{ANY, ANY_COUNTED, COUNTED, Counts, better, cull_bound};
use crate::triangle::RayShear;
use crate::{Hit, Ray};

impl Bvh {
    /// The wide tree's answer to a closest-hit, any-hit or counted query (`MODE` as in
    /// [`crate::traverse`]).
    #[inline(always)]
    pub(crate) fn run_wide<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        // Each wide node on the path pushes at most three children, and the wide tree is no
        // deeper than the binary one.
        if self.depth <= 64 {
            self.traverse_wide::<MODE, { 3 * 64 }>(ray)
        } else {
            self.traverse_wide::<MODE, { 3 * crate::bvh::MAX_DEPTH }>(ray)
        }
    }

    #[inline(always)]
    fn traverse_wide<const MODE: u8, const STACK: usize>(
        &self,
        ray: &Ray,
    ) -> (Option<Hit>, Counts) {
        let counted = MODE == COUNTED || MODE == ANY_COUNTED;
        let any = MODE == ANY || MODE == ANY_COUNTED;
        let mut counts = Counts::default();
        let Some(shear) = RayShear::new(ray.origin, ray.dir) else {
            return (None, counts);
        };
        // NaN-safe: a NaN or empty range traces nothing.
        if ray.tmin.partial_cmp(&ray.tmax).is_none_or(|o| o.is_gt()) {
            return (None, counts);
        }
        let wide = &self.wide;
        if wide.nodes.is_empty() {
            return (None, counts);
        }
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        let mut best: Option<Hit> = None;
        let mut cull = cull_bound(tmax);
        let boxes = Box4Ray::new(ray);
        let shear = Shear4::new(shear);
        let nodes = &wide.nodes[..];
        let groups = &wide.groups[..];
        // (inner node or first group, triangle count (0: inner), entry distance).
        // Left uninitialised: zeroing a few kilobytes per ray costs more than a short ray's
        // whole walk. Only entries below `sp` are read, and each was written first.
        let mut stack = [const { MaybeUninit::<(u32, u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let (mut child, mut count) = (0u32, 0u32);
        loop {
            if counted {
                counts.nodes += 1;
            }
            if count == 0 {
                // SAFETY: `child` is 0 or an inner child index written by `WideBvh::collapse`,
                // which only writes indices of nodes it pushed.
                let node = unsafe { nodes.get_unchecked(child as usize) };
                let (mask, near) = boxes.hit4(node, tmin, cull);
                if mask == 0 && child == 0 {
                    // The root's own box is not tested (its children's are, at once): a ray
                    // that meets none of them has entered nothing.
                    return (None, Counts::default());
                }
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        (child, count) = (node.child[first], node.count[first]);
                        continue;
                    }
                    // Two to four children: order them nearest first (ties by slot, so the
                    // walk is deterministic), push all but the nearest, farthest first.
                    let mut hit = [(0usize, 0f32); 4];
                    let mut n = 0;
                    for (k, &t) in near.iter().enumerate() {
                        if mask & (1 << k) != 0 {
                            let mut j = n;
                            while j > 0 && hit[j - 1].1 > t {
                                hit[j] = hit[j - 1];
                                j -= 1;
                            }
                            hit[j] = (k, t);
                            n += 1;
                        }
                    }
                    for &(k, t) in hit[1..n].iter().rev() {
                        // The stack never holds more than 3 entries per wide level (see above).
                        stack[sp].write((node.child[k], node.count[k], t));
                        sp += 1;
                    }
                    let k = hit[0].0;
                    (child, count) = (node.child[k], node.count[k]);
                    continue;
                }
            } else {
                let first = child as usize;
                let n = count.div_ceil(4) as usize;
                // SAFETY: a leaf's `ceil(count / 4)` groups from `child` were pushed by
                // `WideBvh::collapse` when it wrote the leaf.
                let leaf = unsafe { groups.get_unchecked(first..first + n) };
                for (j, g) in leaf.iter().enumerate() {
                    if counted {
                        counts.tris += (count - 4 * j as u32).min(4);
                    }
                    let h = shear.intersect4(g, tmin, tmax);
                    let mut m = h.mask;
                    while m != 0 {
                        let k = m.trailing_zeros() as usize;
                        m &= m - 1;
                        if better(h.t[k], g.prim[k], best) {
                            best = Some(Hit {
                                t: h.t[k],
                                prim: g.prim[k],
                                u: h.u[k],
                                v: h.v[k],
                            });
                            if any {
                                return (best, counts);
                            }
                            cull = cull_bound(h.t[k]);
                        }
                    }
                }
            }
            // Pop the next node, skipping those now beyond the nearest hit.
            loop {
                if sp == 0 {
                    return (best, counts);
                }
                sp -= 1;
                // SAFETY: entries below the old `sp` were written by a push.
                let (c, n, t_near) = unsafe { stack[sp].assume_init() };
                if t_near <= cull {
                    (child, count) = (c, n);
                    break;
                }
            }
        }
    }
}
