//! The flat node and triangle layouts that the CPU traverses and the GPU uploads unchanged.

use bytemuck::{Pod, Zeroable};
use obvhs::triangle::Triangle;

/// A BVH node, 32 bytes: `#[repr(C)]`, `Pod`, and laid out like the WGSL struct
/// `struct Node { min: vec3<f32>, index: u32, max: vec3<f32>, count: u32 }` (a `vec3<f32>` has
/// 16-byte alignment there, so `index` and `count` fill the padding exactly).
///
/// An inner node (`count == 0`) has its children at `index` and `index + 1`; a leaf
/// (`count > 0`) owns triangles `index .. index + count` of [`crate::Bvh::triangles`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Node {
    /// Box minimum.
    pub min: [f32; 3],
    /// Left child (inner) or first triangle (leaf).
    pub index: u32,
    /// Box maximum.
    pub max: [f32; 3],
    /// Triangle count; zero for an inner node.
    pub count: u32,
}

const _: () = assert!(size_of::<Node>() == 32);

impl Node {
    /// The filler at index 1 (and at the end of an odd array): an empty box that no ray
    /// enters and no node points to. It keeps every sibling pair `2k, 2k + 1` on one
    /// 64-byte cache line, so a traversal step touches one line, not two.
    pub const PAD: Self = Self {
        min: [f32::MAX; 3],
        index: 0,
        max: [f32::MIN; 3],
        count: 0,
    };
}

/// Two sibling nodes on one cache line.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
struct NodePair([Node; 2]);

/// The node array, stored 64-byte aligned so that pairs `2k, 2k + 1` share a cache line;
/// reads and writes as a plain `[Node]`, which is also the GPU's view.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeArray(Vec<NodePair>);

impl From<Vec<Node>> for NodeArray {
    /// Copies `nodes` into aligned storage, appending [`Node::PAD`] if their number is odd.
    fn from(mut nodes: Vec<Node>) -> Self {
        if nodes.len() % 2 == 1 {
            nodes.push(Node::PAD);
        }
        Self(bytemuck::pod_collect_to_vec(&nodes))
    }
}

impl std::ops::Deref for NodeArray {
    type Target = [Node];
    fn deref(&self) -> &[Node] {
        bytemuck::cast_slice(&self.0)
    }
}

impl std::ops::DerefMut for NodeArray {
    fn deref_mut(&mut self) -> &mut [Node] {
        bytemuck::cast_slice_mut(&mut self.0)
    }
}

impl Node {
    /// True for a leaf.
    #[inline(always)]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The box.
    pub fn aabb(&self) -> crate::Aabb {
        crate::Aabb {
            min: self.min.into(),
            max: self.max.into(),
        }
    }
}

/// A triangle in BVH leaf order, 48 bytes (three WGSL `vec4`s): the exact scene vertices (the
/// watertight test needs the shared vertices bit for bit, not edges) and the original
/// primitive id in the padding of the first.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhTriangle {
    /// Vertex 0.
    pub v0: [f32; 3],
    /// Primitive id (triangle index in the scene file).
    pub prim: u32,
    /// Vertex 1.
    pub v1: [f32; 3],
    /// Unused (keeps the GPU layout of a `vec4`).
    pub pad1: u32,
    /// Vertex 2.
    pub v2: [f32; 3],
    /// Unused.
    pub pad2: u32,
}

const _: () = assert!(size_of::<BvhTriangle>() == 48);

/// An obvhs triangle in the GPU layout, tagged with its scene primitive id.
pub(super) fn leaf_triangle(t: &Triangle, prim: u32) -> BvhTriangle {
    BvhTriangle {
        v0: t.v0.to_array(),
        prim,
        v1: t.v1.to_array(),
        pad1: 0,
        v2: t.v2.to_array(),
        pad2: 0,
    }
}
