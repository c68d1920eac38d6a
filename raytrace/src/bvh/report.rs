//! What a build did and how good its tree is ([`BuildReport`]), kept with the tree.

use super::preset::BuildPreset;

/// What the build did and how good the tree is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BuildReport {
    /// The preset used.
    pub preset: BuildPreset,
    /// obvhs's core build time (PLOC, splits, reinsertion, collapse), seconds.
    pub build_seconds: f64,
    /// Everything: triangle boxes, build and flattening, seconds.
    pub total_seconds: f64,
    /// SAH cost with unit node and triangle costs: `(sum of inner areas + sum of leaf areas
    /// times their triangle counts) / root area`. Lower is better; comparable across presets.
    pub sah_cost: f64,
    /// Node count.
    pub nodes: usize,
    /// Leaf count.
    pub leaves: usize,
    /// Triangle references in leaves (more than the triangles with spatial splits).
    pub leaf_triangles: usize,
    /// Degenerate triangles left out.
    pub degenerate_skipped: usize,
    /// Whether large triangles were split (a triangle may then sit in several leaves).
    pub spatial_splits: bool,
    /// Collapsing the binary tree into the CPU's 8-wide one, seconds (part of the total).
    pub collapse_seconds: f64,
}
