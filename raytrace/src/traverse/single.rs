//! The single-ray queries on [`Bvh`]: closest hit, any hit, their counted forms, the reduced
//! and first-leaf walks, and the same on a chosen tree ([`Layout`]).
//!
//! Hit queries walk the 8-wide tree (`wide.rs`), which is faster on the CPU; the reduced
//! traversals stay on the binary tree (`binary.rs`), the one the GPU walks, so the estimator
//! counts the GPU's work.

use crate::bvh::Bvh;
use crate::ray::{Hit, Ray};
use crate::traverse::counts::Counts;
use crate::traverse::layout::Layout;
use crate::traverse::mode::{ANY, ANY_COUNTED, CLOSEST, COUNTED, FIRST_LEAF, REDUCED};
use crate::traverse::walk::Walk;

impl Bvh {
    /// The nearest hit in `[ray.tmin, ray.tmax]`, if any.
    #[inline]
    pub fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        self.run::<CLOSEST>(ray).0
    }

    /// Some hit in range (the first found), for occlusion queries; stops at the first.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> Option<Hit> {
        self.run::<ANY>(ray).0
    }

    /// True when anything blocks the ray within its range.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.any_hit(ray).is_some()
    }

    /// The nearest hit and the work it took (`B`, `T`); the hit equals [`Bvh::closest_hit`]'s.
    #[inline]
    pub fn closest_hit_counted(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        self.run::<COUNTED>(ray)
    }

    /// Some hit and the work it took to find it (`B`, `T` up to the first hit); the hit
    /// equals [`Bvh::any_hit`]'s.
    #[inline]
    pub fn any_hit_counted(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        self.run::<ANY_COUNTED>(ray)
    }

    /// The thesis's reduced traversal: boxes only, no triangle fetched; see the module docs.
    #[inline]
    pub fn reduced_traversal(&self, ray: &Ray) -> Counts {
        self.run::<REDUCED>(ray).1
    }

    /// The reduced traversal that ends the ray at the exit of the first leaf it reaches.
    #[inline]
    pub fn first_leaf_traversal(&self, ray: &Ray) -> Counts {
        self.run::<FIRST_LEAF>(ray).1
    }

    /// The counts of `walk` for one ray.
    #[inline]
    pub fn walk(&self, ray: &Ray, walk: Walk) -> Counts {
        match walk {
            Walk::Reduced => self.reduced_traversal(ray),
            Walk::FirstLeaf => self.first_leaf_traversal(ray),
            Walk::Trace { any: false } => self.closest_hit_counted(ray).1,
            Walk::Trace { any: true } => self.any_hit_counted(ray).1,
        }
    }

    /// The nearest hit on the tree `layout` names; equal to [`Bvh::closest_hit`]'s.
    #[inline]
    pub fn closest_hit_in(&self, ray: &Ray, layout: Layout) -> Option<Hit> {
        match layout {
            Layout::Binary => self.run_binary::<CLOSEST>(ray).0,
            Layout::Wide => self.run_wide::<CLOSEST>(ray).0,
        }
    }

    /// Some hit in range on the tree `layout` names.
    #[inline]
    pub fn any_hit_in(&self, ray: &Ray, layout: Layout) -> Option<Hit> {
        match layout {
            Layout::Binary => self.run_binary::<ANY>(ray).0,
            Layout::Wide => self.run_wide::<ANY>(ray).0,
        }
    }

    /// The counted queries on the tree `layout` names (`any` for the any-hit one), for
    /// comparing the two trees' work.
    #[inline]
    pub fn counted_in(&self, ray: &Ray, any: bool, layout: Layout) -> (Option<Hit>, Counts) {
        match (layout, any) {
            (Layout::Binary, false) => self.run_binary::<COUNTED>(ray),
            (Layout::Binary, true) => self.run_binary::<ANY_COUNTED>(ray),
            (Layout::Wide, false) => self.run_wide::<COUNTED>(ray),
            (Layout::Wide, true) => self.run_wide::<ANY_COUNTED>(ray),
        }
    }

    /// Hit queries walk the wide tree, which is faster on the CPU; the reduced traversals stay
    /// on the binary tree, the one the GPU walks, so the estimator counts the GPU's work.
    #[inline(always)]
    fn run<const MODE: u8>(&self, ray: &Ray) -> (Option<Hit>, Counts) {
        if MODE == REDUCED || MODE == FIRST_LEAF {
            self.run_binary::<MODE>(ray)
        } else {
            self.run_wide::<MODE>(ray)
        }
    }
}
