//! The batch queries: hits, counted hits and reduced counts of a [`RayBatch`], in parallel
//! (rayon, in chunks of rays), and the trace left once a sample's rays are known.
//!
//! Hit batches walk the wide tree a chunk of rays per call ([`Bvh::wide_each`]), so that
//! neighbouring rays walk together where AVX2 runs: any-hit rays thirty-two at a time
//! whatever their origins, closest-hit rays in runs of one origin. Reduced counts walk in
//! AVX2 packets (`packet.rs`).

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use crate::Aabb;
use crate::bvh::Bvh;
use crate::ray::{Hit, HitBatch, Ray, RayBatch, prefetch};
use crate::traverse::counts::Counts;
use crate::traverse::layout::Layout;
use crate::traverse::mode::{ANY, ANY_COUNTED, CLOSEST, COUNTED};
use crate::traverse::packet;
use crate::traverse::source::records;
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

/// [`HitBatch::misses`], written in parallel (see [`reset`]).
fn misses(n: usize) -> HitBatch {
    let mut out = HitBatch::default();
    reset(&mut out, n);
    out
}

/// `out` made `n` misses in its own buffers, written in parallel. Kept buffers spare the
/// trace a fresh batch's pages, which the kernel maps and zeroes on their first touch: a
/// small mesh's AO probes traced again into a batch of the same size measured 1.05x faster
/// on one thread, 1.07-1.09x on two. Where the batch is fresh, its pages are first touched
/// here, and mapping them is work one thread alone would otherwise do while the others wait.
fn reset(out: &mut HitBatch, n: usize) {
    out.t.clear();
    out.prim.clear();
    out.t.par_extend(rayon::iter::repeat_n(f32::INFINITY, n));
    out.prim
        .par_extend(rayon::iter::repeat_n(HitBatch::MISS, n));
}

fn hits_of<F>(rays: &RayBatch, out: &mut HitBatch, f: F)
where
    F: Fn(&Ray) -> Option<Hit> + Sync,
{
    check(rays);
    reset(out, rays.len());
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
}

/// [`hits_of`] on the wide tree into `out`, a chunk of rays per call: the loop of
/// [`fill_skipping`] with nothing to skip, so that the full trace, a render's task and the
/// trace left after an estimate's sample run one compiled loop, and their times differ by
/// their rays alone (two copies of the same loop, placed apart in the binary, measured 2–3 %
/// apart on AO rays).
fn wide_hits_into<const MODE: u8>(bvh: &Bvh, rays: &RayBatch, out: &mut HitBatch) {
    check(rays);
    reset(out, rays.len());
    out.t
        .par_chunks_mut(CHUNK)
        .zip(out.prim.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (ts, ps))| fill_with::<MODE>(bvh, rays, c * CHUNK, &[], ts, ps));
}

/// Any hits of all rays, walked thirty-two at a time whatever their origins
/// ([`Bvh::wide_each`]). A batch that mostly comes in runs of rays from one point (the AO rays
/// of each hit in turn) is walked as it is; any other in the order of its origins' cells
/// ([`origin_cells`]), each answer written to its ray's place: rays from nearby points enter
/// the same nodes, which the cache then holds (a large tree's shuffled AO rays walked as they
/// come measured 1.2-1.5x slower on the dragon and the hairball). The sort is part of the
/// call's time. Each ray's answer, hit or miss, is its own walk's; which triangle an occluded
/// ray reports may differ with its neighbours, as any-hit queries allow.
fn wide_any_hits_into(bvh: &Bvh, rays: &RayBatch, out: &mut HitBatch) {
    check(rays);
    if in_runs(rays) {
        return wide_hits_into::<ANY>(bvh, rays, out);
    }
    let n = rays.len();
    let order = origin_cells(&bvh.bounds(), rays);
    // Walked in that order, a ray is read from its record, one line, where its eight columns
    // were eight lines (single thread, against the columns: 1.13x on a small mesh, 1.04x on
    // the bunny, 1.09x on Sibenik).
    let records = records(rays);
    let records = &records[..];
    reset(out, n);
    // Each answer goes straight to its ray's place in the batch: putting them back in a pass
    // after, reading the walk's answers by each ray's place, cost 8 % of a small mesh's walk.
    let (t, prim) = (
        atomic(bytemuck::cast_slice_mut(&mut out.t)),
        atomic(&mut out.prim),
    );
    order.par_chunks(CHUNK).for_each(|part| {
        let at = |k: usize| {
            // The records lie scattered in the order now, where the hardware prefetchers,
            // which follow streams, do not fetch them.
            if let Some(&ahead) = part.get(k + SAMPLE_AHEAD) {
                prefetch(records, ahead as usize);
            }
            Some(part[k] as usize)
        };
        bvh.wide_each::<ANY>(records, part.len(), at, |k, hit, _| {
            if let Some(h) = hit {
                let i = part[k] as usize;
                t[i].store(h.t.to_bits(), Ordering::Relaxed);
                prim[i].store(h.prim, Ordering::Relaxed);
            }
        });
    });
}

