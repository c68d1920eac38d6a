//! Stack-based traversal of the flat binary [`Bvh`], near child first (pbrt-v4's
//! `BVHAggregate::Intersect`, with sibling pairs tested together): every query of `mode.rs`
//! in one loop, specialised at compile time.
//!
//! `B` counts nodes *entered* (the root, if its box is hit, and every child whose box is hit);
//! entering an inner node costs two child box tests, entering a leaf `count` triangle tests.
//! The reduced traversal never fetches a triangle, so its ray is never shortened: `T` counts
//! the triangles of the leaves it reaches. The first-leaf walk ends each ray where it leaves
//! the first leaf it reaches, children taken in the fixed order of [`near_child_first`].
//!
//! The ray/box test is Ize's conservative one (`slab.rs`), both children of a node at
//! once. Sibling pairs are 64-byte aligned ([`crate::bvh::NodeArray`]), so a step reads one
//! cache line.

use crate::bvh::Bvh;
use crate::bvh::node::Node;
use crate::ray::{Hit, Ray};
use crate::slab::BoxRay;
use crate::traverse::closest::{better, cull_bound};
use crate::traverse::counts::Counts;
use crate::traverse::mode::{ANY, ANY_COUNTED, COUNTED, FIRST_LEAF, REDUCED};
use crate::traverse::walk::near_child_first;
use crate::triangle::{RayShear, intersect_watertight};

impl Bvh {
    #[inline(always)]
    pub(super) fn run_binary<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        if self.depth <= 64 {
            self.traverse::<MODE, 64>(ray)
        } else {
            self.traverse::<MODE, { crate::bvh::MAX_DEPTH }>(ray)
        }
    }

    #[inline(always)]
    fn traverse<const MODE: u8, const STACK: usize>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        let mut counts = Counts::default();
        let Some(shear) = RayShear::new(ray.origin, ray.dir) else {
            return (None, counts);
        };
        // NaN-safe: a NaN or empty range traces nothing.
        if ray.tmin.partial_cmp(&ray.tmax).is_none_or(|o| o.is_gt()) {
            return (None, counts);
        }
        let (tmin, tmax) = (ray.tmin, ray.tmax);
        let reduced = MODE == REDUCED || MODE == FIRST_LEAF;
        // The reduced traversals bound boxes by `best_t` itself (the first-leaf walk shortens
        // it); the hit queries by `cull_bound` of the nearest hit.
        let mut best_t = if reduced { tmax } else { cull_bound(tmax) };
        let mut best: Option<Hit> = None;
        let boxes = BoxRay::new(ray);
        let negative = boxes.negative();
        let nodes = &self.nodes[..];
        let tris = &self.tris[..];
        if tris.is_empty() {
            // The empty tree's lone node is not a pair parent; never walk it.
            return (None, counts);
        }
        if boxes.hit(&nodes[0], tmin, best_t).is_none() {
            return (None, counts);
        }
        let mut stack = [(0u32, 0f32); STACK];
        let mut sp = 0usize;
        let mut i = 0usize;
        loop {
            // SAFETY: `i` is 0 or a child index read from an inner node; `validate`'s invariants
            // (established by `Bvh::build`, and the fields are private) put every child pair
            // `index, index + 1` inside `nodes`.
            let node = unsafe { nodes.get_unchecked(i) };
            if MODE == COUNTED || MODE == ANY_COUNTED || MODE == REDUCED || MODE == FIRST_LEAF {
                counts.nodes += 1;
            }
            if node.is_leaf() {
                if MODE == REDUCED || MODE == FIRST_LEAF {
                    counts.tris += node.count;
                    if MODE == FIRST_LEAF {
                        best_t = boxes.exit(node, best_t);
                    }
                } else {
                    let first = node.index as usize;
                    // SAFETY: leaves own `index .. index + count` of `tris` (validated invariant).
                    let leaf = unsafe { tris.get_unchecked(first..first + node.count as usize) };
                    for t in leaf {
                        if MODE == COUNTED || MODE == ANY_COUNTED {
                            counts.tris += 1;
                        }
                        // The range is the ray's own, not the nearest hit's, so that which
                        // triangles hit does not depend on the walk (see `better`).
                        if let Some((t_hit, u, v)) =
                            intersect_watertight(&shear, &t.v0, &t.v1, &t.v2, tmin, tmax)
                            && better(t_hit, t.prim, best)
                        {
                            best_t = cull_bound(t_hit);
                            best = Some(Hit {
                                t: t_hit,
                                prim: t.prim,
                                u,
                                v,
                            });
                            if MODE == ANY || MODE == ANY_COUNTED {
                                return (best, counts);
                            }
                        }
                    }
                }
            } else {
                let l = node.index as usize;
                // SAFETY: an inner node's children `l, l + 1` are in `nodes` (validated), so
                // the two nodes from `l` are in bounds and form one `[Node; 2]`.
                let pair = unsafe { &*nodes.as_ptr().add(l).cast::<[Node; 2]>() };
                match boxes.hit_pair(pair, tmin, best_t).into() {
                    (Some(a), Some(b)) => {
                        let left = if MODE == FIRST_LEAF {
                            near_child_first(pair, negative)
                        } else {
                            a <= b
                        };
                        let (near, far, t_far) = if left { (l, l + 1, b) } else { (l + 1, l, a) };
                        // The stack never holds more than depth - 1 entries (validated).
                        stack[sp] = (far as u32, t_far);
                        sp += 1;
                        i = near;
                        continue;
                    }
                    (Some(_), None) => {
                        i = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        i = l + 1;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next node, skipping those now beyond the nearest hit (exactly what
            // re-testing their box against the shortened ray would decide).
            loop {
                if sp == 0 {
                    return (best, counts);
                }
                sp -= 1;
                let (next, t_near) = stack[sp];
                if t_near <= best_t {
                    i = next as usize;
                    break;
                }
            }
        }
    }
}
