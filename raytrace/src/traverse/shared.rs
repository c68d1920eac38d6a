//! Rays walked through the wide tree together ([`Bvh::walk_shared`]): any hits, such as the AO
//! rays of one hit point or neighbouring occlusion rays of any origins, and closest hits, such
//! as a pinhole camera's primary rays taken a few neighbours (in Morton order) at a time.
//!
//! Rays of one origin wait on the same nodes near it: short AO rays that mostly miss spend
//! their time proving that nothing is there, one node after another, and a primary ray finds
//! its nodes in the cache (its neighbour just walked them), so it waits less on memory than on
//! its own chain of box test, choice of child and stack. Walked together, a node is fetched
//! once for all of them and their box tests, which do not depend on each other, overlap; rays
//! of one origin, bit for bit, also share each test's first step, the planes less the origin
//! (primary rays 7 %, AO rays 3 % faster on the bunny); AO probes come eight to a hit point,
//! so each eight lanes of a packet keep their own origin. The rays come gathered by lane, and
//! their set-up is made eight at once ([`crate::traverse::lanes`]), then laid out per ray as
//! the box test reads it at every node.
//!
//! A packet holds thirty-two rays: the node's fetch, the choice of child and the stack are
//! paid once for four times as many rays as eight would, and four times as many box tests
//! overlap (single thread, against eight: camera rays 1.02-1.12x, AO probes 1.01-1.13x,
//! shuffled AO rays 1.06-1.15x on Sibenik, the bunny, Conference and the dragon; sixteen
//! gained about half as much, and four measured 0.77-0.82x of eight on camera rays).
//!
//! Each ray still makes exactly the box tests it makes alone: a node is entered with the set
//! of rays that hit its box in its parent's test (a bit per ray), and each of those tests the
//! node's eight children with its own range and culling bound.
//! - Any hit: a ray leaves every set once it has found a hit. So the packet's answer for each
//!   ray, hit or miss, is the single walk's; which triangle an occluded ray reports may
//!   differ, since the order differs, as any-hit queries allow.
//! - Closest hit: a leaf is tested by each ray that entered it, every triangle of it. The
//!   answer does not depend on the order: the closest hit is the smallest `(t, primitive id)`
//!   among the triangles the watertight test accepts in the ray's `[tmin, tmax]` (see
//!   [`crate::traverse::wide`]), every box on the path to that triangle passes the test with
//!   any bound at or beyond its distance, and the packet drops a ray from a node only where
//!   the ray's own bound is nearer than the node's entry. So each ray's hit is its single
//!   walk's, bit for bit, ties included.

use std::mem::MaybeUninit;

use crate::bvh::Bvh;
use crate::bvh::wide::{Tri4, WIDTH};
use crate::ray::Hit;
use crate::traverse::closest::cull_bound;
use crate::traverse::counts::Counts;
use crate::traverse::lanes::{GROUPS, Lanes, PACKET, Setup};
use crate::traverse::mode::{ANY, ANY_COUNTED, COUNTED};
use crate::traverse::simd::{self, Rel8, fold, pair_prim};

