//! The device speeds a tracer plans with: one blend over every generation measured, and one
//! per ray kind.
//!
//! A device's speed relative to another depends on the rays: a GPU's any-hit kernel is cheap
//! against its closest-hit one, while the host's side of a launch costs the same, so a CPU
//! and a GPU that trace primary rays at about one speed can trace shadow rays at 1 : 5. One
//! blend for all kinds would plan every AO and shadow generation with the primary rays'
//! ratio. So a kind measured before plans with its own speeds; a kind not seen yet falls back
//! to the blend.

use std::collections::BTreeMap;

use crate::RayKind;

/// Speeds and the busy seconds behind them: each measurement is blended in by its own busy
/// time, so a small, noisy generation cannot swing the plan of a large one.
#[derive(Clone, Debug)]
struct Blend {
    speeds: Vec<f64>,
    evidence: f64,
}

impl Blend {
    /// Blends `new` (speeds of the devices `active`, in order) measured over `weight` busy
    /// seconds.
    fn add(&mut self, active: &[usize], new: &[f64], weight: f64) {
        let prior = self.evidence;
        for (&d, &n) in active.iter().zip(new) {
            let old = self.speeds[d];
            self.speeds[d] = if prior == 0.0 {
                n
            } else {
                (prior * old + weight * n) / (prior + weight)
            };
        }
        self.evidence = prior + weight;
    }
}

/// See the module documentation.
#[derive(Clone, Debug)]
pub(crate) struct SpeedBook {
    all: Blend,
    by_kind: BTreeMap<RayKind, Blend>,
}

impl SpeedBook {
    /// `devices` devices, all of speed 1.
    pub(crate) fn new(devices: usize) -> Self {
        Self {
            all: Blend {
                speeds: vec![1.0; devices],
                evidence: 0.0,
            },
            by_kind: BTreeMap::new(),
        }
    }

    /// The blend over every kind measured so far.
    pub(crate) fn all(&self) -> &[f64] {
        &self.all.speeds
    }

    /// The speeds a generation of `kind` is planned with: its kind's, once measured, else the
    /// blend over every kind.
    pub(crate) fn for_kind(&self, kind: RayKind) -> &[f64] {
        self.by_kind
            .get(&kind)
            .map_or(self.all(), |b| b.speeds.as_slice())
    }

    /// Learns `new` (speeds of the devices `active`, from a generation of `kind` that kept
    /// them busy `weight` seconds in all). Nothing is learnt from no time.
    pub(crate) fn learn(&mut self, kind: RayKind, active: &[usize], new: &[f64], weight: f64) {
        if !(weight > 0.0 && weight.is_finite()) {
            return;
        }
        let all = &self.all;
        self.by_kind
            .entry(kind)
            .or_insert_with(|| Blend {
                speeds: all.speeds.clone(),
                evidence: 0.0,
            })
            .add(active, new, weight);
        self.all.add(active, new, weight);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kind_plans_with_its_own_speeds_once_measured() {
        let mut book = SpeedBook::new(2);
        assert_eq!(book.for_kind(RayKind::Ao), [1.0, 1.0]);
        book.learn(RayKind::Primary, &[0, 1], &[1.2, 0.8], 1.0);
        // AO not seen yet: the blend, which is the primary rays' alone so far.
        assert_eq!(book.for_kind(RayKind::Ao), [1.2, 0.8]);
        book.learn(RayKind::Ao, &[0, 1], &[0.4, 1.6], 3.0);
        assert_eq!(book.for_kind(RayKind::Ao), [0.4, 1.6]);
        assert_eq!(book.for_kind(RayKind::Primary), [1.2, 0.8]);
        // The blend weighs each generation by its busy seconds: (1·1.2 + 3·0.4) / 4.
        assert!((book.all()[0] - 0.6).abs() < 1e-12, "{:?}", book.all());
        // A second AO generation blends into AO's own, by busy seconds.
        book.learn(RayKind::Ao, &[1], &[2.0], 1.0);
        assert!((book.for_kind(RayKind::Ao)[1] - 1.7).abs() < 1e-12);
        assert_eq!(book.for_kind(RayKind::Ao)[0], 0.4);
        // Nothing is learnt from no time.
        let before = book.clone();
        book.learn(RayKind::Shadow, &[0, 1], &[9.0, 9.0], 0.0);
        assert_eq!(book.for_kind(RayKind::Shadow), before.all());
    }
}
