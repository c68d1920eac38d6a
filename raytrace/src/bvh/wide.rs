//! The 8-wide BVH the CPU traces: the binary tree collapsed so that each node holds up to eight
//! children's boxes side by side (one SIMD lane each: one AVX2 register, or two SSE ones), and
//! each leaf's triangles packed four to a group, coordinates by lane (see `simd.rs`).
//!
//! Collapsing keeps the binary tree's leaves and boxes as they are: a wide node's children are
//! binary nodes, so a ray tests only boxes and leaves the binary traversal would, fewer of them
//! one by one, and the counts of the two trees compare. Which inner binary nodes become wide
//! nodes and which are skipped is chosen for the least SAH cost by dynamic programming over
//! the binary tree (Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs
//! Through Compressed Wide BVHs", HPG 2017): for every binary node and every number of slots up
//! to eight, the cheapest way to cover its subtree with that many children of one wide node.
//! Opening the largest child until there are eight, the greedy rule, leaves half-empty nodes
//! wherever the children it stops at hold only two or three leaves: on the scanned meshes
//! and scenes measured, 4.2–4.6 children per node against 5.6–6.2 here, and 20–30 % more
//! nodes.
//!
//! Eight, not four, as Embree's trees on AVX2 CPUs: half as many levels, so half as many
//! dependent node fetches on the way down, which is what an incoherent ray waits on.

use bytemuck::{Pod, Zeroable};

use super::node::{BvhTriangle, Node};

/// Children per wide node.
pub const WIDTH: usize = 8;

/// Eight child boxes and their references, 256 bytes (four cache lines), `Pod`.
///
/// Child `k` is an inner node (`count[k] == 0`) at `child[k]` of [`WideBvh::nodes`], or a
/// leaf of `count[k]` triangles in groups `child[k] ..` of [`WideBvh::groups`]. An unused slot
/// has an empty box (min `f32::MAX`, max `f32::MIN`) that no ray enters, as [`Node::PAD`].
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Node8 {
    /// Box planes by lane: min x, min y, min z, max x, max y, max z. Each row is 32-byte
    /// aligned, as AVX's aligned loads want.
    pub planes: [[f32; WIDTH]; 6],
    /// Inner node index or first triangle group.
    pub child: [u32; WIDTH],
    /// Triangles of a leaf child; zero for an inner child.
    pub count: [u32; WIDTH],
}

const _: () = assert!(size_of::<Node8>() == 256);

impl Node8 {
    const EMPTY: Self = Self {
        planes: [
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [f32::MIN; WIDTH],
            [f32::MIN; WIDTH],
            [f32::MIN; WIDTH],
        ],
        child: [0; WIDTH],
        count: [0; WIDTH],
    };

    fn set(&mut self, k: usize, n: &Node, child: u32, count: u32) {
        for a in 0..3 {
            self.planes[a][k] = n.min[a];
            self.planes[3 + a][k] = n.max[a];
        }
        self.child[k] = child;
        self.count[k] = count;
    }
}

/// Four triangles, 160 bytes, `Pod`: the exact scene vertices (as [`BvhTriangle`] keeps them)
/// by vertex, axis and lane, and their primitive ids. A leaf whose size is not a multiple of
/// four repeats its last triangle in the spare lanes: a repeat finds the same hit, never a new
/// one, so no lane needs masking.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Tri4 {
    /// `v[vertex][axis][lane]`.
    pub v: [[[f32; 4]; 3]; 3],
    /// Primitive ids by lane.
    pub prim: [u32; 4],
}

const _: () = assert!(size_of::<Tri4>() == 160);

/// The collapsed tree; empty when the binary tree has no triangles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WideBvh {
    pub(crate) nodes: Vec<Node8>,
    pub(crate) groups: Vec<Tri4>,
    /// Levels of wide nodes (a lone root has depth 1); no more than the binary tree's.
    pub(crate) depth: usize,
}

impl WideBvh {
    /// Asks for the cache lines of every child of `node` whose bit is set in `kids`, at once.
    ///
    /// For an estimate's sampled packets: each lies far from the packet walked before it, so
    /// the nodes and triangles it enters are cold, and asked for together they arrive
    /// together instead of each waiting in turn. A packet of the full trace finds them warm
    /// from its neighbours, and there the requests only cost.
    #[inline(always)]
    pub(crate) fn prefetch_children(&self, node: &Node8, mut kids: u32) {
        while kids != 0 {
            let k = kids.trailing_zeros() as usize;
            kids &= kids - 1;
            self.prefetch_child(node.child[k], node.count[k]);
        }
    }

