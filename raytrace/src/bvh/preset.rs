//! How a tree is built ([`BuildPreset`]): obvhs's PLOC presets and the top-down binned SAH
//! build (`sah.rs`), by the names the command line gives them.

use std::str::FromStr;

use obvhs::BvhBuildParams;

/// obvhs's PLOC build presets, from fastest build to best trees, then the top-down binned SAH
/// build. The trade (build time against trace speed) is measured by `cobalt tradeoff`;
/// `Medium` is obvhs's "about embree's build time".
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
    /// Top-down binned SAH (32 slabs per axis on centroids), without PLOC or reinsertion.
    Sah,
}

impl BuildPreset {
    /// All presets: obvhs's, fastest build first, then the SAH build.
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
            Self::Medium | Self::Sah => BvhBuildParams::medium_build(),
            Self::Slow => BvhBuildParams::slow_build(),
            Self::VerySlow => BvhBuildParams::very_slow_build(),
        }
    }

    /// The CLI name (`fastest`, `very-fast`, `fast`, `medium`, `slow`, `very-slow`, `sah`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Fastest => "fastest",
            Self::VeryFast => "very-fast",
            Self::Fast => "fast",
            Self::Medium => "medium",
            Self::Slow => "slow",
            Self::VerySlow => "very-slow",
            Self::Sah => "sah",
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
                    "unknown BVH preset `{s}` (fastest, very-fast, fast, medium, slow, very-slow, sah)"
                )
            })
    }
}
