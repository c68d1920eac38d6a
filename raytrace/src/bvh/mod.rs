//! The bounding volume hierarchy: built by obvhs's PLOC or by binned SAH (`sah.rs`)
//! ([`build`], with a [`BuildPreset`], reported in a [`BuildReport`]), its depth bounded
//! (`bound.rs` rebuilds deep subtrees), flattened into [`Node`]s and [`BvhTriangle`]s in leaf order ([`node`]), and checked
//! ([`mod@validate`]).

mod bound;
pub mod build;
pub mod node;
pub mod preset;
pub mod report;
pub(crate) mod sah;
pub mod validate;
pub mod wide;

pub use node::{BvhTriangle, Node, NodeArray};
pub use preset::BuildPreset;
pub use report::BuildReport;
pub use validate::{ValidationReport, validate};
pub use wide::WideBvh;

/// Deepest tree the traversal stacks (CPU and GPU) support; the build keeps every tree within
/// it by rebuilding deeper subtrees by object median.
pub const MAX_DEPTH: usize = 256;

/// A flattened binary BVH over a scene's non-degenerate triangles, and the 8-wide tree
/// collapsed from it.
///
/// The node array and the triangle array are the binary tree: a GPU uploads them unchanged and
/// the CPU's reduced traversals walk them. The CPU's hit queries walk the wide tree
/// ([`Bvh::wide`]), built from the same nodes and triangles. Fields are private so the
/// invariants that traversal relies on (checked by [`validate()`]) cannot be broken after the
/// build.
#[derive(Clone, Debug)]
pub struct Bvh {
    pub(crate) nodes: NodeArray,
    pub(crate) tris: Vec<BvhTriangle>,
    pub(crate) depth: usize,
    pub(crate) report: BuildReport,
    pub(crate) wide: WideBvh,
}

impl Bvh {
    /// Nodes; node 0 is the root, node 1 is [`Node::PAD`] and every inner node's children
    /// `index, index + 1` form an aligned pair (`index` is even).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Triangles in leaf order (a triangle can appear more than once with spatial splits).
    pub fn triangles(&self) -> &[BvhTriangle] {
        &self.tris
    }

    /// The 8-wide tree the CPU's hit queries walk.
    pub fn wide(&self) -> &WideBvh {
        &self.wide
    }

    /// Depth of the tree (a lone root leaf has depth 1).
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// How the build went.
    pub fn report(&self) -> &BuildReport {
        &self.report
    }

    /// The scene bounds as the root box sees them.
    pub fn bounds(&self) -> crate::Aabb {
        self.nodes[0].aabb()
    }
}
