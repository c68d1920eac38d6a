//! The top-down binned SAH build ([`BuildPreset::Sah`](super::BuildPreset::Sah)): each node's
//! triangles are binned by centroid into [`BINS`] slabs along each axis, split at the slab
//! boundary of least surface area heuristic cost, or kept as a leaf where no split pays. The
//! tree is obvhs's [`Bvh2`] layout (root at 0, children as adjacent pairs), so the depth bound
//! and the flattening that follow a PLOC build take it unchanged.
//!
//! The costs are the ones obvhs's leaf collapse weighs after a PLOC build: a triangle test
//! costs 1, a box step [`TRAVERSAL`], and a leaf holds at most [`MAX_LEAF`] triangles; but
//! triangles are counted in groups of four ([`blocks`]), as the wide tree tests them. Subtrees
//! over [`PARALLEL`] triangles are built on rayon's threads, and so is the binning of a node
//! over [`PARALLEL_BINNING`] of them, so the root's pass over every triangle is not one
//! thread's work.

use glam::Vec3A;
use obvhs::{aabb::Aabb, bvh2::Bvh2, bvh2::node::Bvh2Node};
use rayon::prelude::*;

/// Slabs per axis: 128 changed the SAH cost of Conference's and the hairball's trees by under
/// 1.5 % and took twice the build time; 32 keeps a node's bins (3 × 32 boxes and counts)
/// within a few kilobytes.
pub(super) const BINS: usize = 32;

/// Cost of a box step, in triangle tests (obvhs's `collapse_traversal_cost` of every preset).
pub(super) const TRAVERSAL: f32 = 3.0;

/// Most triangles in a leaf (obvhs's `max_prims_per_leaf` of every preset but the fastest).
pub(crate) const MAX_LEAF: usize = 8;

/// Smallest subtree whose two children are built in parallel.
const PARALLEL: usize = 4096;

/// Smallest node whose triangles are binned in parallel.
const PARALLEL_BINNING: usize = 1 << 16;

/// Triangles per chunk of a parallel binning.
const CHUNK: usize = 1 << 14;

/// What the build reads: each triangle's box and centroid.
struct Input<'a> {
    boxes: &'a [Aabb],
    centroids: Vec<Vec3A>,
}

/// One slab: the box of its triangles and their number.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Bin {
    const EMPTY: Self = Self {
        bounds: Aabb {
            min: Vec3A::splat(f32::INFINITY),
            max: Vec3A::splat(f32::NEG_INFINITY),
        },
        count: 0,
    };
}

/// The slabs of all three axes.
type Bins = [[Bin; BINS]; 3];

/// How a node's centroids map to slabs: `(c - origin) * scale`, per axis.
#[derive(Clone, Copy)]
struct Slabs {
    origin: Vec3A,
    scale: Vec3A,
}

impl Slabs {
    fn of(centroids: &Aabb) -> Self {
        let extent = centroids.max - centroids.min;
        // An axis with no extent gets scale 0 (every centroid in slab 0), which no split uses.
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            Vec3A::splat(BINS as f32 * (1.0 - f32::EPSILON)) / extent,
            Vec3A::ZERO,
        );
        Self {
            origin: centroids.min,
            scale,
        }
    }

    #[inline(always)]
    fn slab(&self, c: Vec3A, axis: usize) -> usize {
        (((c[axis] - self.origin[axis]) * self.scale[axis]) as usize).min(BINS - 1)
    }
}

/// Builds over `boxes`, box `k` bounding (a piece of) triangle `triangles[k]`; the tree's
/// `primitive_indices` are those triangle numbers.
pub(super) fn build(boxes: &[Aabb], triangles: &[u32]) -> Bvh2 {
    let input = Input {
        boxes,
        centroids: boxes.par_iter().map(Aabb::center).collect(),
    };
    let mut prims: Vec<u32> = (0..boxes.len() as u32).collect();
    let root = bounds(&input, &prims);
    let nodes = subtree(&input, &mut prims, 0, root);
    for p in &mut prims {
        *p = triangles[*p as usize];
    }
    Bvh2 {
        nodes,
        primitive_indices: prims,
        ..Default::default()
    }
}

/// A node's two boxes: of its triangles, and of their centroids.
type Boxes = (Aabb, Aabb);

/// How a node splits: its first `mid` triangles go left, and each side's boxes.
struct Split {
    mid: usize,
    sides: [Boxes; 2],
}

