//! The batch queries: hits, counted hits and reduced counts of a [`RayBatch`], in parallel
//! (rayon, in chunks of rays), and the trace left once a sample's rays are known.
//!
//! Hit batches walk the wide tree a chunk of rays per call ([`Bvh::wide_each`]), so that
//! neighbouring rays walk together where AVX2 runs: any-hit rays eight at a time whatever
//! their origins, closest-hit rays in runs of one origin. Reduced counts walk in AVX2 packets
//! (`packet.rs`).

use rayon::prelude::*;

use crate::bvh::Bvh;
use crate::ray::{Hit, HitBatch, Ray, RayBatch};
use crate::traverse::counts::Counts;
use crate::traverse::layout::Layout;
use crate::traverse::mode::{ANY, ANY_COUNTED, CLOSEST, COUNTED};
use crate::traverse::packet;
use crate::traverse::walk::Walk;

/// Rays per rayon work item: enough to amortise scheduling, small enough to balance.
const CHUNK: usize = 256;

/// How far ahead of the ray being walked a sample read in place is prefetched: two runs of
/// eight. The sampled runs lie apart in the batch, where the hardware prefetchers, which
/// follow streams, do not fetch them, so each run's loads would miss the cache and wait.
const SAMPLE_AHEAD: usize = 16;

fn check(rays: &RayBatch) {
    assert!(
        rays.is_consistent(),
        "RayBatch columns have different lengths"
    );
}

/// [`HitBatch::misses`], written in parallel: a fresh batch's pages are first touched there,
/// and mapping them is work one thread alone would otherwise do while the others wait.
fn misses(n: usize) -> HitBatch {
    let mut out = HitBatch {
        t: Vec::with_capacity(n),
        prim: Vec::with_capacity(n),
    };
    out.t.par_extend(rayon::iter::repeat_n(f32::INFINITY, n));
    out.prim
        .par_extend(rayon::iter::repeat_n(HitBatch::MISS, n));
    out
}

fn hits_of<F>(rays: &RayBatch, f: F) -> HitBatch
where
    F: Fn(&Ray) -> Option<Hit> + Sync,
{
    check(rays);
    let n = rays.len();
    let mut out = misses(n);
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
    let mut out = misses(rays.len());
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

/// Any hits of all rays, in parallel (`t` is the distance of the hit found), walked eight
/// consecutive rays at a time whatever their origins ([`Bvh::wide_each`]). Each ray's answer,
/// hit or miss, is its own walk's; which triangle an occluded ray reports may differ with its
/// neighbours, as any-hit queries allow. A shuffled batch is walked as it comes: sorting it by
/// origin first made its packets more coherent but cost more than that gained (two threads;
/// the sort held one of them).
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
/// parallel: on the wide tree, as the batch queries walk it (rays sharing an origin together,
/// AVX2 where it runs), so that an estimate's sample costs what the render's trace does.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_counted_in(
    bvh: &Bvh,
    rays: &RayBatch,
    any: bool,
    layout: Layout,
) -> (HitBatch, Vec<Counts>) {
    if layout == Layout::Wide {
        return if any {
            any_hits_counted(bvh, rays)
        } else {
            closest_hits_counted(bvh, rays)
        };
    }
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
    let mut out = misses(n);
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
    let mut out = misses(range.len());
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
