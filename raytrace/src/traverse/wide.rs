//! Traversal of the 8-wide tree ([`crate::bvh::wide`]): the closest-hit, any-hit and counted
//! queries of [`crate::traverse`], eight child boxes and four triangles per step (eight, a
//! leaf's two groups at once, where AVX2 runs).
//!
//! The closest hit is the smallest `(t, primitive id)` among the triangles the watertight test
//! accepts in `[tmin, tmax]`; neither the tree's shape nor the order the nodes are visited in
//! changes it, so the wide and the binary traversal return the same hit, bit for bit.
//!
//! Children hit are visited nearest first; the others wait on a stack with their entry
//! distance and are dropped when the nearest hit so far is closer. Any-hit queries take the
//! nearest child next too, but push the others in slot order, unsorted: the first hit ends
//! the walk, so the order of the rest matters less than sorting them costs (single-thread
//! CPU time, AO rays: 5–10 % faster on forest, hairball and the dragon, the same elsewhere).
//! Taking the first slot next instead of the nearest measured 5 % slower on the bunny and
//! Sibenik, rooms and closed surfaces where the nearest box holds the likeliest occluder.
//! Where AVX2 runs, the nearest is found in one pass over the eight distances
//! ([`simd::nearest`]), to within eight units in the last place, instead of a loop whose
//! compares mispredict.
//!
//! A batch of any-hit queries walks every thirty-two consecutive rays together where AVX2
//! runs ([`crate::traverse::shared`]): the AO rays of one hit point wait on the same nodes,
//! which the packet fetches once, and rays of other origins share at least the upper levels
//! (two threads, shuffled AO rays: 10–15 % faster than packets of one origin only).
//! Closest-hit batches walk each run of up to thirty-two consecutive rays of one origin
//! together: a pinhole camera's neighbouring rays enter mostly the same nodes, and their box
//! tests overlap instead of each waiting on its own (single-thread CPU time, primary rays:
//! 5–22 % less on every scene measured).
//!
//! `B` counts nodes entered as in the binary traversal: the root, if one of its children's
//! boxes is hit, and every child (inner or leaf) taken from the stack, whose boxes are the
//! binary tree's; `T` counts the triangles of the leaves tested (not the repeats that fill a
//! leaf's last group). Counted batches walk in packets as the uncounted ones do, and count
//! what each ray did there: the estimate's sample is counted as the trace it stands for walks
//! it. A closest-hit ray in a packet may enter a node its single walk would have culled, so
//! its counts can differ from [`Bvh::closest_hit_counted`]'s; its hit does not.

use std::mem::MaybeUninit;

use crate::bvh::Bvh;
use crate::bvh::wide::WIDTH;
use crate::ray::{Hit, Ray};
use crate::traverse::closest::cull_bound;
use crate::traverse::counts::Counts;
#[cfg(target_arch = "x86_64")]
use crate::traverse::lanes::{Lanes, PACKET, Setup};
use crate::traverse::mode::{ANY, ANY_COUNTED, COUNTED};
use crate::traverse::simd::{self, Box8Ray, Shear4, leaf_hits};
use crate::traverse::source::Source;
use crate::triangle::RayShear;

/// Wide levels the common traversal's stack is sized for (under 4 KiB of entries); deeper
/// trees take [`Bvh::run_wide_deep`] and its larger stack.
const SHALLOW: usize = 32;

/// Stack entries for a wide tree of `levels` levels: each node on the path leaves at most
/// `WIDTH - 1` children on the stack, and holds one more briefly.
const fn stack_for(levels: usize) -> usize {
    (WIDTH - 1) * levels + 1
}

