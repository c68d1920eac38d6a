//! Stack-based traversal of the flat [`Bvh`], near child first (pbrt-v4's
//! `BVHAggregate::Intersect`, with sibling pairs tested together).
//!
//! The queries share one loop, specialised at compile time:
//! - [`Bvh::closest_hit`]: the nearest hit;
//! - [`Bvh::any_hit`]: the first hit found, for shadow and AO rays (early exit);
//! - [`Bvh::closest_hit_counted`] and [`Bvh::any_hit_counted`]: the same hits plus the cost
//!   the thesis models, nodes visited `B` and triangle tests `T`;
//! - [`Bvh::reduced_traversal`]: the thesis's *reduced traversal* (section 3.3): boxes only,
//!   never fetching a triangle, so the ray is never shortened; `B` counts the nodes it enters
//!   and `T` the triangles of the leaves it reaches. This is the cost estimator's walk.
//! - [`Bvh::first_leaf_traversal`]: the same, but each ray ends where it leaves the first leaf
//!   it reaches ([`Walk::FirstLeaf`]), children taken in a fixed order ([`near_child_first`]).
//!
//! `B` counts nodes *entered* (the root, if its box is hit, and every child whose box is hit);
//! entering an inner node costs two child box tests, entering a leaf `count` triangle tests.
//!
//! The ray/box test is Ize's conservative one (`slab.rs`), both children of a node at
//! once. Sibling pairs are 64-byte aligned ([`crate::bvh::NodeArray`]), so a step reads one
//! cache line.
//!
//! Batch versions run over a [`RayBatch`] with rayon, in chunks.

mod packet;
#[cfg(target_arch = "x86_64")]
mod shared_any;
#[cfg(target_arch = "x86_64")]
mod shared_closest;
mod simd;
mod walk;
mod wide;

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use crate::bvh::Bvh;
use crate::slab::BoxRay;
use crate::triangle::{RayShear, intersect_watertight};
use crate::{Hit, HitBatch, Ray, RayBatch};

pub use walk::{Walk, near_child_first};

/// Cost counters of one ray: nodes entered `B` and triangles tested (or, in the reduced
/// traversal, triangles in reached leaves) `T`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct Counts {
    /// `B`: nodes entered.
    pub nodes: u32,
    /// `T`: triangle tests.
    pub tris: u32,
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, o: Self) {
        self.nodes += o.nodes;
        self.tris += o.tris;
    }
}

pub(crate) const CLOSEST: u8 = 0;
pub(crate) const ANY: u8 = 1;
pub(crate) const COUNTED: u8 = 2;
const REDUCED: u8 = 3;
const FIRST_LEAF: u8 = 4;
pub(crate) const ANY_COUNTED: u8 = 5;

/// Which tree the hit queries walk. Both give the same closest hits, bit for bit; the any-hit
/// queries may stop at different hits (each returns some hit in range exactly when there is
/// one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layout {
    /// The binary tree, two boxes and one triangle at a time: what the GPU walks.
    Binary,
    /// The 8-wide tree collapsed from it ([`crate::bvh::wide`]), eight boxes and four
    /// triangles at a time: what the CPU queries walk.
    #[default]
    Wide,
}

impl Layout {
    /// The name used on the command line: `binary` or `wide`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Binary => "binary",
            Self::Wide => "wide",
        }
    }
}

impl std::str::FromStr for Layout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        [Self::Binary, Self::Wide]
            .into_iter()
            .find(|l| l.name() == s.trim())
            .ok_or_else(|| format!("unknown BVH layout `{s}` (expected binary or wide)"))
    }
}

/// Whether a hit at `t` on `prim` replaces `best`: the smaller distance, and on equal
/// distances the smaller primitive id, so the closest hit does not depend on the order the
/// tree is walked in.
#[inline(always)]
pub(crate) fn better(t: f32, prim: u32, best: Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && prim < b.prim),
    }
}

