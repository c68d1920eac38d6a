//! The 8-wide BVH the CPU traces: the binary tree collapsed so that each node holds up to eight
//! children's boxes side by side (one SIMD lane each: one AVX2 register, or two SSE ones), and
//! each leaf's triangles packed four to a group, coordinates by lane (see `simd.rs`).
//!
//! Collapsing keeps the binary tree's leaves and boxes as they are: a wide node's children are
//! binary nodes, chosen by opening the largest-area inner child until there are eight. A ray
//! therefore tests exactly the boxes the binary traversal would, only fewer of them one by one.
//! Eight, not four, as Embree's trees on AVX2 CPUs: half as many levels, so half as many
//! dependent node fetches on the way down, which is what an incoherent ray waits on.

use bytemuck::{Pod, Zeroable};

use super::{BvhTriangle, Node};

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
        let spans = spans(nodes);
        // An inner node whose subtree holds at most one group's triangles, in one run, becomes
        // a leaf: one four-triangle test costs less than the boxes and tests below it.
        let leaf_of = |i: usize| -> Option<(u32, u32)> {
            let n = &nodes[i];
            if n.is_leaf() {
                return Some((n.index, n.count));
            }
            spans[i].filter(|&(_, c)| c <= 4)
        };
        out.nodes.push(Node8::EMPTY);
        // (wide node to fill, binary node whose children it gets). A lone root leaf becomes
        // the only child of the wide root.
        let mut todo: Vec<(usize, Option<usize>, usize)> =
            vec![(0, (!nodes[0].is_leaf()).then_some(0), 1)];
        while let Some((w, b, level)) = todo.pop() {
            out.depth = out.depth.max(level);
            let mut kids: Vec<usize> = match b {
                Some(b) => {
                    let l = nodes[b].index as usize;
                    vec![l, l + 1]
                }
                None => vec![0],
            };
            // Open the largest inner child until eight: the big boxes are the ones rays enter
            // most often, so they are the ones worth testing alongside their siblings.
            while kids.len() < WIDTH {
                let widest = kids
                    .iter()
                    .enumerate()
                    .filter(|(_, i)| leaf_of(**i).is_none())
                    .max_by(|a, b| {
                        let area = |i: usize| nodes[i].aabb().half_area();
                        area(*a.1).total_cmp(&area(*b.1))
                    })
                    .map(|(k, _)| k);
                let Some(k) = widest else { break };
                let l = nodes[kids[k]].index as usize;
                kids.splice(k..=k, [l, l + 1]);
            }
            let mut inner = Vec::new();
            for (k, &i) in kids.iter().enumerate() {
                let n = &nodes[i];
                if let Some((start, count)) = leaf_of(i) {
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
                    inner.push((c, Some(i), level + 1));
                }
            }
            // Depth first, first child next, so a subtree's nodes lie together.
            todo.extend(inner.into_iter().rev());
        }
        out
    }
}

/// Each node's triangles as one run `(first, count)` of the triangle array, where they form
/// one (the flattening writes leaves depth first, so every subtree's do).
fn spans(nodes: &[Node]) -> Vec<Option<(u32, u32)>> {
    let mut spans = vec![None; nodes.len()];
    // Children come after their parent, so a backward sweep sees them first.
    for i in (0..nodes.len()).rev() {
        let n = &nodes[i];
        if n.is_leaf() {
            spans[i] = Some((n.index, n.count));
        } else if i == 0 || n != &Node::PAD {
            let l = n.index as usize;
            spans[i] = match (
                spans.get(l).copied().flatten(),
                spans.get(l + 1).copied().flatten(),
            ) {
                (Some((a, m)), Some((b, k))) if a + m == b => Some((a, m + k)),
                _ => None,
            };
        }
    }
    spans
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