impl Bvh {
    /// The hits `MODE` asks for (closest or any, counted or not) of the first `n` rays of
    /// `lanes` (one to [`PACKET`]) into `out[..n]`, their set-up made in `setup`,
    /// each `None` on a miss, and, where `MODE` counts, each ray's counts added to `counts`
    /// as the single walk keeps them: every node a ray enters, the root only if one of its
    /// children's boxes is hit, and the triangles it tests (for any hit, until its hit).
    ///
    /// # Safety
    /// The CPU must have AVX2, the stack hold `STACK` entries for this tree (as
    /// [`Bvh::wide_each`] sizes it), and, for closest hits, every ray's `tmin` have its sign
    /// bit clear where its range is not empty (entry distances are then ordered by their
    /// bits, which the culling of a waiting node relies on).
    #[inline(always)]
    pub(crate) unsafe fn walk_shared<const MODE: u8, const STACK: usize>(
        &self,
        lanes: &Lanes,
        n: usize,
        setup: &mut Setup,
        out: &mut [Option<Hit>; PACKET],
        counts: &mut [Counts; PACKET],
    ) {
        let any = MODE == ANY || MODE == ANY_COUNTED;
        let counting = MODE == COUNTED || MODE == ANY_COUNTED;
        let n = n.min(PACKET);
        // The nearest hit so far of each ray, which the walk keeps in place.
        let best = out;
        best[..n].fill(None);
        let wide = &self.wide;
        if wide.nodes.is_empty() || n == 0 {
            return;
        }
        // SAFETY: the CPU has AVX2 (see `# Safety`).
        unsafe { setup.set(lanes, n) };
        let setup = &*setup;
        let mut live = setup.valid;
        let boxes = setup.boxes();
        let (tmin, tmax) = (lanes.tmin, lanes.tmax);
        // Only rays that trace at all (`setup.valid`) are ever in a node's set, so every ray
        // met below has a meaningful set-up.
        // Rays of one origin, bit for bit, share the first step of every box test.
        let (origins, one_origin) = (lanes.group_origins::<GROUPS>(), setup.one_origin);
        // Whether a later group of eight holds rays of another origin than the first's.
        let groups_apart = origins
            .iter()
            .enumerate()
            .any(|(g, o)| n > 8 * g && o.map(f32::to_bits) != origins[0].map(f32::to_bits));
        // The origins a leaf's pairs are taken less once for their rays, and the shift from a
        // lane to its group: one origin for all, one per eight lanes, or one per four (the AO
        // rays of a hit four at a time).
        let quads;
        let shared: Option<(&[[f32; 3]], u32)> = if one_origin {
            Some((&origins, if groups_apart { 3 } else { 5 }))
        } else if setup.quad_origin {
            quads = lanes.group_origins::<{ PACKET / 4 }>();
            Some((&quads, 2))
        } else {
            None
        };
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
                // One ray left in this subtree: its own walk (from its nearest hit so far, for
                // a closest hit) is cheaper than the packet's bookkeeping for one.
                let r = m.trailing_zeros() as usize;
                let seed = if any { None } else { best[r] };
                // SAFETY: the CPU has AVX2 (see `# Safety`), and `(child, count)` is the
                // root or a child reference read from the tree.
                let (hit, c) = unsafe {
                    self.walk_from::<MODE, true, STACK>(
                        &boxes[r],
                        &setup.shear(r),
                        tmin[r],
                        tmax[r],
                        seed,
                        (child, count),
                    )
                };
                if counting {
                    counts[r].nodes += c.nodes;
                    counts[r].tris += c.tris;
                }
                if let Some(h) = hit {
                    best[r] = Some(h);
                    cull[r] = cull_bound(h.t);
                    if any {
                        live &= !(1 << r);
                    }
                }
            } else if count == 0 {
                // SAFETY: `child` is 0 or an inner child index written by `WideBvh::collapse`.
                let node = unsafe { nodes.get_unchecked(child as usize) };
                // SAFETY: the CPU has AVX2 (see `# Safety`); `relative` is taken from every
                // ray's origin.
                let h = unsafe {
                    macro_rules! test {
                        ($near:literal) => {
                            if one_origin {
                                if groups_apart {
                                    // Written out: through a closure, the first step
                                    // would not be inlined, as it is not compiled for AVX2.
                                    let rels = [
                                        simd::relative(node, &origins[0]),
                                        simd::relative(node, &origins[1]),
                                        simd::relative(node, &origins[2]),
                                        simd::relative(node, &origins[3]),
                                    ];
                                    simd::packet_node::<false, true, $near, PACKET, GROUPS>(
                                        boxes,
                                        m,
                                        std::array::from_fn(|h| rels[h].rows()),
                                        &tmin,
                                        &cull,
                                    )
                                } else {
                                    let rel = simd::relative(node, &origins[0]);
                                    simd::packet_node::<false, false, $near, PACKET, GROUPS>(
                                        boxes,
                                        m,
                                        [rel.rows(); GROUPS],
                                        &tmin,
                                        &cull,
                                    )
                                }
                            } else {
                                simd::packet_node::<true, false, $near, PACKET, GROUPS>(
                                    boxes,
                                    m,
                                    [&node.planes; GROUPS],
                                    &tmin,
                                    &cull,
                                )
                            }
                        };
                    }
                    // Closest hits: each child's nearest entry over the rays that hit it, the
                    // order key and the bound a waiting child is culled by. Any hits take
                    // neither.
                    if any { test!(false) } else { test!(true) }
                };
                if counting {
                    let met = h.cols.iter().fold(0, |a, &c| a | c);
                    let mut each = m;
                    while each != 0 {
                        let r = each.trailing_zeros() as usize;
                        each &= each - 1;
                        if child != 0 || met & (1 << r) != 0 {
                            counts[r].nodes += 1;
                        }
                    }
                }
                let (cols, near) = (h.cols, h.near);
                let mut kids = h.kids;
                if kids != 0 {
                    if counting {
                        // A counted packet is an estimate's sample: its children are cold.
                        wide.prefetch_children(node, kids);
                    }
                    // A macro, not a closure: a closure is not compiled for AVX2.
                    macro_rules! push {
                        ($k:expr) => {{
                            let k: usize = $k;
                            let rays = cols[k];
                            // The stack holds at most `WIDTH - 1` entries per wide level.
                            stack[sp].write((node.child[k], node.count[k], rays, near[k]));
                            sp += 1;
                        }};
                    }
                    // Any-hit rays take the first child next and push the others in slot
                    // order: most short AO rays miss, and a miss enters every child its rays
                    // hit whatever the order, so the packet's per-ray fold of entries into a
                    // nearest child cost more than it saved (single thread, AO probes and
                    // shuffled AO rays: 4-9 % faster on Sibenik, the bunny, Conference and
                    // the dragon; ordering by the box's distance from a shared origin, once a
                    // node, gained nothing). Closest-hit rays take the nearest first and push
                    // the others farthest first, keys compared as bits, as `packet_node` made
                    // them.
                    let first = if any {
                        let first = kids.trailing_zeros() as usize;
                        let mut rest = kids & !(1 << first);
                        while rest != 0 {
                            push!(rest.trailing_zeros() as usize);
                            rest &= rest - 1;
                        }
                        first
                    } else {
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
                            push!(k);
                        }
                        order[0]
                    };
                    child = node.child[first];
                    count = node.count[first];
                    m = cols[first];
                    continue;
                }
            } else {
                let first = child as usize;
                let g = count.div_ceil(4) as usize;
                // SAFETY: a leaf's `ceil(count / 4)` groups from `child` were pushed by
                // `WideBvh::collapse` when it wrote the leaf.
                let leaf = unsafe { groups.get_unchecked(first..first + g) };
                // SAFETY: the CPU has AVX2 (see `# Safety`); each ray of `shared`'s groups
                // starts at its group's origin, bit for bit (`one_origin`, `quad_origin`).
                let changed = unsafe {
                    packet_leaf::<MODE>(setup, leaf, count, shared, m, (&tmin, &tmax), best, counts)
                };
                let mut each = changed;
                while each != 0 {
                    let r = each.trailing_zeros() as usize;
                    each &= each - 1;
                    if let Some(hit) = best[r] {
                        cull[r] = cull_bound(hit.t);
                    }
                }
                if any {
                    live &= !changed;
                }
            }
            if live == 0 {
                // Every any-hit ray has found its hit.
                break;
            }
            // Pop the next node that a live ray entered (closest hits: a ray whose nearest hit
            // is not closer than the node).
            m = 0;
            while sp > 0 {
                sp -= 1;
                // SAFETY: entries below the old `sp` were written by a push.
                let (c, k, rays, t_near) = unsafe { stack[sp].assume_init() };
                let keep = if any {
                    rays & live
                } else {
                    // `t_near` is at most each of these rays' own entry (the ordering of bits
                    // is that of the floats here, see `# Safety`).
                    // SAFETY: the CPU has AVX2 (see `# Safety`).
                    rays & unsafe { simd::within(t_near, &cull) }
                };
                if keep != 0 {
                    (child, count, m) = (c, k, keep);
                    break;
                }
            }
        }
    }
}

