//! The cost model `C = kR·R + kB·B + kT·T`: the thesis's `kB·B + kT·T` (equation 3.1) and
//! a per-ray term.
//!
//! The per-ray term is what a ray costs apart from its nodes and triangles (its setup, the
//! root's box tests, writing its hit). Without it a task of rays that miss everything looks
//! free: on an open scene whose sky tasks each cost a few node visits a ray, the real trace's
//! counts calibrated without it left a plan of eight devices at 62 % balance where the
//! measured times gave 98 %.

use crate::traverse::counts::Counts;

/// Nodes entered `B` and triangles reached `T` of a task, and the rays `R` they were counted
/// for: exact sums for a full count, scaled sample sums for an estimate (hence `f64`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Work {
    /// `B`: nodes entered.
    pub nodes: f64,
    /// `T`: triangles in reached leaves (reduced traversal) or tested (full trace).
    pub tris: f64,
    /// `R`: the task's rays (for a task of paths, its paths).
    pub rays: f64,
}

impl Work {
    /// Sums per-ray counts exactly (in integers) before converting, so a task's full work does
    /// not depend on summation order.
    pub fn sum(counts: &[Counts]) -> Self {
        let (b, t) = counts.iter().fold((0u64, 0u64), |(b, t), c| {
            (b + u64::from(c.nodes), t + u64::from(c.tris))
        });
        Self {
            nodes: b as f64,
            tris: t as f64,
            rays: counts.len() as f64,
        }
    }

    /// `self + other`, term by term.
    pub fn plus(self, other: Self) -> Self {
        Self {
            nodes: self.nodes + other.nodes,
            tris: self.tris + other.tris,
            rays: self.rays + other.rays,
        }
    }

    /// The work of `len` rays from that of `sampled` of them: `· len / sampled`, multiplied
    /// first so that integral results (a uniform task) come out exact.
    pub fn scaled(self, len: usize, sampled: usize) -> Self {
        let (n, k) = (len as f64, sampled as f64);
        Self {
            nodes: self.nodes * n / k,
            tris: self.tris * n / k,
            rays: self.rays * n / k,
        }
    }
}

/// The constants of `C = kR·R + kB·B + kT·T`: what one ray, one node visit and one triangle
/// test cost, in seconds after a calibration or in node-visit units by default.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CostModel {
    /// `kR`: cost of one ray apart from its nodes and triangles.
    pub kr: f64,
    /// `kB`: cost of entering one node (two child box tests).
    pub kb: f64,
    /// `kT`: cost of one triangle test.
    pub kt: f64,
}

impl Default for CostModel {
    /// `kR = 0`, `kB = 1`, `kT = 2`: one watertight triangle test costs about two node
    /// entries (four box tests' worth of arithmetic plus a triangle fetch) in our CPU
    /// traversal, and `B` already counts each ray's root; the order of magnitude is all a
    /// policy needs before a calibration exists.
    fn default() -> Self {
        Self::counts_only(1.0, 2.0)
    }
}

impl CostModel {
    /// A model of the counts alone, `kR = 0`: the thesis's equation 3.1.
    pub fn counts_only(kb: f64, kt: f64) -> Self {
        Self { kr: 0.0, kb, kt }
    }

    /// Whether a plan can weigh tasks by this model: every constant finite and `≥ 0`, and
    /// `kB` or `kT` positive (the counts, not the ray count alone, rank the tasks).
    pub fn can_plan(&self) -> bool {
        [self.kr, self.kb, self.kt]
            .iter()
            .all(|k| k.is_finite() && *k >= 0.0)
            && self.kb + self.kt > 0.0
    }

    /// `kR·R + kB·B + kT·T`.
    pub fn cost(&self, w: Work) -> f64 {
        self.kr * w.rays + self.kb * w.nodes + self.kt * w.tris
    }

    /// The cost of every task.
    pub fn costs(&self, work: &[Work]) -> Vec<f64> {
        work.iter().map(|&w| self.cost(w)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_weighs_counts() {
        let m = CostModel::counts_only(3.0, 0.5);
        assert_eq!(
            m.cost(Work {
                nodes: 2.0,
                tris: 4.0,
                rays: 1.0,
            }),
            8.0
        );
    }

    #[test]
    fn work_sums_exactly() {
        let counts = [Counts {
            nodes: u32::MAX,
            tris: 1,
        }; 3];
        let w = Work::sum(&counts);
        assert_eq!(w.nodes, 3.0 * f64::from(u32::MAX));
        assert_eq!(w.tris, 3.0);
    }
}
