//! Traversal of the [`Bvh`](crate::bvh::Bvh): single rays, rays sharing an origin, packets of
//! reduced walks, and batches of all of them.
//!
//! The queries (`mode.rs`): the closest hit; any hit, the first found, for shadow and AO rays;
//! both counted, with the cost the thesis models, nodes visited `B` and triangle tests `T`
//! ([`Counts`]); and the estimator's walks ([`Walk`]): the thesis's *reduced traversal*
//! (section 3.3), boxes only, never fetching a triangle, and the first-leaf walk that ends
//! each ray at the exit of the first leaf it reaches. Every closest-hit walk returns the same
//! hit, bit for bit, by the rules of `closest.rs`.
//!
//! Where each is walked:
//! - `single.rs`: one ray's queries ([`Bvh::closest_hit`](crate::bvh::Bvh::closest_hit) and
//!   the rest), on the tree [`Layout`] names;
//! - `binary.rs`: the binary tree, one loop for every query;
//! - `wide.rs`: the 8-wide tree, eight boxes and four triangles a step (`simd.rs` holds the
//!   lane kernels), and runs of rays sharing an origin handed to
//! - `shared.rs`: any-hit and closest-hit rays sharing an origin walked together (AVX2),
//!   thirty-two at a time, gathered and set up eight lanes a step by `lanes.rs`, from a
//!   batch's columns or its rays' records (`source.rs`);
//! - `packet.rs`: reduced and first-leaf walks of eight rays at once (AVX2);
//! - `batch.rs`: the batch queries over a [`crate::RayBatch`], in parallel.

pub(crate) mod batch;
mod binary;
mod closest;
pub(crate) mod counts;
#[cfg(target_arch = "x86_64")]
mod lanes;
pub(crate) mod layout;
mod mode;
mod packet;
#[cfg(target_arch = "x86_64")]
mod shared;
mod simd;
mod single;
mod source;
pub(crate) mod walk;
mod wide;

pub use batch::{
    any_hits, any_hits_counted, closest_hits, closest_hits_counted, fill_skipping, hits_counted_in,
    hits_in, hits_into, hits_skipping, hits_skipping_in, reduced_counts, reduced_counts_at, slices,
    traced_at,
};
pub use counts::Counts;
pub use layout::Layout;
pub use walk::{Walk, near_child_first};
