//! What a path renderer keeps between runs: the speeds and `kB`, `kT` of a [`Calibration`]
//! plan its first frame ([`PathRenderer::recall`]), and what its frames measured goes back
//! into one ([`PathRenderer::remember`]).
//!
//! Speeds are relative, so one recalled for a class plans against the others as it did in
//! the run that measured it. A class's model costs the frames only when that class estimates
//! them (the first device's), and is fitted only on frames it estimated, since work is
//! counted differently by each kind of device. Within a run the model stays the one the run
//! started with, so that its frames are costed in one unit and compare.

use crate::calibration::{Calibration, Entry, Key};
use crate::cost::{CostModel, Work, calibrate};

use super::PathRenderer;
use super::learn::Learnt;

/// Fewer launches than this fit no model worth planning with: with two unknowns, a handful
/// of points is fitted exactly, noise included.
const MIN_FIT_LAUNCHES: usize = 8;

/// What one device class's launches taught over a run.
#[derive(Clone, Debug, Default)]
pub(crate) struct History {
    /// Work and seconds of the launches kept, from frames this class estimated.
    fit: Vec<(Work, f64)>,
    /// Launches learnt from.
    samples: u64,
    /// Launches left out as timing spikes.
    spikes: u64,
}

impl History {
    /// Adds a frame's lesson; its launches join the fit when `fitted` (the class estimated
    /// the frame).
    pub(crate) fn add(&mut self, learnt: &Learnt, fitted: bool) {
        self.samples += learnt.kept.len() as u64;
        self.spikes += learnt.spikes as u64;
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

    /// `kB`, `kT` in seconds, if enough launches were kept and the fit can plan.
    fn model(&self) -> Option<CostModel> {
        if self.fit.len() < MIN_FIT_LAUNCHES {
            return None;
        }
        let (work, seconds): (Vec<Work>, Vec<f64>) = self.fit.iter().copied().unzip();
        let m = calibrate(&work, &seconds).ok()?.model;
        m.can_plan().then_some(m)
    }
}

impl PathRenderer<'_> {
    /// Plans the next frame with what `calibration` holds for this renderer's device classes
    /// on `host` for `workload`: their speeds, and the estimating class's `kB`, `kT`. Returns
    /// how many entries were used. Frames already rendered are not undone; call it first.
    pub fn recall(&mut self, calibration: &Calibration, host: &str, workload: &str) -> usize {
        let mut classes: Vec<String> = self.devices.iter().map(|d| d.class()).collect();
        classes.sort();
        classes.dedup();
        let mut used = 0;
        for class in classes {
            if let Some(e) = calibration.get(&Key::new(host, &class, workload)) {
                self.speeds.insert(class.clone(), e.speed);
                if let Some(m) = e.model {
                    self.models.insert(class, m);
                }
                used += 1;
            }
        }
        used
    }

    /// Records in `calibration`, for `host` and `workload`, each device class's speed as the
    /// next frame would plan it and the `kB`, `kT` its launches fit (an earlier entry's where
    /// this run fitted none), with the launches learnt from and left out added to the
    /// entry's counts. A class this run measured nothing of is left as it was. Returns how
    /// many entries were written.
    pub fn remember(&self, calibration: &mut Calibration, host: &str, workload: &str) -> usize {
        let mut written = 0;
        for (class, h) in &self.history {
            if h.samples == 0 {
                continue;
            }
            let Some(&speed) = self.speeds.get(class) else {
                continue;
            };
            let key = Key::new(host, class, workload);
            let old = calibration.get(&key).copied();
            let entry = Entry {
                speed,
                model: h.model().or(old.and_then(|e| e.model)),
                samples: old.map_or(0, |e| e.samples) + h.samples,
                spikes: old.map_or(0, |e| e.spikes) + h.spikes,
            };
            if calibration.insert(key, entry) {
                written += 1;
            }
        }
        written
    }
}

#[cfg(test)]
mod tests {
    use crate::calibration::{Calibration, Key};
    use crate::devices::parse_devices;
    use crate::paths::{PathRenderer, build_path_devices};
    use crate::scheduled::Settings;
    use crate::shade::{RenderOptions, Shader};
    use crate::{BuildPreset, Bvh, Camera, SceneSource};

    #[test]
    fn what_one_renderer_remembers_plans_the_next_ones_first_frame() {
        let shader = Shader::Whitted(Default::default());
        let scene = SceneSource::parse("builtin:cornell:0.2")
            .unwrap()
            .load(shader.needs())
            .unwrap();
        let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
        let options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 0), shader);
        let specs = parse_devices("cpu:2,cpu:1/2").unwrap();
        let renderer = || {
            let devices = build_path_devices(&scene, &bvh, &specs, &[]).unwrap();
            PathRenderer::new(devices, Settings::default()).unwrap()
        };
        let mut first = renderer();
        let mut calibration = Calibration::new();
        assert_eq!(first.recall(&calibration, "h", "w"), 0);
        first.render(&scene, &bvh, &options).unwrap();
        // Two classes, `cpu/1` and `cpu/2`, each measured.
        assert_eq!(first.remember(&mut calibration, "h", "w"), 2);
        let stored = calibration.get(&Key::new("h", "cpu/2", "w")).unwrap();
        assert!(stored.samples >= 1, "{stored:?}");

        let mut second = renderer();
        assert_eq!(second.recall(&calibration, "h", "other workload"), 0);
        assert_eq!(second.speed(2), 1.0);
        assert_eq!(second.recall(&calibration, "h", "w"), 2);
        for d in 0..3 {
            assert_eq!(second.speed(d), first.speed(d), "device {d}");
        }
        let frame = second.render(&scene, &bvh, &options).unwrap();
        assert_eq!(frame.stats.devices[2].speed, first.speed(2));
    }
}
