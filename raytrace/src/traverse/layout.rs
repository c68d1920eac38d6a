//! Which tree the hit queries walk ([`Layout`]): the binary tree the GPU walks or the 8-wide
//! one collapsed from it, for comparing the two.

/// Which tree the hit queries walk. Both give the same closest hits, bit for bit; the any-hit
/// queries may stop at different hits (each returns some hit in range exactly when there is
/// one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layout {
    /// The binary tree, two boxes and one triangle at a time: what the GPU walks.
    Binary,
    /// The 8-wide tree collapsed from it ([`crate::bvh::wide`]), eight boxes and four
    /// triangles at a time: what the CPU queries walk.
    #[default]
    Wide,
}

impl Layout {
    /// The name used on the command line: `binary` or `wide`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Binary => "binary",
            Self::Wide => "wide",
        }
    }
}

impl std::str::FromStr for Layout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        [Self::Binary, Self::Wide]
            .into_iter()
            .find(|l| l.name() == s.trim())
            .ok_or_else(|| format!("unknown BVH layout `{s}` (expected binary or wide)"))
    }
}