/// Whether at least half of the rays start where the ray before them does, bit for bit,
/// judged on up to [`RUN_SAMPLES`] rays spread evenly over the batch: it picks a path, not an
/// answer, and reading every origin cost about 3 % of the walk of the bunny's AO probes.
fn in_runs(rays: &RayBatch) -> bool {
    let n = rays.len();
    let step = (n / RUN_SAMPLES).max(1);
    let (mut same, mut seen) = (0, 0);
    for i in (1..n).step_by(step) {
        same += usize::from(rays.same_origin(i, i - 1));
        seen += 1;
    }
    2 * same >= seen.max(1)
}

/// How many rays [`in_runs`] looks at.
const RUN_SAMPLES: usize = 1024;

/// Cells per side of the scene's box, as bits: 32³ cells, sorted in one counting pass over
/// their Morton keys. Rays of one cell need not share an origin (the packets do not ask it),
/// only nodes: a key of 30 bits in three radix passes (which grouped each origin's rays) made
/// the whole query 1.2-1.4x slower on shuffled AO rays, and one of 18 bits no faster.
const CELL_BITS: u32 = 5;

/// The rays' indices in the order of their origins' cells on a Morton curve through `bounds`
/// (rays of one cell keep their order).
fn origin_cells(bounds: &Aabb, rays: &RayBatch) -> Vec<u32> {
    let n = rays.len();
    let keys = cell_keys(bounds, rays);
    // A counting sort in as many parts as threads: each part counts its keys, then places its
    // rays after the same cell's rays of the parts before it.
    let size = n.div_ceil(rayon::current_num_threads()).max(1);
    let mut starts: Vec<Vec<u32>> = keys
        .par_chunks(size)
        .map(|part| {
            let mut count = vec![0u32; 1 << (3 * CELL_BITS)];
            for &k in part {
                count[k as usize] += 1;
            }
            count
        })
        .collect();
    let mut sum = 0;
    for cell in 0..1 << (3 * CELL_BITS) {
        for part in &mut starts {
            (part[cell], sum) = (sum, sum + part[cell]);
        }
    }
    // The places are all different, so each entry is written once.
    let mut order = vec![0u32; n];
    let places = atomic(&mut order);
    keys.par_chunks(size)
        .zip(starts.par_iter_mut())
        .enumerate()
        .for_each(|(p, (part, start))| {
            for (j, &k) in part.iter().enumerate() {
                let place = &mut start[k as usize];
                places[*place as usize].store((p * size + j) as u32, Ordering::Relaxed);
                *place += 1;
            }
        });
    order
}

/// `words` as atomic words, for a parallel pass to fill at places that are all different
/// (relaxed stores are plain stores).
fn atomic(words: &mut [u32]) -> &[AtomicU32] {
    const { assert!(align_of::<AtomicU32>() == align_of::<u32>()) };
    // SAFETY: `AtomicU32` has the size, alignment and bit validity of `u32`, and the
    // exclusive borrow, held for the view's life, leaves no other access to the words.
    unsafe { &*(std::ptr::from_mut(words) as *const [AtomicU32]) }
}

/// Each ray's origin cell: its Morton key on a grid of [`CELL_BITS`] bits a side over `bounds`
/// (the scene's), an origin outside it in the nearest cell.
fn cell_keys(bounds: &Aabb, rays: &RayBatch) -> Vec<u16> {
    let cells = ((1u32 << CELL_BITS) - 1) as f32;
    let (lo, extent) = (bounds.min, bounds.max - bounds.min);
    let scale = extent.to_array().map(|e| {
        if e > 0.0 && e.is_finite() {
            cells / e
        } else {
            0.0
        }
    });
    let (lo, scale) = (lo.to_array(), scale);
    let mut keys = vec![0u16; rays.len()];
    // A chunk of keys a work item, in a plain loop over scalars, which vectorises: through
    // rayon's `map`, or with the box read through the closure's references, it was a call or
    // sixty instructions a ray.
    keys.par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, part)| {
            let at = c * CHUNK..c * CHUNK + part.len();
            let (xs, ys, zs) = (&rays.ox[at.clone()], &rays.oy[at.clone()], &rays.oz[at]);
            let ([lx, ly, lz], [sx, sy, sz]) = (lo, scale);
            for (((k, &x), &y), &z) in part.iter_mut().zip(xs).zip(ys).zip(zs) {
                let key = axis_key(x, lx, sx, cells)
                    | axis_key(y, ly, sy, cells) << 1
                    | axis_key(z, lz, sz, cells) << 2;
                *k = key as u16;
            }
        });
    keys
}

/// One axis of a cell key: the cell of `x` on a grid from `lo` with `scale` cells a unit and
/// `cells` the last, its bits spread ([`spread`]). `min` takes a NaN (a non-finite origin, or
/// an infinite extent times zero) to the last cell, and `max` what lies below to the first.
#[inline(always)]
fn axis_key(x: f32, lo: f32, scale: f32, cells: f32) -> u32 {
    let c = ((x - lo) * scale).min(cells).max(0.0);
    // SAFETY: `c` is finite and in `0..=cells`, which `u32` holds: `min` and `max` left no
    // NaN. (The checked cast's NaN and range tests kept the loop from vectorising.)
    spread(unsafe { c.to_int_unchecked::<u32>() })
}