/// How far past the nearest hit so far nodes are still entered. A triangle's computed
/// distance and its leaf box's computed entry differ by a few roundings, so a leaf holding a
/// hit at exactly the nearest distance (a tie the primitive id decides) could otherwise be
/// culled by one walk and not by another.
#[inline(always)]
pub(crate) fn cull_bound(t: f32) -> f32 {
    t + t.abs() * (16.0 * crate::spawn::gamma(3))
}

/// Rays per rayon work item: enough to amortise scheduling, small enough to balance.
const CHUNK: usize = 256;

/// How far ahead of the ray being walked a sample read in place is prefetched: two runs of
/// eight. The sampled runs lie apart in the batch, where the hardware prefetchers, which
/// follow streams, do not fetch them, so each run's loads would miss the cache and wait
/// (docs/measurements.md has what that cost the estimate).
const SAMPLE_AHEAD: usize = 16;

impl Bvh {
    /// The nearest hit in `[ray.tmin, ray.tmax]`, if any.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        self.run::<CLOSEST>(ray).0
    }

    /// Some hit in range (the first found), for occlusion queries; stops at the first.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> Option<Hit> {
        self.run::<ANY>(ray).0
    }

    /// True when anything blocks the ray within its range.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.any_hit(ray).is_some()
    }

    /// The nearest hit and the work it took (`B`, `T`); the hit equals [`Bvh::closest_hit`]'s.
    #[inline]
    pub fn closest_hit_counted(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        self.run::<COUNTED>(ray)
    }

    /// Some hit and the work it took to find it (`B`, `T` up to the first hit); the hit
    /// equals [`Bvh::any_hit`]'s.
    #[inline]
    pub fn any_hit_counted(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        self.run::<ANY_COUNTED>(ray)
    }

    /// The thesis's reduced traversal: boxes only, no triangle fetched; see the module docs.
    #[inline]
    pub fn reduced_traversal(&self, ray: &Ray) -> Counts {
        self.run::<REDUCED>(ray).1
    }

    /// The reduced traversal that ends the ray at the exit of the first leaf it reaches.
    #[inline]
    pub fn first_leaf_traversal(&self, ray: &Ray) -> Counts {
        self.run::<FIRST_LEAF>(ray).1
    }

    /// The counts of `walk` for one ray.
    #[inline]
    pub fn walk(&self, ray: &Ray, walk: Walk) -> Counts {
        match walk {
            Walk::Reduced => self.reduced_traversal(ray),
            Walk::FirstLeaf => self.first_leaf_traversal(ray),
            Walk::Trace { any: false } => self.closest_hit_counted(ray).1,
            Walk::Trace { any: true } => self.any_hit_counted(ray).1,
        }
    }

    /// The nearest hit on the tree `layout` names; equal to [`Bvh::closest_hit`]'s.
    #[inline]
    pub fn closest_hit_in(&self, ray: &Ray, layout: Layout) -> Option<Hit> {
        match layout {
            Layout::Binary => self.run_binary::<CLOSEST>(ray).0,
            Layout::Wide => self.run_wide::<CLOSEST>(ray).0,
        }
    }

    /// Some hit in range on the tree `layout` names.
    #[inline]
    pub fn any_hit_in(&self, ray: &Ray, layout: Layout) -> Option<Hit> {
        match layout {
            Layout::Binary => self.run_binary::<ANY>(ray).0,
            Layout::Wide => self.run_wide::<ANY>(ray).0,
        }
    }

    /// The counted queries on the tree `layout` names (`any` for the any-hit one), for
    /// comparing the two trees' work.
    #[inline]
    pub fn counted_in(&self, ray: &Ray, any: bool, layout: Layout) -> (Option<Hit>, Counts) {
        match (layout, any) {
            (Layout::Binary, false) => self.run_binary::<COUNTED>(ray),
            (Layout::Binary, true) => self.run_binary::<ANY_COUNTED>(ray),
            (Layout::Wide, false) => self.run_wide::<COUNTED>(ray),
            (Layout::Wide, true) => self.run_wide::<ANY_COUNTED>(ray),
        }
    }

    /// Hit queries walk the wide tree, which is faster on the CPU; the reduced traversals stay
    /// on the binary tree, the one the GPU walks, so the estimator counts the GPU's work.
    #[inline(always)]
    fn run<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        if MODE == REDUCED || MODE == FIRST_LEAF {
            self.run_binary::<MODE>(ray)
        } else {
            self.run_wide::<MODE>(ray)
        }
    }

    #[inline(always)]
    fn run_binary<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
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
                let pair = unsafe { &*nodes.as_ptr().add(l).cast::<[crate::Node; 2]>() };
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

