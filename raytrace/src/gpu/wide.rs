//! The compressed 8-wide node layout for the GPU's trace kernels (Ylitie, Karras and Laine,
//! "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017), made
//! from the CPU's wide tree ([`WideBvh`]) so that both walk the same children and leaves.
//!
//! A node is 80 bytes, one fetch per visit: the parent grid's origin and power-of-two cell
//! sizes, where its inner children and its leaves' triangles start, one byte per slot telling
//! what the slot holds, and each child box in eight bits per plane. Quantization is
//! conservative: the host decodes every plane as the kernel will (`origin + q * scale` in f32)
//! and widens it by a cell until it contains the true plane, so a ray that enters a child's true
//! box also enters its quantized box (the slab test is monotonic in the planes), and the hits
//! stay those of the exact boxes.

use bytemuck::{Pod, Zeroable};

use crate::bvh::{BvhTriangle, WideBvh, wide::WIDTH};

/// [`CompressedNode::meta`] of an unused slot.
pub const META_EMPTY: u8 = 0;
/// [`CompressedNode::meta`] of an inner child.
pub const META_INNER: u8 = 0xff;
/// Most triangles one leaf slot can hold: the meta byte carries the count.
pub const MAX_LEAF: u32 = 0xfe;

/// One compressed wide node, 80 bytes, `Pod`, laid out as its WGSL struct reads it.
///
/// Slot `k` is empty (`meta[k] == 0`), an inner child (`0xff`): node `child + ` the number of
/// inner slots before `k`, or a leaf of `meta[k]` triangles starting at `tri + ` the triangles
/// of the leaf slots before `k`. Its box is `origin + q * 2^(exp - 127)` per axis, `q` from
/// `lo` and `hi`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CompressedNode {
    /// The grid's origin: the minimum of the children's boxes.
    pub origin: [f32; 3],
    /// Per axis, the cell size's biased f32 exponent (bits 0-7, 8-15, 16-23).
    pub exp: u32,
    /// The first inner child in [`CompressedTree::nodes`].
    pub child: u32,
    /// The first triangle of the first leaf slot in [`CompressedTree::tris`].
    pub tri: u32,
    /// What each slot holds, four slots a word.
    pub meta: [u8; WIDTH],
    /// Quantized lower planes: x of the eight slots, then y, then z.
    pub lo: [[u8; WIDTH]; 3],
    /// Quantized upper planes, as `lo`.
    pub hi: [[u8; WIDTH]; 3],
}

const _: () = assert!(size_of::<CompressedNode>() == 80);

/// Why a wide tree has no compressed form.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum CompressError {
    /// A leaf holds more triangles than a slot's byte can count.
    #[error("a leaf of {count} triangles exceeds the compressed layout's {MAX_LEAF}")]
    LeafTooLarge {
        /// The leaf's triangles.
        count: u32,
    },
    /// A child box is not finite, so no grid covers it.
    #[error("a child box of wide node {node} is not finite")]
    NotFinite {
        /// The wide node.
        node: usize,
    },
}

/// The compressed nodes (node 0 the root) and the triangles their leaves own, leaf by leaf.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CompressedTree {
    /// Nodes; the inner children of a node lie together, in slot order.
    pub nodes: Vec<CompressedNode>,
    /// Triangles in the order the leaf slots name them.
    pub tris: Vec<BvhTriangle>,
}

impl CompressedTree {
    /// Bytes one node visit reads.
    pub const NODE_BYTES: usize = size_of::<CompressedNode>();

    /// Compresses `wide`; empty when it is.
    pub fn new(wide: &WideBvh) -> Result<Self, CompressError> {
        let mut out = Self::default();
        let src = wide.nodes();
        if src.is_empty() {
            return Ok(out);
        }
        out.nodes.push(CompressedNode::default());
        // (wide node, its compressed index), breadth first, so that each node's inner
        // children are given consecutive places when it is encoded.
        let mut queue = std::collections::VecDeque::from([(0usize, 0usize)]);
        while let Some((w, c)) = queue.pop_front() {
            let n = &src[w];
            let slots: Vec<usize> = (0..WIDTH)
                .filter(|&k| n.planes[0][k] <= n.planes[3][k])
                .collect();
            let mut node = CompressedNode {
                child: out.nodes.len() as u32,
                tri: out.tris.len() as u32,
                ..CompressedNode::default()
            };
            let (origin, scale, exp) =
                grid(n, &slots).ok_or(CompressError::NotFinite { node: w })?;
            node.origin = origin;
            node.exp = exp[0] | exp[1] << 8 | exp[2] << 16;
            for &k in &slots {
                if n.count[k] == 0 {
                    node.meta[k] = META_INNER;
                    queue.push_back((n.child[k] as usize, out.nodes.len()));
                    out.nodes.push(CompressedNode::default());
                } else {
                    if n.count[k] > MAX_LEAF {
                        return Err(CompressError::LeafTooLarge { count: n.count[k] });
                    }
                    node.meta[k] = n.count[k] as u8;
                    out.tris.extend(unpack(wide, n.child[k], n.count[k]));
                }
                for a in 0..3 {
                    node.lo[a][k] = quantize_lo(n.planes[a][k], origin[a], scale[a]);
                    node.hi[a][k] = quantize_hi(n.planes[3 + a][k], origin[a], scale[a]);
                }
            }
            out.nodes[c] = node;
        }
        Ok(out)
    }
}

