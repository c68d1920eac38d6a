//! The batch queries: hits, counted hits and reduced counts of a [`RayBatch`], in parallel
//! (rayon, in chunks of rays), and the trace left once a sample's rays are known.
//!
//! Hit batches walk the wide tree a chunk of rays per call ([`Bvh::wide_each`]), so that rays
//! sharing an origin walk together where AVX2 runs; an any-hit batch that does not come in runs
//! of one origin (shuffled AO rays) is walked in its origins' order along a Morton curve, which
//! makes the runs and keeps nearby rays together. Reduced counts walk in AVX2 packets
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

/// Any hits of all rays. A batch that mostly comes in runs of rays from one point (the AO rays
/// of each hit in turn) is walked as it is ([`wide_hits_of`]); any other is walked in the
/// order of its origins along a Morton curve ([`origin_order`]) and its answers scattered back:
/// rays from nearby points enter the same nodes, which the cache then holds, and rays from one
/// point, wherever the batch put them, become one run, walked together ([`Bvh::wide_each`]).
/// The sort is part of the call's time. Each ray's answer, hit or miss, is its own walk's;
/// which triangle an occluded ray reports may differ with the order, as any-hit queries allow.
fn wide_any_hits(bvh: &Bvh, rays: &RayBatch) -> HitBatch {
    check(rays);
    if in_runs(rays) {
        return wide_hits_of::<ANY>(bvh, rays);
    }
    let n = rays.len();
    let order = origin_order(rays);
    let mut t = vec![f32::INFINITY; n];
    let mut prim = vec![u32::MAX; n];
    t.par_chunks_mut(CHUNK)
        .zip(prim.par_chunks_mut(CHUNK))
        .enumerate()
        .for_each(|(c, (ts, ps))| {
            let first = c * CHUNK;
            let at = |k: usize| {
                // The rays lie scattered in the batch now, where the hardware prefetchers,
                // which follow streams, do not fetch them.
                if let Some(&ahead) = order.get(first + k + SAMPLE_AHEAD) {
                    rays.prefetch(ahead as usize);
                }
                Some(order[first + k] as usize)
            };
            bvh.wide_each::<ANY>(rays, ts.len(), at, |k, hit, _| {
                if let Some(h) = hit {
                    (ts[k], ps[k]) = (h.t, h.prim);
                }
            });
        });
    let mut out = misses(n);
    for (k, &i) in order.iter().enumerate() {
        (out.t[i as usize], out.prim[i as usize]) = (t[k], prim[k]);
    }
    out
}

/// Whether at least half of the rays start where the ray before them does, bit for bit.
fn in_runs(rays: &RayBatch) -> bool {
    let same = |i: usize| {
        rays.ox[i].to_bits() == rays.ox[i - 1].to_bits()
            && rays.oy[i].to_bits() == rays.oy[i - 1].to_bits()
            && rays.oz[i].to_bits() == rays.oz[i - 1].to_bits()
    };
    2 * (1..rays.len()).into_par_iter().filter(|&i| same(i)).count() >= rays.len()
}

/// Bits of a Morton key per axis: 1024 cells along each side of the origins' box, finer than
/// the spacing of a frame's hit points on the scenes measured, so rays of different points
/// seldom share a key.
const KEY_BITS: u32 = 10;

