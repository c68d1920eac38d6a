//! What a frame teaches the next plan: each device class's speed, from the launches the host
//! timed. A launch whose time is far off what its planned cost predicts (a timing spike, see
//! [`sched::outliers`]) teaches nothing: it is counted and left out of the speeds and of the
//! `kB`, `kT` fit that the calibration file keeps.
//!
//! The launch is the unit, not the task: the tasks of one launch are delivered together, so
//! their spans split the launch's time arbitrarily (the first holds it all). The launches of
//! one class are pooled (they are the same hardware), and each is judged against their
//! median time per cost; a class with fewer than three launches in a frame has no median to
//! trust, and is learnt from whole.
//!
//! What one class's launches taught over a run ([`History`]), the work and time of the launches
//! kept, gives its paths per second and its fitted `kB`, `kT`: the renderer keeps one per
//! class, and `memory.rs` carries them into a calibration.

use sched::Timeline;
use sched::outliers::{SPIKE_FACTOR, inliers};

use crate::cost::{CostModel, Work, calibrate};

/// One launch of a frame, as the host timed it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LaunchSample {
    /// The device that ran it (index into the frame's devices).
    pub device: usize,
    /// The planned cost of its tasks.
    pub cost: f64,
    /// The estimated work of its tasks (zero when the frame was not estimated).
    pub work: Work,
    /// Wall seconds from its start to its last task's delivery.
    pub seconds: f64,
    /// Paths of its tasks.
    pub paths: f64,
}

/// The launches of `timeline`: each device's spans, in order, cut where `opens[task]` says a
/// task's output opened a launch. `costs`, `work` and `paths` are per task; `work` may be
/// empty.
pub(crate) fn launches(
    timeline: &Timeline,
    costs: &[f64],
    work: &[Work],
    paths: &[usize],
    opens: &[bool],
) -> Vec<LaunchSample> {
    let mut samples: Vec<LaunchSample> = Vec::new();
    // Per device, the index in `samples` of its launch being read.
    let mut open: Vec<Option<usize>> = vec![None; timeline.devices];
    for s in &timeline.spans {
        let (d, t) = (s.device as usize, s.task as usize);
        if d >= open.len() {
            open.resize(d + 1, None);
        }
        let at = match open[d] {
            Some(at) if !opens.get(t).copied().unwrap_or(false) => at,
            _ => {
                samples.push(LaunchSample {
                    device: d,
                    ..Default::default()
                });
                open[d] = Some(samples.len() - 1);
                samples.len() - 1
            }
        };
        let l = &mut samples[at];
        l.cost += costs.get(t).copied().unwrap_or(0.0);
        l.paths += paths.get(t).copied().unwrap_or(0) as f64;
        if let Some(w) = work.get(t) {
            l.work.nodes += w.nodes;
            l.work.tris += w.tris;
        }
        l.seconds += (s.end - s.start).max(0.0);
    }
    samples
}

/// What one class's launches of a frame teach.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Learnt {
    /// Planned cost of the launches kept.
    pub cost: f64,
    /// Their seconds.
    pub seconds: f64,
    /// Their paths.
    pub paths: f64,
    /// The launches kept, for a fit of `kB`, `kT`.
    pub kept: Vec<LaunchSample>,
    /// Launches left out as timing spikes.
    pub spikes: usize,
}

impl Learnt {
    /// Cost per second over the launches kept, if there is a usable one.
    pub fn rate(&self) -> Option<f64> {
        let r = self.cost / self.seconds;
        (self.cost > 0.0 && self.seconds > 0.0 && r.is_finite() && r > 0.0).then_some(r)
    }
}

/// `samples` pooled by class (`class[device]`, `classes` of them), each launch judged against
/// its class's median seconds per cost.
pub(crate) fn learn(samples: &[LaunchSample], class: &[usize], classes: usize) -> Vec<Learnt> {
    let mut learnt = vec![Learnt::default(); classes];
    for (c, l) in learnt.iter_mut().enumerate() {
        let mine: Vec<&LaunchSample> = samples
            .iter()
            .filter(|s| class.get(s.device) == Some(&c))
            .collect();
        let cost: Vec<f64> = mine.iter().map(|s| s.cost).collect();
        let seconds: Vec<f64> = mine.iter().map(|s| s.seconds).collect();
        for (s, keep) in mine.iter().zip(inliers(&cost, &seconds, SPIKE_FACTOR)) {
            if keep {
                l.cost += s.cost;
                l.seconds += s.seconds;
                l.paths += s.paths;
                l.kept.push(**s);
            } else {
                l.spikes += 1;
            }
        }
    }
    learnt
}

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