fn check(rays: &RayBatch) {
    assert!(
        rays.is_consistent(),
        "RayBatch columns have different lengths"
    );
}

fn hits_of<F>(rays: &RayBatch, f: F) -> HitBatch
where
    F: Fn(&Ray) -> Option<Hit> + Sync,
{
    check(rays);
    let n = rays.len();
    let mut out = HitBatch::misses(n);
    out.t
        .par_chunks_mut(CHUNK)
        .zip(out.prim.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (ts, ps))| {
            for (k, (t, p)) in ts.iter_mut().zip(ps.iter_mut()).enumerate() {
                if let Some(h) = f(&rays.get(c * CHUNK + k)) {
                    *t = h.t;
                    *p = h.prim;
                }
            }
        });
    out
}

/// [`hits_of`] on the wide tree, a chunk of rays per call: the loop of [`fill_skipping`]
/// with nothing to skip, so that the full trace, a render's task and the trace left after an
/// estimate's sample run one compiled loop, and their times differ by their rays alone (two
/// copies of the same loop, placed apart in the binary, measured 2–3 % apart on AO rays).
fn wide_hits_of<const MODE: u8>(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    check(rays);
    let mut out = HitBatch::misses(rays.len());
    out.t
        .par_chunks_mut(CHUNK)
        .zip(out.prim.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (ts, ps))| fill_with::<MODE>(bvh, rays, c * CHUNK, &[], ts, ps));
    out
}

/// Closest hits of all rays, in parallel.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn closest_hits(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    wide_hits_of::<CLOSEST>(bvh, rays)
}

/// Any hits of all rays, in parallel (`t` is the distance of the hit found).
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn any_hits(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    wide_hits_of::<ANY>(bvh, rays)
}

/// [`closest_hits`] or, with `any`, [`any_hits`], on the tree `layout` names: for comparing
/// the two trees' speed.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_in(bvh: &Bvh, rays: &RayBatch, any: bool, layout: Layout) -> HitBatch {
    if layout == Layout::Wide {
        return if any {
            wide_hits_of::<ANY>(bvh, rays)
        } else {
            wide_hits_of::<CLOSEST>(bvh, rays)
        };
    }
    if any {
        hits_of(rays, |r| bvh.any_hit_in(r, layout))
    } else {
        hits_of(rays, |r| bvh.closest_hit_in(r, layout))
    }
}

/// Closest hits and per-ray counts, in parallel.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn closest_hits_counted(bvh: &Bvh, rays: &RayBatch) -> (HitBatch, Vec<Counts>) {
    counted_wide::<COUNTED>(bvh, rays, rays.len(), |i| i)
}

/// Closest hits (or, with `any`, any hits) and per-ray counts on the tree `layout` names, in
/// parallel.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_counted_in(
    bvh: &Bvh,
    rays: &RayBatch,
    any: bool,
    layout: Layout,
) -> (HitBatch, Vec<Counts>) {
    counted_at(rays, rays.len(), |first, ts, ps, cs| {
        for k in 0..ts.len() {
            let (hit, counts) = bvh.counted_in(&rays.get(first + k), any, layout);
            put(ts, ps, cs, k, hit, counts);
        }
    })
}

/// Any hits and per-ray counts (up to the first hit found), in parallel.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn any_hits_counted(bvh: &Bvh, rays: &RayBatch) -> (HitBatch, Vec<Counts>) {
    counted_wide::<ANY_COUNTED>(bvh, rays, rays.len(), |i| i)
}