impl Bvh {
    /// The wide tree's answer to a closest-hit, any-hit or counted query (`MODE` as in
    /// [`crate::traverse`]), with the SSE box test, inlined into the caller.
    ///
    /// One ray at a time takes no AVX2: that needs a call into a function compiled for it
    /// per ray, which measured slower than the SSE test inlined. Batches take it a chunk of
    /// rays per call ([`Bvh::wide_each`]).
    #[inline(always)]
    pub(crate) fn run_wide<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        if self.wide.depth > SHALLOW {
            return self.run_wide_deep::<MODE>(ray);
        }
        // SAFETY: the SSE kernels need nothing beyond the x86_64 baseline.
        unsafe { self.traverse_wide::<MODE, false, { stack_for(SHALLOW) }>(ray) }
    }

    /// [`Bvh::run_wide`] on a tree deeper than [`SHALLOW`], kept out of line so that its
    /// larger stack does not grow the common case's frame.
    #[inline(never)]
    fn run_wide_deep<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        // SAFETY: the SSE kernels need nothing beyond the x86_64 baseline.
        unsafe { self.traverse_wide::<MODE, false, { stack_for(crate::bvh::MAX_DEPTH) }>(ray) }
    }

    /// `MODE`'s query of rays `at(0), …, at(n - 1)` of `rays` (`None`: skipped), each answer
    /// handed to `put(k, hit, counts)`. Where the CPU has AVX2, the whole run is one call into
    /// a loop compiled for it, so the eight-box test is one AVX2 pass, inlined: every batch
    /// query (hits, counted hits, hits of all but a sample) goes through here, so that none
    /// pays the single-ray SSE test.
    #[inline(always)]
    pub(crate) fn wide_each<const MODE: u8>(
        &self,
        rays: &(impl Source + ?Sized),
        n: usize,
        at: impl FnMut(usize) -> Option<usize>,
        put: impl FnMut(usize, Option<Hit>, Counts),
    ) {
        if self.wide.depth <= SHALLOW && simd::avx2() {
            // SAFETY: the CPU has AVX2, just checked, and the tree is shallow.
            unsafe { self.wide_each_avx2::<MODE, _>(rays, n, at, put) }
        } else {
            each(n, at, put, |i| self.run_wide::<MODE>(&rays.ray(i)));
        }
    }

    /// # Safety
    /// The CPU must have AVX2, and the tree be no deeper than [`SHALLOW`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2"))]
    unsafe fn wide_each_avx2<const MODE: u8, S: Source + ?Sized>(
        &self,
        rays: &S,
        n: usize,
        at: impl FnMut(usize) -> Option<usize>,
        put: impl FnMut(usize, Option<Hit>, Counts),
    ) {
        // Every query, the counted ones too, so that an estimate's sample is traced (and
        // counted) as the trace it stands for.
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as the caller states (see `# Safety`).
        unsafe {
            self.shared_runs::<MODE, S>(rays, n, at, put)
        }
        #[cfg(not(target_arch = "x86_64"))]
        each(n, at, put, |i| {
            // SAFETY: as the caller states (see `# Safety`).
            unsafe { self.traverse_wide::<MODE, true, { stack_for(SHALLOW) }>(&rays.ray(i)) }
        });
    }

    /// Any or closest hits (`MODE`) of rays `at(0), …, at(n - 1)`, walked together
    /// ([`Bvh::walk_shared`]) [`PACKET`] consecutive rays at a time for any hits, each run of up
    /// to [`PACKET`] consecutive rays with one origin for closest hits; a ray alone takes the
    /// single walk.
    ///
    /// # Safety
    /// The CPU must have AVX2, and the tree be no deeper than [`SHALLOW`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn shared_runs<const MODE: u8, S: Source + ?Sized>(
        &self,
        rays: &S,
        n: usize,
        mut at: impl FnMut(usize) -> Option<usize>,
        mut put: impl FnMut(usize, Option<Hit>, Counts),
    ) {
        let any = MODE == ANY || MODE == ANY_COUNTED;
        let counting = MODE == COUNTED || MODE == ANY_COUNTED;
        // The run so far: its rays' batch indices and the queries they answer; its rays are
        // gathered into lanes when it is walked.
        let mut run = Lanes::ZERO;
        let mut idx = [0usize; PACKET];
        let mut slot = [0usize; PACKET];
        let mut len = 0usize;
        // Each packet's set-up and answers, kept between packets rather than made anew.
        let mut setup = Setup::ZERO;
        let mut out = [None; PACKET];
        let mut counts = [Counts::default(); PACKET];
        // A macro, not a closure: a closure is not compiled for AVX2, so the kernels would
        // not inline into it.
        macro_rules! flush {
            () => {
                if len == 1 {
                    // SAFETY: as the caller states (see `# Safety`).
                    let (hit, counts) = unsafe {
                        self.traverse_wide::<MODE, true, { stack_for(SHALLOW) }>(&rays.ray(idx[0]))
                    };
                    put(slot[0], hit, counts);
                } else {
                    // SAFETY: as the caller states (see `# Safety`).
                    unsafe { rays.gather(&mut run, &idx[..len]) };
                    if counting {
                        counts[..len].fill(Counts::default());
                    }
                    // SAFETY: as the caller states; the stack is sized as the single walk's,
                    // and a closest-hit run's rays have `tmin`s with the sign bit clear.
                    unsafe {
                        self.walk_shared::<MODE, { stack_for(SHALLOW) }>(
                            &run,
                            len,
                            &mut setup,
                            &mut out,
                            &mut counts,
                        )
                    };
                    for r in 0..len {
                        put(slot[r], out[r], counts[r]);
                    }
                }
            };
        }
        for k in 0..n {
            let Some(i) = at(k) else { continue };
            if !any {
                // A closest-hit packet culls the nodes it leaves waiting by the entry
                // distances' bits, which order as the floats only where they are not
                // negative: a ray that starts behind its origin (or at -0) walks alone.
                if rays.tmin(i).is_sign_negative() {
                    if len > 0 {
                        flush!();
                        len = 0;
                    }
                    // SAFETY: as the caller states (see `# Safety`).
                    let (hit, counts) = unsafe {
                        self.traverse_wide::<MODE, true, { stack_for(SHALLOW) }>(&rays.ray(i))
                    };
                    put(k, hit, counts);
                    continue;
                }
                // Closest-hit runs keep to one origin (a camera's), whose shared box planes
                // and nearest-first order pay there; any-hit rays of other origins still
                // share the upper nodes, fetched once for the packet.
                if len > 0 && !rays.same_origin(i, idx[0]) {
                    flush!();
                    len = 0;
                }
            }
            // A counted packet is an estimate's sample, whose runs of adjacent rays stand for
            // the trace's packets: rays of two runs never walk together, so that a run's
            // counts do not depend on which run the sample puts beside it.
            if len == PACKET || (counting && len > 0 && i != idx[len - 1] + 1) {
                flush!();
                len = 0;
            }
            idx[len] = i;
            slot[len] = k;
            len += 1;
        }
        if len > 0 {
            flush!();
        }
    }

    /// # Safety
    /// With `AVX2`, the CPU must have AVX2.
    #[inline(always)]
    unsafe fn traverse_wide<const MODE: u8, const AVX2: bool, const STACK: usize>(
        &self,
        ray: &Ray,
    ) -> (Option<Hit>, Counts) {
        let counts = Counts::default();
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
        let boxes = Box8Ray::new(ray);
        let shear = Shear4::new(shear);
        // SAFETY: as the caller states (see `# Safety`); the root is node 0.
        unsafe {
            self.walk_from::<MODE, AVX2, STACK>(&boxes, &shear, ray.tmin, ray.tmax, None, (0, 0))
        }
    }

    /// The walk of [`Bvh::traverse_wide`] from `start` (inner node or first group, triangle
    /// count, 0 for an inner node: the root is `(0, 0)`), for a ray whose range is not empty,
    /// with `seed` the nearest hit found so far (closest-hit queries: the answer is the
    /// nearer of the seed and the subtree's hits).
    ///
    /// # Safety
    /// With `AVX2`, the CPU must have AVX2; `start` must be the root or a child reference of
    /// the wide tree.
    #[inline(always)]
    pub(crate) unsafe fn walk_from<const MODE: u8, const AVX2: bool, const STACK: usize>(
        &self,
        boxes: &Box8Ray,
        shear: &Shear4,
        tmin: f32,
        tmax: f32,
        seed: Option<Hit>,
        start: (u32, u32),
    ) -> (Option<Hit>, Counts) {
        let counted = MODE == COUNTED || MODE == ANY_COUNTED;
        let any = MODE == ANY || MODE == ANY_COUNTED;
        let mut counts = Counts::default();
        let wide = &self.wide;
        let mut best = seed;
        let mut cull = cull_bound(best.map_or(tmax, |h| h.t));
        let nodes = &wide.nodes[..];
        let groups = &wide.groups[..];
        // (inner node or first group, triangle count (0: inner), entry distance).
        // Left uninitialised: zeroing a few kilobytes per ray costs more than a short ray's
        // whole walk. Only entries below `sp` are read, and each was written first.
        let mut stack = [const { MaybeUninit::<(u32, u32, f32)>::uninit() }; STACK];
        let mut sp = 0usize;
        let (mut child, mut count) = start;
        loop {
            if counted {
                counts.nodes += 1;
            }
            if count == 0 {
                // SAFETY: `child` is 0 or an inner child index written by `WideBvh::collapse`,
                // which only writes indices of nodes it pushed.
                let node = unsafe { nodes.get_unchecked(child as usize) };
                // SAFETY: as the caller states (see `# Safety`).
                let (mask, near) = unsafe { boxes.hit8::<AVX2>(node, tmin, cull) };
                if mask == 0 && child == 0 && start == (0, 0) {
                    // The root's own box is not tested (its children's are, at once): a ray
                    // that meets none of them has entered nothing.
                    return (best, Counts::default());
                }
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        (child, count) = (node.child[first], node.count[first]);
                        continue;
                    }
                    if any {
                        // The first hit ends the walk, and the nearest child likeliest holds it:
                        // it goes next (the first slot on a tie), the others wait unsorted.
                        // SAFETY: as the caller states (see `# Safety`).
                        let b = unsafe { simd::nearest::<AVX2>(mask, &near) };
                        let mut m = mask & !(1 << b);
                        while m != 0 {
                            let k = m.trailing_zeros() as usize;
                            m &= m - 1;
                            stack[sp].write((node.child[k], node.count[k], near[k]));
                            sp += 1;
                        }
                        (child, count) = (node.child[b], node.count[b]);
                        continue;
                    }
                    // Two to eight children: order them nearest first (ties by slot, so the
                    // walk is deterministic), push all but the nearest, farthest first.
                    let mut hit = [(0usize, 0f32); WIDTH];
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
                        // The stack holds at most `WIDTH - 1` entries per wide level.
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
                // SAFETY: as the caller states (see `# Safety`).
                let (changed, tested) =
                    unsafe { leaf_hits::<AVX2>(any, shear, leaf, tmin, tmax, count, &mut best) };
                if counted {
                    counts.tris += tested;
                }
                if let (true, Some(hit)) = (changed, best) {
                    if any {
                        return (best, counts);
                    }
                    cull = cull_bound(hit.t);
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

/// `put(k, query(at(k)))` for every `k < n` whose `at(k)` is a ray, inlined into the caller
/// (so into a loop compiled for AVX2 where the caller is one).
#[inline(always)]
fn each(
    n: usize,
    mut at: impl FnMut(usize) -> Option<usize>,
    mut put: impl FnMut(usize, Option<Hit>, Counts),
    query: impl Fn(usize) -> (Option<Hit>, Counts),
) {
    for k in 0..n {
        if let Some(i) = at(k) {
            let (hit, counts) = query(i);
            put(k, hit, counts);
        }
    }
}
