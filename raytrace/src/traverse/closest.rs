//! What the closest hit is, for every walk that looks for one (binary, wide, rays sharing an
//! origin): the order hits are compared in, and how far past the nearest hit so far nodes are
//! still entered. Every walk following these two rules returns the same hit, bit for bit.

use crate::ray::Hit;

/// Whether a hit at `t` on `prim` replaces `best`: the smaller distance, and on equal
/// distances the smaller primitive id, so the closest hit does not depend on the order the
/// tree is walked in.
#[inline(always)]
pub(super) fn better(t: f32, prim: u32, best: Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && prim < b.prim),
    }
}

/// How far past the nearest hit so far nodes are still entered. A triangle's computed
/// distance and its leaf box's computed entry differ by a few roundings, so a leaf holding a
/// hit at exactly the nearest distance (a tie the primitive id decides) could otherwise be
/// culled by one walk and not by another.
#[inline(always)]
pub(super) fn cull_bound(t: f32) -> f32 {
    t + t.abs() * (16.0 * crate::spawn::gamma(3))
}