/// The rays' indices sorted by their origins' cells on a Morton curve through the origins'
/// bounding box (a stable radix sort: rays of one cell keep their order). Rays with a
/// non-finite origin trace nothing and take the first cell's key.
fn origin_order(rays: &RayBatch) -> Vec<u32> {
    let n = rays.len();
    let axes = [&rays.ox, &rays.oy, &rays.oz];
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for (a, column) in axes.iter().enumerate() {
        for &x in column.iter().filter(|x| x.is_finite()) {
            lo[a] = lo[a].min(x);
            hi[a] = hi[a].max(x);
        }
    }
    let cells = ((1u32 << KEY_BITS) - 1) as f32;
    let scale = [0, 1, 2].map(|a| {
        let extent = hi[a] - lo[a];
        if extent > 0.0 && extent.is_finite() {
            cells / extent
        } else {
            0.0
        }
    });
    // The key above the index, so that sorting the words by their upper half keeps the
    // indices of equal keys in order.
    let mut words: Vec<u64> = (0..n)
        .map(|i| {
            let p = [rays.ox[i], rays.oy[i], rays.oz[i]];
            let key = if p.iter().all(|x| x.is_finite()) {
                // `as` saturates, and turns a NaN (an infinite extent times zero) into 0.
                let q = [0, 1, 2].map(|a| ((p[a] - lo[a]) * scale[a]).min(cells) as u32);
                spread(q[0]) | spread(q[1]) << 1 | spread(q[2]) << 2
            } else {
                0
            };
            u64::from(key) << 32 | i as u64
        })
        .collect();
    let mut sorted = vec![0u64; n];
    let digit =
        |w: u64, pass: u32| ((w >> (32 + KEY_BITS * pass)) & ((1 << KEY_BITS) - 1)) as usize;
    for pass in 0..3 {
        let mut start = vec![0usize; 1 << KEY_BITS];
        for &w in &words {
            start[digit(w, pass)] += 1;
        }
        let mut sum = 0;
        for s in start.iter_mut() {
            (*s, sum) = (sum, sum + *s);
        }
        for &w in &words {
            let d = digit(w, pass);
            sorted[start[d]] = w;
            start[d] += 1;
        }
        std::mem::swap(&mut words, &mut sorted);
    }
    words.into_iter().map(|w| w as u32).collect()
}

/// The low [`KEY_BITS`] bits of `x`, two zero bits after each: one axis of a Morton key.
fn spread(x: u32) -> u32 {
    let mut v = x & 0x3ff;
    v = (v | v << 16) & 0x0300_00ff;
    v = (v | v << 8) & 0x0300_f00f;
    v = (v | v << 4) & 0x030c_30c3;
    v = (v | v << 2) & 0x0924_9249;
    v
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
    wide_any_hits(bvh, rays)
}

/// [`closest_hits`] or, with `any`, [`any_hits`], on the tree `layout` names: for comparing
/// the two trees' speed.
///
/// # Panics
/// Panics if the batch's columns have different lengths.
pub fn hits_in(bvh: &Bvh, rays: &RayBatch, any: bool, layout: Layout) -> HitBatch {
    if layout == Layout::Wide {
        return if any {
            wide_any_hits(bvh, rays)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rng;

    #[test]
    fn origin_order_sorts_by_cell_and_keeps_ties_in_order() {
        let mut rng = Rng::new(crate::testkit::seed(5));
        let mut rays = RayBatch::default();
        let dir = glam::Vec3::X;
        // Runs of one origin, interleaved, and a few origins that trace nothing.
        let points: Vec<glam::Vec3> = (0..300)
            .map(|_| glam::Vec3::new(rng.f32(), rng.f32() * 4.0, rng.f32() - 2.0))
            .collect();
        for k in 0..2000 {
            let p = if k % 97 == 5 {
                glam::Vec3::new(f32::NAN, 0.0, f32::INFINITY)
            } else {
                points[rng.below(points.len() as u32) as usize]
            };
            rays.push(&Ray::new(p, dir));
        }
        assert!(!in_runs(&rays));
        let order = origin_order(&rays);
        let mut seen = vec![false; rays.len()];
        for &i in &order {
            assert!(!std::mem::replace(&mut seen[i as usize], true), "{i} twice");
        }
        assert!(seen.iter().all(|&s| s), "a permutation");
        let origin = |i: u32| rays.get(i as usize).origin;
        let finite = |i: u32| origin(i).is_finite();
        // Non-finite origins first, then every origin's rays in one run, each in order.
        let first_finite = order.iter().position(|&i| finite(i)).unwrap();
        assert!(order[first_finite..].iter().all(|&i| finite(i)));
        let mut done = std::collections::HashSet::new();
        for run in order[first_finite..].chunk_by(|&a, &b| origin(a) == origin(b)) {
            assert!(run.windows(2).all(|w| w[0] < w[1]), "a run keeps its order");
            let key = origin(run[0]).to_array().map(f32::to_bits);
            assert!(done.insert(key), "{:?} in two runs", origin(run[0]));
        }
        assert_eq!(done.len(), points.len());
    }

    #[test]
    fn spread_interleaves_ten_bits() {
        assert_eq!(spread(0), 0);
        assert_eq!(spread(0x3ff), 0x0924_9249);
        for b in 0..10 {
            assert_eq!(spread(1 << b), 1 << (3 * b));
        }
        assert_eq!(spread(0x400), 0, "bits above ten are dropped");
    }
}
