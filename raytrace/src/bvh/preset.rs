//! How a tree is built ([`BuildPreset`]): obvhs's PLOC presets and the top-down binned SAH
//! build (`sah.rs`), by the names the command line gives them, and the rule that picks one
//! for a scene ([`BuildPreset::Auto`], [`BuildPreset::for_areas`]).

use std::str::FromStr;

use obvhs::BvhBuildParams;

/// obvhs's PLOC build presets, from fastest build to best trees, then the top-down binned SAH
/// build, then the per-scene choice between them. The trade (build time against trace speed)
/// is measured by `cobalt tradeoff`; `Medium` is obvhs's "about embree's build time".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildPreset {
    /// PLOC with search radius 1, one triangle per leaf, no optimisation.
    Fastest,
    /// Plus a little reinsertion and leaf collapse.
    VeryFast,
    /// Wider PLOC search.
    Fast,
    /// obvhs's default balance.
    Medium,
    /// Spatial pre-splits of large triangles and more reinsertion.
    Slow,
    /// The best trees obvhs builds.
    VerySlow,
    /// Top-down binned SAH (32 slabs per axis on centroids), without PLOC or reinsertion.
    Sah,
    /// `Sah` or `Medium`, by [`BuildPreset::for_areas`] on the scene's triangles; a tree's
    /// [`BuildReport`](super::BuildReport) names the one it was built with.
    #[default]
    Auto,
}

impl BuildPreset {
    /// Every build: obvhs's, fastest first, then the SAH build (not [`BuildPreset::Auto`],
    /// which is one of them).
    pub const ALL: [Self; 7] = [
        Self::Fastest,
        Self::VeryFast,
        Self::Fast,
        Self::Medium,
        Self::Slow,
        Self::VerySlow,
        Self::Sah,
    ];

    /// The obvhs parameters; the SAH build reads only `pre_split` (off) of medium's.
    pub fn params(self) -> BvhBuildParams {
        match self {
            Self::Fastest => BvhBuildParams::fastest_build(),
            Self::VeryFast => BvhBuildParams::very_fast_build(),
            Self::Fast => BvhBuildParams::fast_build(),
            Self::Medium | Self::Sah | Self::Auto => BvhBuildParams::medium_build(),
            Self::Slow => BvhBuildParams::slow_build(),
            Self::VerySlow => BvhBuildParams::very_slow_build(),
        }
    }

    /// The CLI name (`fastest`, `very-fast`, `fast`, `medium`, `slow`, `very-slow`, `sah`,
    /// `auto`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Fastest => "fastest",
            Self::VeryFast => "very-fast",
            Self::Fast => "fast",
            Self::Medium => "medium",
            Self::Slow => "slow",
            Self::VerySlow => "very-slow",
            Self::Sah => "sah",
            Self::Auto => "auto",
        }
    }
}

impl FromStr for BuildPreset {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL
            .into_iter()
            .chain([Self::Auto])
            .find(|p| p.name() == s || p.name().replace('-', "_") == s)
            .ok_or_else(|| {
                format!(
                    "unknown BVH preset `{s}` (fastest, very-fast, fast, medium, slow, very-slow, sah, auto)"
                )
            })
    }
}

/// Above this share of the triangles' summed box area in their largest 1 %, [`BuildPreset::Auto`]
/// builds with PLOC: a scene of a few huge triangles among many small ones (an interior's
/// walls and floors around its furniture). On the scenes measured (`docs/results.md`) the
/// share is 0.69 for Conference, where PLOC's tree traces 25-28 % faster than the SAH build's,
/// and at most 0.31 for the others, where the SAH build's traces as fast or faster (forest:
/// level within the noise of a shared machine).
pub const CONCENTRATED_AREA: f32 = 0.5;

impl BuildPreset {
    /// The build [`BuildPreset::Auto`] picks for triangles whose boxes have half areas
    /// `areas` (reordered in place): [`BuildPreset::Medium`] where their largest 1 % hold more
    /// than [`CONCENTRATED_AREA`] of the sum, else [`BuildPreset::Sah`]. Linear time: one
    /// selection and two sums.
    pub fn for_areas(areas: &mut [f32]) -> Self {
        let n = areas.len();
        let top = n.div_ceil(100);
        if n == 0 {
            return Self::Sah;
        }
        let total: f64 = areas.iter().map(|&a| f64::from(a)).sum();
        areas.select_nth_unstable_by(n - top, f32::total_cmp);
        let largest: f64 = areas[n - top..].iter().map(|&a| f64::from(a)).sum();
        if largest > f64::from(CONCENTRATED_AREA) * total {
            Self::Medium
        } else {
            Self::Sah
        }
    }
}