/// The subtree over `prims` (boxes `boxes`; they start at `offset` of the whole index array),
/// its root at 0 and every inner node's children as a pair after it.
fn subtree(input: &Input, prims: &mut [u32], offset: usize, boxes: Boxes) -> Vec<Bvh2Node> {
    let node = Bvh2Node::new(boxes.0, prims.len() as u32, offset as u32);
    let Some(Split { mid, sides }) = split(input, prims, &boxes) else {
        return vec![node];
    };
    if prims.len() < PARALLEL {
        let mut nodes = vec![node];
        grow(input, prims, offset, 0, (mid, sides), &mut nodes);
        return nodes;
    }
    let (l, r) = prims.split_at_mut(mid);
    let (left, right) = rayon::join(
        || subtree(input, l, offset, sides[0]),
        || subtree(input, r, offset + mid, sides[1]),
    );
    // The root, the children's roots at 1 and 2, then the rest of each child's nodes: a left
    // node at i >= 1 moves to i + 2, a right one to i + left.len() + 1.
    let mut nodes = Vec::with_capacity(1 + left.len() + right.len());
    let mut root = node;
    root.make_inner(1);
    let relink = |n: &Bvh2Node, by: usize| {
        let mut n = *n;
        if !n.is_leaf() {
            n.first_index += by as u32;
        }
        n
    };
    nodes.extend([root, relink(&left[0], 2), relink(&right[0], left.len() + 1)]);
    nodes.extend(left[1..].iter().map(|n| relink(n, 2)));
    nodes.extend(right[1..].iter().map(|n| relink(n, left.len() + 1)));
    nodes
}

/// Splits node `at` (over `prims`, split at `mid` into `sides`) and its descendants on this
/// thread.
fn grow(
    input: &Input,
    prims: &mut [u32],
    offset: usize,
    at: usize,
    (mid, sides): (usize, [Boxes; 2]),
    nodes: &mut Vec<Bvh2Node>,
) {
    let first = nodes.len();
    nodes[at].make_inner(first as u32);
    let (l, r) = prims.split_at_mut(mid);
    let parts = [(l, offset), (r, offset + mid)];
    // Both children first, as a pair; then each one's subtree after them.
    for ((part, start), (b, _)) in parts.iter().zip(&sides) {
        nodes.push(Bvh2Node::new(*b, part.len() as u32, *start as u32));
    }
    for (k, ((part, start), boxes)) in parts.into_iter().zip(sides).enumerate() {
        if let Some(s) = split(input, part, &boxes) {
            grow(input, part, start, first + k, (s.mid, s.sides), nodes);
        }
    }
}

/// The box of `prims` and the box of their centroids.
fn bounds(input: &Input, prims: &[u32]) -> Boxes {
    let one = |(mut b, mut c): Boxes, &p: &u32| {
        b = b.union(&input.boxes[p as usize]);
        c.extend(input.centroids[p as usize]);
        (b, c)
    };
    let both = |(b0, c0): Boxes, (b1, c1): Boxes| (b0.union(&b1), c0.union(&c1));
    let empty = || (Aabb::empty(), Aabb::empty());
    if prims.len() >= PARALLEL_BINNING {
        prims
            .par_chunks(CHUNK)
            .map(|chunk| chunk.iter().fold(empty(), one))
            .reduce(empty, both)
    } else {
        prims.iter().fold(empty(), one)
    }
}

