//! What one device class's launches taught a renderer over a run ([`History`]): the work and
//! time of the launches kept, for its paths per second and its fitted `kB`, `kT`. The
//! renderer keeps one per class; `memory.rs` carries them into a calibration.

use super::learn::Learnt;
use crate::cost::{CostModel, Work, calibrate};

/// Fewer launches than this fit no model worth planning with: with two unknowns, a handful
/// of points is fitted exactly, noise included.
const MIN_FIT_LAUNCHES: usize = 8;

/// What one device class's launches taught over a run.
#[derive(Clone, Debug, Default)]
pub(crate) struct History {
    /// Work and seconds of the launches kept, from frames this class estimated.
    fit: Vec<(Work, f64)>,
    /// Launches learnt from.
    pub(super) samples: u64,
    /// Launches left out as timing spikes.
    pub(super) spikes: u64,
    /// Paths and seconds of the launches kept.
    paths: f64,
    seconds: f64,
}

impl History {
    /// Adds a frame's lesson; its launches join the fit when `fitted` (the class estimated
    /// the frame).
    pub(crate) fn add(&mut self, learnt: &Learnt, fitted: bool) {
        self.samples += learnt.kept.len() as u64;
        self.spikes += learnt.spikes as u64;
        self.paths += learnt.paths;
        self.seconds += learnt.seconds;
        if fitted {
            self.fit.extend(
                learnt
                    .kept
                    .iter()
                    .filter(|l| l.work.nodes + l.work.tris > 0.0)
                    .map(|l| (l.work, l.seconds)),
            );
        }
    }

    /// Paths per second over the run's launches kept, if any were.
    pub(crate) fn paths_per_second(&self) -> Option<f64> {
        let r = self.paths / self.seconds;
        (r.is_finite() && r > 0.0).then_some(r)
    }

    /// `kB`, `kT` in seconds, if enough launches were kept and the fit can plan.
    pub(crate) fn model(&self) -> Option<CostModel> {
        if self.fit.len() < MIN_FIT_LAUNCHES {
            return None;
        }
        let (work, seconds): (Vec<Work>, Vec<f64>) = self.fit.iter().copied().unzip();
        let m = calibrate(&work, &seconds)?.model;
        m.can_plan().then_some(m)
    }
}