/// The box plane `q` decodes to, as the kernel computes it.
pub fn decode(origin: f32, scale: f32, q: u8) -> f32 {
    origin + f32::from(q) * scale
}

/// The parent grid of node `n`'s used slots: origin, cell size and its biased exponent per
/// axis, the cells small enough that 254 of them span the children (one to spare for widening).
fn grid(n: &crate::bvh::wide::Node8, slots: &[usize]) -> Option<([f32; 3], [f32; 3], [u32; 3])> {
    let mut origin = [0.0; 3];
    let mut scale = [0.0; 3];
    let mut exp = [0; 3];
    for a in 0..3 {
        let lo = slots
            .iter()
            .map(|&k| n.planes[a][k])
            .fold(f32::INFINITY, f32::min);
        let hi = slots
            .iter()
            .map(|&k| n.planes[3 + a][k])
            .fold(f32::NEG_INFINITY, f32::max);
        if !lo.is_finite() || !hi.is_finite() {
            return None;
        }
        let span = f64::from(hi) - f64::from(lo);
        // The smallest power of two with 254 cells covering the span; the exponent stays a
        // normal f32's.
        let mut e: i32 = -126;
        while f64::from(e).exp2() * 254.0 < span {
            e += 1;
        }
        if e > 127 {
            return None;
        }
        origin[a] = lo;
        exp[a] = (e + 127) as u32;
        scale[a] = f32::from_bits(exp[a] << 23);
    }
    Some((origin, scale, exp))
}

/// The largest cell index whose decoded plane lies at or below `x`.
fn quantize_lo(x: f32, origin: f32, scale: f32) -> u8 {
    let mut q = ((f64::from(x) - f64::from(origin)) / f64::from(scale))
        .floor()
        .clamp(0.0, 255.0) as u8;
    while q > 0 && decode(origin, scale, q) > x {
        q -= 1;
    }
    q
}

/// The smallest cell index whose decoded plane lies at or above `x`.
fn quantize_hi(x: f32, origin: f32, scale: f32) -> u8 {
    let mut q = ((f64::from(x) - f64::from(origin)) / f64::from(scale))
        .ceil()
        .clamp(0.0, 255.0) as u8;
    while q < 255 && decode(origin, scale, q) < x {
        q += 1;
    }
    q
}

/// The `count` triangles of the leaf whose groups start at `first`.
fn unpack(wide: &WideBvh, first: u32, count: u32) -> impl Iterator<Item = BvhTriangle> + '_ {
    (0..count as usize).map(move |i| {
        let g = &wide.groups()[first as usize + i / 4];
        let lane = i % 4;
        let v = |vertex: usize| [0, 1, 2].map(|axis| g.v[vertex][axis][lane]);
        BvhTriangle {
            v0: v(0),
            prim: g.prim[lane],
            v1: v(1),
            pad1: 0,
            v2: v(2),
            pad2: 0,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildPreset, Bvh, Rng, testkit};

    /// Every compressed child box contains its wide child's box, every leaf names the same
    /// triangles, and every wide node is reached once.
    fn check(bvh: &Bvh) {
        let wide = bvh.wide();
        let tree = CompressedTree::new(wide).expect("compresses");
        assert_eq!(tree.nodes.len(), wide.nodes().len());
        let mut stack = vec![(0usize, 0usize)];
        let mut seen = 0;
        let mut leaf_tris = 0;
        while let Some((w, c)) = stack.pop() {
            seen += 1;
            let (n, z) = (&wide.nodes()[w], &tree.nodes[c]);
            let (mut inner, mut tri) = (z.child as usize, z.tri as usize);
            for k in 0..WIDTH {
                if z.meta[k] == META_EMPTY {
                    assert!(n.planes[0][k] > n.planes[3][k], "a used slot is empty");
                    continue;
                }
                for a in 0..3 {
                    let scale = f32::from_bits((z.exp >> (8 * a) & 0xff) << 23);
                    assert!(decode(z.origin[a], scale, z.lo[a][k]) <= n.planes[a][k]);
                    assert!(decode(z.origin[a], scale, z.hi[a][k]) >= n.planes[3 + a][k]);
                }
                if z.meta[k] == META_INNER {
                    assert_eq!(n.count[k], 0);
                    stack.push((n.child[k] as usize, inner));
                    inner += 1;
                } else {
                    let count = u32::from(z.meta[k]);
                    assert_eq!(count, n.count[k]);
                    let got: Vec<_> = tree.tris[tri..tri + count as usize].to_vec();
                    let want: Vec<_> = unpack(wide, n.child[k], count).collect();
                    assert_eq!(got, want);
                    tri += count as usize;
                    leaf_tris += count as usize;
                }
            }
        }
        assert_eq!(seen, wide.nodes().len());
        assert_eq!(leaf_tris, tree.tris.len());
    }

    #[test]
    fn compressed_boxes_contain_the_wide_boxes() {
        for name in [
            "builtin:cornell:0.2",
            "builtin:forest:0.05",
            "builtin:hairball:0.02",
        ] {
            let (_, bvh) = testkit::builtin_with_bvh(name).expect("built-in scene");
            check(&bvh);
        }
        let mut rng = Rng::new(testkit::seed(5));
        for n in [1, 7, 300] {
            let scene = testkit::random_triangles(&mut rng, n, 10.0, 0.5);
            check(&Bvh::build(&scene, BuildPreset::Medium).expect("BVH"));
        }
    }
}