/// The low [`CELL_BITS`] bits of `x`, two zero bits after each: one axis of a Morton key.
fn spread(x: u32) -> u32 {
    let mut v = x & 0x1f;
    v = (v | v << 8) & 0x0000_f00f;
    v = (v | v << 4) & 0x0000_30c3;
    v = (v | v << 2) & 0x0000_9249;
    v
}

/// Closest hits of all rays, in parallel.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn closest_hits(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    hits_in(bvh, rays, false, Layout::Wide)
}

/// Any hits of all rays, in parallel (`t` is the distance of the hit found), walked thirty-two
/// rays at a time whatever their origins: as they come where they mostly come in runs of one
/// origin, else in the order of their origins' cells in the scene. Each ray's answer, hit or
/// miss, is its own walk's; which triangle an occluded ray reports may differ with its
/// neighbours, as any-hit queries allow.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn any_hits(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    hits_in(bvh, rays, true, Layout::Wide)
}

/// [`closest_hits`] or, with `any`, [`any_hits`], on the tree `layout` names: for comparing
/// the two trees' speed.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_in(bvh: &Bvh, rays: &RayBatch, any: bool, layout: Layout) -> HitBatch {
    let mut out = HitBatch::default();
    hits_into(bvh, rays, any, layout, &mut out);
    out
}

/// [`hits_in`] into `out`, whatever it held, in its buffers: a caller that traces batch after
/// batch (frames, bounces, repeated timings) keeps one and pays no fresh pages per call.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_into(bvh: &Bvh, rays: &RayBatch, any: bool, layout: Layout, out: &mut HitBatch) {
    match (layout, any) {
        (Layout::Wide, true) => wide_any_hits_into(bvh, rays, out),
        (Layout::Wide, false) => wide_hits_into::<CLOSEST>(bvh, rays, out),
        (_, true) => hits_of(rays, out, |r| bvh.any_hit_in(r, layout)),
        (_, false) => hits_of(rays, out, |r| bvh.closest_hit_in(r, layout)),
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
/// after a sample both call (see `wide_hits_into`).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rng;
    use glam::Vec3;

    #[test]
    fn origin_cells_sort_by_cell_and_keep_ties_in_order() {
        let mut rng = Rng::new(crate::testkit::seed(5));
        let mut rays = RayBatch::default();
        // Scattered origins, a few outside the box, and a few that trace nothing.
        for k in 0..3000 {
            let p = match k % 97 {
                5 => Vec3::new(f32::NAN, 0.0, f32::INFINITY),
                6 => Vec3::new(-3.0, 9.0, 0.0),
                _ => Vec3::new(rng.f32(), rng.f32() * 4.0, rng.f32() - 2.0),
            };
            rays.push(&Ray::new(p, Vec3::X));
        }
        assert!(!in_runs(&rays));
        let bounds = Aabb {
            min: Vec3::new(0.0, 0.0, -2.0),
            max: Vec3::new(1.0, 4.0, -1.0),
        };
        let keys = cell_keys(&bounds, &rays);
        let mut stable: Vec<u32> = (0..rays.len() as u32).collect();
        stable.sort_by_key(|&i| keys[i as usize]);
        assert_eq!(origin_cells(&bounds, &rays), stable);
        let distinct: std::collections::HashSet<u16> = keys.iter().copied().collect();
        assert!(distinct.len() > 1000, "{} cells", distinct.len());
    }

    #[test]
    fn cell_keys_span_the_box_and_clamp_the_rest() {
        let bounds = Aabb {
            min: Vec3::new(1.0, 2.0, 3.0),
            max: Vec3::new(5.0, 4.0, 7.0),
        };
        let mut rays = RayBatch::default();
        for p in [
            [1.0, 2.0, 3.0],
            [5.0, 2.5, 3.0],
            [5.0, 4.0, 7.0],
            [-9.0, 40.0, 3.0],
            [f32::NAN, f32::INFINITY, f32::NEG_INFINITY],
        ] {
            rays.push(&Ray::new(Vec3::from(p), Vec3::X));
        }
        let top = 31;
        let k = |x, y, z| (spread(x) | spread(y) << 1 | spread(z) << 2) as u16;
        assert_eq!(
            cell_keys(&bounds, &rays),
            [
                k(0, 0, 0),
                k(top, 7, 0),
                k(top, top, top),
                k(0, top, 0),
                k(top, top, 0)
            ]
        );
    }

    #[test]
    fn spread_interleaves_five_bits() {
        assert_eq!(spread(0), 0);
        assert_eq!(spread(0x1f), 0x1249);
        for b in 0..5 {
            assert_eq!(spread(1 << b), 1 << (3 * b));
        }
        assert_eq!(spread(0x20), 0, "bits above five are dropped");
    }
}