/// Each class's speed relative to the fastest one measured (`None` where a class measured
/// nothing usable).
pub(crate) fn relative_speeds(learnt: &[Learnt]) -> Vec<Option<f64>> {
    let rates: Vec<Option<f64>> = learnt.iter().map(Learnt::rate).collect();
    let Some(fastest) = rates.iter().flatten().copied().reduce(f64::max) else {
        return rates;
    };
    rates.iter().map(|r| r.map(|r| r / fastest)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sched::{Costs, Span};

    fn span(device: u32, task: u32, start: f64, end: f64) -> Span {
        Span {
            device,
            task,
            start,
            end,
            device_seconds: None,
        }
    }

    #[test]
    fn launches_are_cut_where_a_task_opens_one() {
        // Device 0: one launch of tasks 0..3 (the first span holds the launch's time);
        // device 1: two launches, of task 3 and of task 4.
        let t = Timeline {
            devices: 2,
            spans: vec![
                span(0, 0, 0.0, 3.0),
                span(1, 3, 0.0, 1.0),
                span(0, 1, 3.0, 3.0),
                span(1, 4, 1.0, 3.0),
                span(0, 2, 3.0, 3.0),
            ],
        };
        let opens = [true, false, false, true, true];
        let work = vec![
            Work {
                nodes: 1.0,
                tris: 2.0,
                rays: 0.0,
            };
            5
        ];
        let l = launches(&t, &[1.0, 2.0, 3.0, 4.0, 5.0], &work, &[10; 5], &opens);
        assert_eq!(l.len(), 3);
        assert_eq!((l[0].device, l[0].cost, l[0].seconds), (0, 6.0, 3.0));
        assert_eq!((l[0].paths, l[1].paths), (30.0, 10.0));
        assert_eq!(l[0].work.nodes, 3.0);
        assert_eq!((l[1].device, l[1].cost, l[1].seconds), (1, 4.0, 1.0));
        assert_eq!((l[2].device, l[2].cost, l[2].seconds), (1, 5.0, 2.0));
    }

    /// Two classes of three devices (a fast and a slow one), ten launches each (a queue's
    /// frame), with `noise` (a fraction) on their times; `spike` makes one launch a hundred
    /// times slower. Costs are whole and speeds powers of two, so without noise every rate
    /// is exact and two plans compare exactly.
    fn frame(noise: f64, spike: Option<usize>) -> Vec<LaunchSample> {
        let mut rng = sched::Rng::new(5);
        (0..60)
            .map(|k| {
                let device = k % 6;
                let cost = (1.0 + 9.0 * rng.f64()).floor();
                let speed = if device < 3 { 4.0 } else { 1.0 };
                let mut seconds = cost / speed * (1.0 + noise * (k as f64 * 2.399).sin());
                if spike == Some(k) {
                    seconds *= 100.0;
                }
                LaunchSample {
                    device,
                    cost,
                    work: Work {
                        nodes: cost,
                        tris: 0.0,
                        rays: 0.0,
                    },
                    seconds,
                    paths: cost,
                }
            })
            .collect()
    }

    /// A launch a hundred times slower than its prediction is left out of the speeds, so the
    /// next plan is the one the frame without the spike would have made; learnt from, it
    /// would have moved work off the class it hit.
    #[test]
    fn a_timing_spike_leaves_the_next_plan_unchanged() {
        let class = [0, 0, 0, 1, 1, 1];
        let next = Costs::new((1..=60).map(f64::from).collect()).unwrap();
        let plan = |learnt: &[Learnt]| {
            let by_class = relative_speeds(learnt);
            let speeds: Vec<f64> = class.iter().map(|&c| by_class[c].unwrap()).collect();
            sched::plan_lpt(&next, &sched::Speeds::new(speeds).unwrap())
        };
        let clean = learn(&frame(0.0, None), &class, 2);
        assert_eq!(clean.iter().map(|l| l.spikes).sum::<usize>(), 0);
        let clean_plan = plan(&clean);
        for spiked in [0, 4, 17, 59] {
            let learnt = learn(&frame(0.0, Some(spiked)), &class, 2);
            assert_eq!(
                learnt.iter().map(|l| l.spikes).sum::<usize>(),
                1,
                "only the spike is left out"
            );
            assert_eq!(plan(&learnt), clean_plan, "spike on launch {spiked}");
            // Learnt from, the spike would have changed the plan.
            let all = frame(0.0, Some(spiked));
            let whole: Vec<Learnt> = (0..2)
                .map(|c| {
                    let mine = all.iter().filter(|s| class[s.device] == c);
                    mine.fold(Learnt::default(), |mut l, s| {
                        l.cost += s.cost;
                        l.seconds += s.seconds;
                        l
                    })
                })
                .collect();
            assert_ne!(plan(&whole), clean_plan);
            // With noise, the spike is still the only launch left out, and the speeds are
            // those of the noisy frame without it to within the noise.
            let noisy = relative_speeds(&learn(&frame(0.05, None), &class, 2));
            let learnt = learn(&frame(0.05, Some(spiked)), &class, 2);
            assert_eq!(learnt.iter().map(|l| l.spikes).sum::<usize>(), 1);
            for (a, b) in relative_speeds(&learnt).iter().zip(&noisy) {
                let (a, b) = (a.unwrap(), b.unwrap());
                assert!((a / b - 1.0).abs() < 0.02, "{a} against {b}");
            }
        }
    }
}