    /// Asks for the cache lines of child `(child, count)` of a node: an inner node's four, or
    /// the first three of a leaf's triangle groups (a group is 160 bytes).
    #[inline(always)]
    fn prefetch_child(&self, child: u32, count: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let (p, lines): (*const i8, usize) = if count == 0 {
                (self.nodes.as_ptr().wrapping_add(child as usize).cast(), 4)
            } else {
                (self.groups.as_ptr().wrapping_add(child as usize).cast(), 3)
            };
            for l in 0..lines {
                // SAFETY: a prefetch only hints the cache and never reads or faults.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * l)) }
            }
        }
    }

    /// Wide nodes; node 0 is the root, whose children are the binary root's.
    pub fn nodes(&self) -> &[Node8] {
        &self.nodes
    }

    /// Levels of wide nodes.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// Triangle groups, leaf by leaf.
    pub fn groups(&self) -> &[Tri4] {
        &self.groups
    }

    /// Collapses a valid binary tree (`nodes`, `tris` as [`super::Bvh`] holds them).
    pub(crate) fn collapse(nodes: &[Node], tris: &[BvhTriangle]) -> Self {
        let mut out = Self::default();
        if tris.is_empty() {
            return out;
        }
        let plan = Plan::new(nodes);
        out.nodes.push(Node8::EMPTY);
        // (wide node to fill, its children's binary nodes, level). A lone root leaf becomes
        // the only child of the wide root.
        let root_kids = if nodes[0].is_leaf() {
            vec![0]
        } else {
            plan.children(nodes, 0)
        };
        let mut todo = vec![(0usize, root_kids, 1usize)];
        while let Some((w, kids, level)) = todo.pop() {
            out.depth = out.depth.max(level);
            let mut inner = Vec::new();
            for (k, &i) in kids.iter().enumerate() {
                let n = &nodes[i];
                if let Some((start, count)) = plan.leaf[i] {
                    let first = out.groups.len() as u32;
                    let leaf = &tris[start as usize..(start + count) as usize];
                    for chunk in leaf.chunks(4) {
                        out.groups.push(pack(chunk));
                    }
                    out.nodes[w].set(k, n, first, count);
                } else {
                    let c = out.nodes.len();
                    out.nodes.push(Node8::EMPTY);
                    out.nodes[w].set(k, n, c as u32, 0);
                    inner.push((c, plan.children(nodes, i), level + 1));
                }
            }
            // Depth first, first child next, so a subtree's nodes lie together.
            todo.extend(inner.into_iter().rev());
        }
        out
    }
}

/// How a binary node's subtree fills at most `i` children of a wide node.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fill {
    /// One child: the node itself, a leaf or a wide node.
    One,
    /// Its left subtree takes this many children, its right subtree the rest.
    Split(u8),
}

/// The collapse's choices, by binary node: the result of the dynamic programme.
struct Plan {
    /// `fill[n][i - 1]`: the cheapest way to cover `n`'s subtree with at most `i` children.
    fill: Vec<[Fill; WIDTH]>,
    /// How many of the eight children of the wide node made of inner node `n` cover its left
    /// subtree (the right one's take the rest).
    left: Vec<u8>,
    /// The triangles `(first, count)` of a leaf.
    leaf: Vec<Option<(u32, u32)>>,
}

impl Plan {
    fn new(nodes: &[Node]) -> Self {
        // Reachable nodes, parents before children: the reverse visits children first.
        let mut order = Vec::new();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            order.push(i);
            if !nodes[i].is_leaf() {
                let l = nodes[i].index as usize;
                stack.extend([l, l + 1]);
            }
        }
        // The SAH cost of a cover: the summed areas of the wide nodes it makes, to which a
        // random ray's expected node visits are proportional. Leaves are the binary tree's in
        // every cover, so their cost is the same in all and left out.
        let mut cost = vec![[f64::INFINITY; WIDTH]; nodes.len()];
        let mut fill = vec![[Fill::One; WIDTH]; nodes.len()];
        let mut leaf = vec![None; nodes.len()];
        let mut left = vec![0u8; nodes.len()];
        for &n in order.iter().rev() {
            let node = &nodes[n];
            if node.is_leaf() {
                cost[n] = [0.0; WIDTH];
                leaf[n] = Some((node.index, node.count));
                continue;
            }
            let l = node.index as usize;
            // `split[i - 1]`: the cheapest cover by the two subtrees with at most `i` children;
            // one child on the left where no cost compares (an infinite or NaN area).
            let mut split = [(f64::INFINITY, 1u8); WIDTH];
            for i in 2..=WIDTH {
                for k in 1..i {
                    let c = cost[l][k - 1] + cost[l + 1][i - k - 1];
                    if c < split[i - 1].0 {
                        split[i - 1] = (c, k as u8);
                    }
                }
            }
            cost[n][0] = node.aabb().half_area() + split[WIDTH - 1].0;
            for i in 2..=WIDTH {
                let (c, k) = split[i - 1];
                if c < cost[n][i - 2] {
                    cost[n][i - 1] = c;
                    fill[n][i - 1] = Fill::Split(k);
                } else {
                    cost[n][i - 1] = cost[n][i - 2];
                    fill[n][i - 1] = fill[n][i - 2];
                }
            }
            left[n] = split[WIDTH - 1].1;
        }
        Self { fill, leaf, left }
    }

    /// The children of the wide node made of inner binary node `n`: two to eight binary nodes.
    fn children(&self, nodes: &[Node], n: usize) -> Vec<usize> {
        let mut kids = Vec::with_capacity(WIDTH);
        let (l, k) = (nodes[n].index as usize, self.left[n] as usize);
        self.cover(nodes, l, k, &mut kids);
        self.cover(nodes, l + 1, WIDTH - k, &mut kids);
        kids
    }

    /// Appends the children covering `n`'s subtree with at most `i` of them.
    fn cover(&self, nodes: &[Node], n: usize, i: usize, kids: &mut Vec<usize>) {
        match self.fill[n][i - 1] {
            Fill::One => kids.push(n),
            Fill::Split(k) => {
                let l = nodes[n].index as usize;
                self.cover(nodes, l, k as usize, kids);
                self.cover(nodes, l + 1, i - k as usize, kids);
            }
        }
    }
}

/// One to four triangles in lanes, the last repeated into the spare lanes.
fn pack(tris: &[BvhTriangle]) -> Tri4 {
    let mut g = Tri4::zeroed();
    for lane in 0..4 {
        let t = &tris[lane.min(tris.len() - 1)];
        for (vertex, p) in [t.v0, t.v1, t.v2].iter().enumerate() {
            for (axis, &x) in p.iter().enumerate() {
                g.v[vertex][axis][lane] = x;
            }
        }
        g.prim[lane] = t.prim;
    }
    g
}