/// A leaf tested by the rays `m` of a packet. Each ray makes the single walk's tests in its
/// order, with its bits, a pair of triangle groups at a time (an any-hit ray stopping at its
/// first hit); its hits fold into `best` and its counts into `counts` as
/// [`simd::leaf_hits`] does.
/// Returns the rays whose `best` changed.
///
/// Rays share what the tests allow. Where the packet's groups of lanes each start at one origin
/// (`shared`: the groups' origins, and the shift from a lane to its group: 5 for one group of
/// all, 3 for groups of eight, 2 for groups of four), a pair's vertices less an origin are
/// taken once for the rays from it ([`Rel8`]) where two or more still test the pair. A lone
/// group (most of a small mesh's leaves hold four triangles or fewer) is tested by two rays in
/// one eight-lane pass.
///
/// # Safety
/// The CPU must have AVX2, and with `shared`, each ray of `m` start at its group's origin, bit
/// for bit.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn packet_leaf<const MODE: u8>(
    setup: &Setup,
    leaf: &[Tri4],
    count: u32,
    shared: Option<(&[[f32; 3]], u32)>,
    m: u32,
    (tmin, tmax): (&[f32; PACKET], &[f32; PACKET]),
    best: &mut [Option<Hit>; PACKET],
    counts: &mut [Counts; PACKET],
) -> u32 {
    let any = MODE == ANY || MODE == ANY_COUNTED;
    let counting = MODE == COUNTED || MODE == ANY_COUNTED;
    if counting {
        let mut each = m;
        while each != 0 {
            counts[each.trailing_zeros() as usize].nodes += 1;
            each &= each - 1;
        }
    }
    // The rays still testing the leaf (any-hit rays leave it at their hit), and those whose
    // nearest hit changed.
    let (mut each, mut changed) = (m, 0u32);
    // A macro, not a closure: a closure is not compiled for AVX2.
    macro_rules! fold {
        ($r:expr, $h:expr, $lanes:expr, $prim:expr, $tested:expr) => {{
            let r: usize = $r;
            if counting {
                counts[r].tris += $tested;
            }
            if fold(any, $h, $lanes, $prim, &mut best[r]) {
                changed |= 1 << r;
                if any {
                    each &= !(1 << r);
                }
            }
        }};
    }
    let n = leaf.len();
    let mut j = 0;
    while j < n && each != 0 {
        if j + 1 < n {
            let (a, b) = (&leaf[j], &leaf[j + 1]);
            let tested = (count - 4 * j as u32).min(8);
            let mut rows = [const { MaybeUninit::<Rel8>::uninit() }; PACKET / 4];
            let mut made = 0u32;
            let mut rays = each;
            while rays != 0 {
                let r = rays.trailing_zeros() as usize;
                rays &= rays - 1;
                let s = setup.shear(r);
                // SAFETY: the CPU has AVX2 (see `# Safety`); a group's rows are made from its
                // origin, which each of its rays starts at.
                let h = unsafe {
                    match shared {
                        Some((origins, shift)) => {
                            let g = r >> shift;
                            let group = (((1u64 << (1 << shift)) - 1) << (g << shift)) as u32;
                            if made & (1 << g) != 0 {
                                s.intersect8_rel(rows[g].assume_init_ref(), tmin[r], tmax[r])
                            } else if rays & group != 0 {
                                // Another ray of the group will test the pair: share the
                                // first step.
                                made |= 1 << g;
                                let rel = rows[g].write(Rel8::new(a, b, &origins[g]));
                                s.intersect8_rel(rel, tmin[r], tmax[r])
                            } else {
                                s.intersect8(a, b, tmin[r], tmax[r])
                            }
                        }
                        None => s.intersect8(a, b, tmin[r], tmax[r]),
                    }
                };
                fold!(r, &h, u32::MAX, |k| pair_prim(a, b, k), tested);
            }
            j += 2;
        } else {
            let g = &leaf[j];
            let tested = (count - 4 * j as u32).min(4);
            let mut rays = each;
            while rays != 0 {
                let r = rays.trailing_zeros() as usize;
                rays &= rays - 1;
                if rays == 0 {
                    let h = setup.shear(r).intersect4(g, tmin[r], tmax[r]);
                    fold!(r, &h, u32::MAX, |k| g.prim[k], tested);
                    break;
                }
                let q = rays.trailing_zeros() as usize;
                rays &= rays - 1;
                // SAFETY: the CPU has AVX2 (see `# Safety`).
                let h = unsafe {
                    let (sr, sq) = (setup.shear(r), setup.shear(q));
                    sr.intersect_two(&sq, g, [tmin[r], tmin[q]], [tmax[r], tmax[q]])
                };
                fold!(r, &h, 0xf, |k| g.prim[k % 4], tested);
                fold!(q, &h, 0xf0, |k| g.prim[k % 4], tested);
            }
            j += 1;
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::traverse::{Layout, any_hits, closest_hits};
    use crate::{Ray, RayBatch, testkit, workload};

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
                let again = testkit::retest(&scene, prim, &r);
                assert_eq!(again.map(f32::to_bits), Some(t.to_bits()), "ray {i}");
            }
        }
        assert!(
            hits > 200 && hits < rays.len() - 200,
            "{hits} of {}",
            rays.len()
        );
    }

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
