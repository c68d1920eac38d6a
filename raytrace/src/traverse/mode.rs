//! The queries one walk is compiled for: each walk is a single loop specialised by a `MODE`
//! constant, so the closest-hit, any-hit, counted and reduced walks share their code and each
//! pays only for what it asks.

/// The nearest hit.
pub(super) const CLOSEST: u8 = 0;
/// Some hit, the first found: the walk ends there.
pub(super) const ANY: u8 = 1;
/// The nearest hit, with the nodes entered and triangles tested.
pub(super) const COUNTED: u8 = 2;
/// The thesis's reduced traversal: boxes only, counted.
pub(super) const REDUCED: u8 = 3;
/// The reduced traversal ended at the exit of the first leaf reached.
pub(super) const FIRST_LEAF: u8 = 4;
/// Some hit, with what it took to find it.
pub(super) const ANY_COUNTED: u8 = 5;