/// The real trace of rays `index[0], index[1], …` of `rays` (any hit with `any`, else the
/// closest), their hits and counts, in parallel: [`crate::Walk::Trace`]'s sample.
///
/// # Panics
/// Panics if an index is out of bounds or the batch's columns have different lengths.
pub fn traced_at(
    bvh: &Bvh,
    rays: &RayBatch,
    any: bool,
    index: &[usize],
) -> (HitBatch, Vec<Counts>) {
    let at = |k: usize| {
        if let Some(&ahead) = index.get(k + SAMPLE_AHEAD) {
            rays.prefetch(ahead);
        }
        index[k]
    };
    // One loop per query, each with its traversal inlined (see `fill_skipping`).
    if any {
        counted_wide::<ANY_COUNTED>(bvh, rays, index.len(), at)
    } else {
        counted_wide::<COUNTED>(bvh, rays, index.len(), at)
    }
}

/// The counted query `MODE` of rays `at(0), …, at(n - 1)` on the wide tree, in parallel: the
/// batch loop of [`Bvh::wide_each`], as fast per ray as the uncounted trace's.
fn counted_wide<const MODE: u8>(
    bvh: &Bvh,
    rays: &RayBatch,
    n: usize,
    at: impl Fn(usize) -> usize + Sync,
) -> (HitBatch, Vec<Counts>) {
    counted_at(rays, n, |first, ts, ps, cs| {
        bvh.wide_each::<MODE>(
            rays,
            ts.len(),
            |k| Some(at(first + k)),
            |k, hit, counts| put(ts, ps, cs, k, hit, counts),
        );
    })
}

/// Query `k`'s answer into the output chunks.
#[inline(always)]
fn put(
    ts: &mut [f32],
    ps: &mut [u32],
    cs: &mut [Counts],
    k: usize,
    hit: Option<Hit>,
    counts: Counts,
) {
    cs[k] = counts;
    if let Some(h) = hit {
        (ts[k], ps[k]) = (h.t, h.prim);
    }
}

/// Hits and counts of `n` queries, in parallel: `chunk(first, t, prim, counts)` answers
/// queries `first ..` into its chunks of the outputs (`t`, `prim` given as misses).
fn counted_at(
    rays: &RayBatch,
    n: usize,
    chunk: impl Fn(usize, &mut [f32], &mut [u32], &mut [Counts]) + Sync,
) -> (HitBatch, Vec<Counts>) {
    check(rays);
    let mut counts = vec![Counts::default(); n];
    let mut out = HitBatch::misses(n);
    out.t
        .par_chunks_mut(CHUNK)
        .zip(out.prim.par_chunks_mut(CHUNK))
        .zip(counts.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, ((ts, ps), cs))| chunk(c * CHUNK, ts, ps, cs));
    (out, counts)
}

/// Traces rays `first, first + 1, …` of `rays` into `ts`, `ps` (one entry each, given as
/// misses), except those whose index is in `known` (sorted): they stay misses, for the caller
/// to fill with hits it has already. Any hit with `any`, else the closest.
pub fn fill_skipping(
    bvh: &Bvh,
    rays: &RayBatch,
    any: bool,
    first: usize,
    known: &[usize],
    ts: &mut [f32],
    ps: &mut [u32],
) {
    // One loop per query, each with its traversal inlined, as the batch functions have: with
    // the choice made per ray inside one loop, tracing all but the sample took as long as
    // tracing everything (Conference AO, 1.04-1.05 of the full trace in one run each).
    if any {
        fill_with::<ANY>(bvh, rays, first, known, ts, ps);
    } else {
        fill_with::<CLOSEST>(bvh, rays, first, known, ts, ps);
    }
}

/// Kept out of line: one copy of the loop per query, which the full trace and the trace left
/// after a sample both call (see `wide_hits_of`).
#[inline(never)]
fn fill_with<const MODE: u8>(
    bvh: &Bvh,
    rays: &RayBatch,
    first: usize,
    known: &[usize],
    ts: &mut [f32],
    ps: &mut [u32],
) {
    let known = &known[known.partition_point(|&k| k < first)..];
    // The next known ray's index, `usize::MAX` past the last: one comparison a ray, which
    // costs the full trace (nothing known) next to nothing.
    let (mut next, mut at) = (known.first().copied().unwrap_or(usize::MAX), 0);
    bvh.wide_each::<MODE>(
        rays,
        ts.len(),
        |k| {
            let i = first + k;
            if i != next {
                return Some(i);
            }
            at += 1;
            next = known.get(at).copied().unwrap_or(usize::MAX);
            None
        },
        |k, hit, _| {
            if let Some(h) = hit {
                (ts[k], ps[k]) = (h.t, h.prim);
            }
        },
    );
}

