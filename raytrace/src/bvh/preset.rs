//! How a tree is built ([`BuildPreset`]): obvhs's presets, by the names the command line
//! gives them.

use std::str::FromStr;

use obvhs::BvhBuildParams;

/// obvhs's build presets, from fastest build to best trees. The trade (build time against
/// trace speed) is measured by the bench; `Medium` is obvhs's "about embree's build time".
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildPreset {
    /// PLOC with search radius 1, one triangle per leaf, no optimisation.
    Fastest,
    /// Plus a little reinsertion and leaf collapse.
    VeryFast,
    /// Wider PLOC search.
    Fast,
    /// obvhs's default balance.
    #[default]
    Medium,
    /// Spatial pre-splits of large triangles and more reinsertion.
    Slow,
    /// The best trees obvhs builds.
    VerySlow,
}

impl BuildPreset {
    /// All presets, fastest build first.
    pub const ALL: [Self; 6] = [
        Self::Fastest,
        Self::VeryFast,
        Self::Fast,
        Self::Medium,
        Self::Slow,
        Self::VerySlow,
    ];

    /// The obvhs parameters.
    pub fn params(self) -> BvhBuildParams {
        match self {
            Self::Fastest => BvhBuildParams::fastest_build(),
            Self::VeryFast => BvhBuildParams::very_fast_build(),
            Self::Fast => BvhBuildParams::fast_build(),
            Self::Medium => BvhBuildParams::medium_build(),
            Self::Slow => BvhBuildParams::slow_build(),
            Self::VerySlow => BvhBuildParams::very_slow_build(),
        }
    }

    /// The CLI name (`fastest`, `very-fast`, `fast`, `medium`, `slow`, `very-slow`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Fastest => "fastest",
            Self::VeryFast => "very-fast",
            Self::Fast => "fast",
            Self::Medium => "medium",
            Self::Slow => "slow",
            Self::VerySlow => "very-slow",
        }
    }
}

impl FromStr for BuildPreset {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == s || p.name().replace('-', "_") == s)
            .ok_or_else(|| {
                format!(
                    "unknown BVH preset `{s}` (fastest, very-fast, fast, medium, slow, very-slow)"
                )
            })
    }
}