/// Where to split `prims` (boxes `bounds` and `centroids`), after reordering them so that the
/// left child's come first; `None` for a leaf.
fn split(input: &Input, prims: &mut [u32], (bounds, centroids): &Boxes) -> Option<Split> {
    let n = prims.len();
    if n <= 1 {
        return None;
    }
    let halves = |prims: &mut [u32]| {
        let (l, r) = prims.split_at(n / 2);
        Split {
            mid: n / 2,
            sides: [bounds_of(input, l), bounds_of(input, r)],
        }
    };
    let slabs = Slabs::of(centroids);
    if slabs.scale == Vec3A::ZERO {
        // Every centroid in one point: no plane separates them, so halve by index.
        return (n > MAX_LEAF).then(|| halves(prims));
    }
    let bins = bin(input, prims, &slabs);
    let (axis, slab, cost) = best_plane(&bins);
    // Both costs over the node's area: a leaf tests all n, a split steps into the node's box
    // and pays each side's tests weighted by the chance of entering it.
    let leaf = blocks(n as u32);
    let cost = TRAVERSAL + cost / bounds.half_area().max(f32::MIN_POSITIVE);
    if n <= MAX_LEAF && leaf <= cost {
        return None;
    }
    // The triangles' boxes of each side are the union of its slabs'; the centroids' are
    // gathered as the partition passes them.
    let row = &bins[axis];
    let side_box = |slabs: &[Bin]| slabs.iter().fold(Aabb::empty(), |b, s| b.union(&s.bounds));
    let (mut i, mut j) = (0, n);
    let (mut lc, mut rc) = (Aabb::empty(), Aabb::empty());
    while i < j {
        let c = input.centroids[prims[i] as usize];
        if slabs.slab(c, axis) < slab {
            lc.extend(c);
            i += 1;
        } else {
            rc.extend(c);
            j -= 1;
            prims.swap(i, j);
        }
    }
    // A plane always leaves a centroid on each side (the extreme ones fall in the first and
    // the last slab); guard anyway, a node must never split into nothing.
    if i == 0 || i == n {
        return Some(halves(prims));
    }
    Some(Split {
        mid: i,
        sides: [(side_box(&row[..slab]), lc), (side_box(&row[slab..]), rc)],
    })
}

/// [`bounds`] on this thread.
fn bounds_of(input: &Input, prims: &[u32]) -> Boxes {
    prims
        .iter()
        .fold((Aabb::empty(), Aabb::empty()), |(b, mut c), &p| {
            c.extend(input.centroids[p as usize]);
            (b.union(&input.boxes[p as usize]), c)
        })
}

/// Counts and boxes of `prims` per slab of every axis.
fn bin(input: &Input, prims: &[u32], slabs: &Slabs) -> Box<Bins> {
    let fill = |mut bins: Box<Bins>, &p: &u32| {
        let (b, c) = (&input.boxes[p as usize], input.centroids[p as usize]);
        for (axis, row) in bins.iter_mut().enumerate() {
            let bin = &mut row[slabs.slab(c, axis)];
            bin.bounds = bin.bounds.union(b);
            bin.count += 1;
        }
        bins
    };
    let empty = || Box::new([[Bin::EMPTY; BINS]; 3]);
    if prims.len() >= PARALLEL_BINNING {
        prims
            .par_chunks(CHUNK)
            .map(|chunk| chunk.iter().fold(empty(), fill))
            .reduce(empty, |mut a, b| {
                for (ra, rb) in a.iter_mut().zip(b.iter()) {
                    for (x, y) in ra.iter_mut().zip(rb) {
                        x.bounds = x.bounds.union(&y.bounds);
                        x.count += y.count;
                    }
                }
                a
            })
    } else {
        prims.iter().fold(empty(), fill)
    }
}

/// The tests of `n` triangles, as the wide tree tests them: a group of four at a time, so a
/// leaf of three costs what one of four does. (Counted one by one, the trees had more leaves
/// of one to three triangles; counted in eights, the pair the AVX2 test takes at once, they
/// mostly traced 5-13 % slower on the bunny and Sibenik.)
fn blocks(n: u32) -> f32 {
    (n.div_ceil(4) * 4) as f32
}

/// The plane of least cost `area(left) × count(left) + area(right) × count(right)`: its axis,
/// the first slab on its right, and the cost. Planes with an empty side are not candidates.
fn best_plane(bins: &Bins) -> (usize, usize, f32) {
    let mut best = (0, 1, f32::INFINITY);
    for (axis, row) in bins.iter().enumerate() {
        // Right sides, swept from the last slab: right[k] covers slabs k.. .
        let mut right = [0f32; BINS];
        let (mut b, mut count) = (Aabb::empty(), 0u32);
        for k in (1..BINS).rev() {
            b = b.union(&row[k].bounds);
            count += row[k].count;
            right[k] = if count == 0 {
                f32::NAN
            } else {
                b.half_area() * blocks(count)
            };
        }
        let (mut b, mut count) = (Aabb::empty(), 0u32);
        for k in 1..BINS {
            b = b.union(&row[k - 1].bounds);
            count += row[k - 1].count;
            // An empty side leaves NaN (right) or a zero count (left): never the best.
            let cost = b.half_area() * blocks(count) + right[k];
            if count > 0 && cost < best.2 {
                best = (axis, k, cost);
            }
        }
    }
    best
}