/// [`fill_skipping`] over the whole batch, in parallel: the trace that is left once the rays
/// at `known` have been traced by the estimator ([`crate::Walk::Trace`]).
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_skipping(bvh: &Bvh, rays: &RayBatch, any: bool, known: &[usize]) -> HitBatch {
    hits_skipping_in(bvh, rays, any, 0..rays.len(), known)
}

/// [`hits_skipping`] of the rays in `range` alone, their hits in order. With nothing `known`
/// it is the trace of those rays, in the loop [`hits_in`] runs on the wide tree; over the
/// [`slices`] of a batch, one by one, the two trace what they trace over the whole batch.
///
/// # Panics
/// Panics if `range` is out of bounds or the batch's columns have different lengths.
pub fn hits_skipping_in(
    bvh: &Bvh,
    rays: &RayBatch,
    any: bool,
    range: std::ops::Range<usize>,
    known: &[usize],
) -> HitBatch {
    check(rays);
    assert!(range.end <= rays.len(), "rays {range:?} of {}", rays.len());
    let mut out = HitBatch::misses(range.len());
    out.t
        .par_chunks_mut(CHUNK)
        .zip(out.prim.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (ts, ps))| {
            fill_skipping(bvh, rays, any, range.start + c * CHUNK, known, ts, ps);
        });
    out
}

/// `count` (at least one) consecutive slices covering a batch of `len` rays, as even as the
/// parallel loop's chunks allow: each starts where a chunk of the whole batch would, so its
/// chunks, and the packets formed in them, are the whole batch's. Fewer where there are
/// fewer chunks; none for no rays.
pub fn slices(len: usize, count: usize) -> Vec<std::ops::Range<usize>> {
    let chunks = len.div_ceil(CHUNK);
    let count = count.clamp(1, chunks.max(1));
    (0..count)
        .map(|s| (s * chunks / count * CHUNK).min(len)..((s + 1) * chunks / count * CHUNK).min(len))
        .filter(|r| !r.is_empty())
        .collect()
}

/// `walk`'s counts of the rays in `range` (a task), in parallel, in packets of 4 or 8 rays
/// (each lane's counts are exactly its ray's [`Bvh::walk`]; see `packet.rs`).
///
/// # Panics
/// Panics if `range` is out of bounds or the batch's columns have different lengths.
pub fn reduced_counts(
    bvh: &Bvh,
    rays: &RayBatch,
    walk: Walk,
    range: std::ops::Range<usize>,
) -> Vec<Counts> {
    check(rays);
    assert!(range.end <= rays.len(), "range beyond the batch");
    let mut counts = vec![Counts::default(); range.len()];
    counts
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, cs)| {
            let first = range.start + c * CHUNK;
            packet::reduced_lanes(bvh, rays, walk, |j| first + j, cs);
        });
    counts
}

/// `walk`'s counts of rays `index[0], index[1], …` of `rays`, in parallel, read in place (a
/// compacted sample without copying its rays out).
///
/// # Panics
/// Panics if an index is out of bounds or the batch's columns have different lengths.
pub fn reduced_counts_at(bvh: &Bvh, rays: &RayBatch, walk: Walk, index: &[usize]) -> Vec<Counts> {
    check(rays);
    assert!(
        index.iter().all(|&i| i < rays.len()),
        "index beyond the batch"
    );
    let mut counts = vec![Counts::default(); index.len()];
    counts
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, cs)| {
            let part = &index[c * CHUNK..];
            packet::reduced_lanes(bvh, rays, walk, |j| part[j], cs);
        });
    counts
}
