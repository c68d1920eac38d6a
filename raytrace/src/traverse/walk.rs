//! How the cost estimator walks the tree with its sampled rays ([`Walk`]), and the fixed
//! child order of the first-leaf walk ([`near_child_first`]): what the single-ray walks of
//! `binary.rs` and the packets of `packet.rs` both follow.

/// How the cost estimator walks the tree with its sampled rays: the thesis's reduced
/// traversal, a shortened one, or the real trace. (AO rays are called probes elsewhere; this
/// is not them.)
///
/// The reduced walk never shortens a ray, so on a closed mesh a camera ray is counted
/// through every box behind the surface it stops at: on the Stanford Dragon it enters 78
/// nodes where the trace enters 25. Ending each ray at the exit of the first leaf it reaches
/// stands for "the ray hits something there", which is what a closed surface does. It is the
/// better model for closest-hit rays on closed meshes and dense geometry, and the worse one
/// where rays pass leaves without hitting (foliage) and for any-hit rays; `cobalt estimate
/// --walk auto` measures both and picks.
///
/// [`Walk::Trace`] is not a reduced traversal: the sample is traced for real, triangles and
/// all, and counted as traced. It costs more per sampled ray but models rooms, where rays stop
/// at walls, far better (`docs/results.md`, "The cost estimate: accuracy and overhead per
/// scene": the reduced walk's error against the trace walk's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Walk {
    /// The thesis's reduced traversal: the whole `[tmin, tmax]` of every ray, boxes only.
    #[default]
    Reduced,
    /// Each ray ends at the exit of the first leaf it reaches, in [`near_child_first`] order.
    FirstLeaf,
    /// The real trace's own counts: a closest hit, or with `any` the first hit found (what
    /// shadow and AO rays are traced with; [`Walk::for_kind`] sets it).
    Trace {
        /// Stop at the first hit found.
        any: bool,
    },
}

impl Walk {
    /// The reduced traversals, in order: what `--walk auto` chooses between.
    pub const ALL: [Self; 2] = [Self::Reduced, Self::FirstLeaf];

    /// The name used on the command line and in reports: `reduced`, `first-leaf` or `trace`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Reduced => "reduced",
            Self::FirstLeaf => "first-leaf",
            Self::Trace { .. } => "trace",
        }
    }

    /// The walk a generation of `kind` is estimated with. For closest-hit rays, this one.
    /// For any-hit rays (shadow, AO), the reduced walk instead of the first-leaf walk, which
    /// modelled the measured times worse on every scene measured, and an
    /// any-hit trace for the trace walk.
    pub fn for_kind(self, kind: crate::ray::RayKind) -> Self {
        match self {
            Self::Trace { .. } => Self::Trace {
                any: kind.is_occlusion(),
            },
            _ if kind.is_occlusion() => Self::Reduced,
            p => p,
        }
    }
}

impl std::str::FromStr for Walk {
    type Err = String;
    /// Parses [`Walk::name`]'s names (`trace` as the closest-hit trace; see
    /// [`Walk::for_kind`]).
    fn from_str(s: &str) -> Result<Self, String> {
        let s = s.trim();
        Self::ALL
            .into_iter()
            .chain([Self::Trace { any: false }])
            .find(|p| p.name() == s)
            .ok_or_else(|| format!("unknown walk `{s}` (expected reduced, first-leaf or trace)"))
    }
}

/// The first-leaf walk's child order: along the axis on which the two children's centres lie
/// furthest apart, the child nearer the side the ray comes from. It depends on the direction's
/// signs alone, not on the ray's distances to the boxes, so rays that share their signs (a
/// packet of camera rays) share the order, and a packet walks exactly like each of its rays.
#[inline(always)]
pub fn near_child_first(pair: &[crate::bvh::node::Node; 2], negative: [bool; 3]) -> bool {
    let gap = |a: usize| (pair[1].min[a] + pair[1].max[a]) - (pair[0].min[a] + pair[0].max[a]);
    let g = [gap(0), gap(1), gap(2)];
    let a = if g[0].abs() >= g[1].abs() {
        if g[0].abs() >= g[2].abs() { 0 } else { 2 }
    } else if g[1].abs() >= g[2].abs() {
        1
    } else {
        2
    };
    (g[a] >= 0.0) != negative[a]
}
