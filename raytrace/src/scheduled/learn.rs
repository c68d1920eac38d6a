//! What a run teaches the next plan: each device's speed, and `kB`, `kT` per device and ray
//! kind, both from the measured timeline. A task whose time is far off its prediction (a
//! timing spike, see [`sched::outliers`]) teaches nothing: it is counted and left out of both.

use crate::RayKind;
use crate::cost::{Work, calibrate};

use super::DeviceFit;
use sched::outliers::{SPIKE_FACTOR, inliers};
use sched::{Costs, Timeline};

/// Which spans of `timeline` are learnt from: per device, those whose time is within
/// [`SPIKE_FACTOR`] of the device's median time per planned cost.
pub(crate) fn learnable(costs: &Costs, timeline: &Timeline) -> Vec<bool> {
    let devices = timeline.devices.max(
        timeline
            .spans
            .iter()
            .map(|s| s.device as usize + 1)
            .max()
            .unwrap_or(0),
    );
    let mut per: Vec<Vec<usize>> = vec![Vec::new(); devices];
    for (k, s) in timeline.spans.iter().enumerate() {
        per[s.device as usize].push(k);
    }
    let mut keep = vec![false; timeline.spans.len()];
    for spans in per {
        let predicted: Vec<f64> = spans
            .iter()
            .map(|&k| costs[timeline.spans[k].task as usize])
            .collect();
        let seconds: Vec<f64> = spans
            .iter()
            .map(|&k| (timeline.spans[k].end - timeline.spans[k].start).max(0.0))
            .collect();
        for (&k, ok) in spans
            .iter()
            .zip(inliers(&predicted, &seconds, SPIKE_FACTOR))
        {
            keep[k] = ok;
        }
    }
    keep
}

/// Relative speeds after a run: each device that did measurable work gets `work / busy` (in
/// the run's cost units, over the spans `keep` admits) of its class (`class[d]`: devices of one class are pooled, see
/// [`super::RayDevice::class`]), rescaled so that those devices keep the total speed they had
/// (`old`); a device that ran nothing keeps its old speed. Units cancel, so a generation
/// costed in node visits can inform one costed in seconds.
///
/// Returns the new speeds and, per device, the measurement if there was one.
pub(crate) fn measured_speeds(
    old: &[f64],
    class: &[usize],
    costs: &Costs,
    timeline: &Timeline,
    keep: &[bool],
) -> (Vec<f64>, Vec<Option<f64>>) {
    let classes = class.iter().max().map_or(0, |&c| c + 1);
    let (mut work, mut time) = (vec![0.0; classes], vec![0.0; classes]);
    let mut ran = vec![false; old.len()];
    for (s, _) in timeline.spans.iter().zip(keep).filter(|(_, k)| **k) {
        work[class[s.device as usize]] += costs[s.task as usize];
        time[class[s.device as usize]] += (s.end - s.start).max(0.0);
        ran[s.device as usize] = true;
    }
    let raw: Vec<Option<f64>> = (0..old.len())
        .map(|d| {
            let (w, b) = (work[class[d]], time[class[d]]);
            let s = w / b;
            (ran[d] && w > 0.0 && b > 0.0 && s.is_finite() && s > 0.0).then_some(s)
        })
        .collect();
    let (old_total, raw_total) = raw
        .iter()
        .zip(old)
        .filter_map(|(r, &o)| r.map(|r| (o, r)))
        .fold((0.0, 0.0), |(a, b), (o, r)| (a + o, b + r));
    if raw_total <= 0.0 {
        return (old.to_vec(), raw);
    }
    let scale = old_total / raw_total;
    let measured: Vec<Option<f64>> = raw.iter().map(|r| r.map(|r| r * scale)).collect();
    let speeds = measured
        .iter()
        .zip(old)
        .map(|(m, &o)| m.filter(|s| s.is_finite() && *s > 0.0).unwrap_or(o))
        .collect();
    (speeds, measured)
}

/// Least-squares `kB`, `kT` of every device that ran tasks, from their estimated work and
/// measured times (the spans `keep` admits). Fits that cannot plan (no positive weight, not
/// finite) are left out.
pub(crate) fn fit_devices(
    kind: RayKind,
    names: &[String],
    work: &[Work],
    timeline: &Timeline,
    keep: &[bool],
) -> Vec<DeviceFit> {
    let mut per_device: Vec<(Vec<Work>, Vec<f64>)> = vec![Default::default(); names.len()];
    for (s, _) in timeline.spans.iter().zip(keep).filter(|(_, k)| **k) {
        let (w, y) = &mut per_device[s.device as usize];
        w.push(work[s.task as usize]);
        y.push((s.end - s.start).max(0.0));
    }
    names
        .iter()
        .zip(per_device)
        .filter_map(|(name, (w, y))| {
            let fit = calibrate(&w, &y).ok()?;
            fit.model.can_plan().then(|| DeviceFit {
                device: name.clone(),
                kind,
                fit,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sched::Span;

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
    fn speeds_are_work_over_busy_keeping_the_total() {
        let costs = Costs::new(vec![4.0, 4.0, 2.0]).unwrap();
        let t = Timeline {
            devices: 3,
            spans: vec![
                span(0, 0, 0.0, 2.0),
                span(1, 1, 0.0, 1.0),
                span(1, 2, 1.0, 1.5),
            ],
        };
        // Device 0: 4 units in 2 s; device 1: 6 units in 1.5 s; device 2 ran nothing.
        let all = vec![true; t.spans.len()];
        let (speeds, measured) = measured_speeds(&[1.0, 1.0, 1.0], &[0, 1, 2], &costs, &t, &all);
        assert_eq!(measured[2], None);
        assert!((speeds[0] - 2.0 / 3.0).abs() < 1e-12, "{speeds:?}");
        assert!((speeds[1] - 4.0 / 3.0).abs() < 1e-12, "{speeds:?}");
        assert_eq!(speeds[2], 1.0);
        // Nothing measurable: speeds unchanged.
        let (same, _) = measured_speeds(&[1.0, 3.0], &[0, 1], &costs, &Timeline::default(), &[]);
        assert_eq!(same, vec![1.0, 3.0]);
        // Devices 0 and 1 of one class share their measurement: 10 units in 3.5 s.
        let (pooled, _) = measured_speeds(&[1.0, 1.0, 1.0], &[0, 0, 1], &costs, &t, &all);
        assert_eq!(pooled[0], pooled[1]);
        assert_eq!(pooled[2], 1.0);
    }

    /// A task a hundred times slower than its prediction is left out of the speeds, so the
    /// next plan is the one the run without the spike would have made; learnt from, it
    /// would have moved work off the device it hit.
    #[test]
    fn a_timing_spike_leaves_the_next_plan_unchanged() {
        let mut rng = sched::Rng::new(11);
        let costs: Vec<f64> = (0..48).map(|_| 1.0 + 9.0 * rng.f64()).collect();
        let costs = Costs::new(costs).unwrap();
        // Two devices, the second twice as fast, each task's time its cost over the speed
        // with ±5 % noise; tasks alternate between them.
        let timeline = |spike: Option<usize>| {
            let mut clock = [0.0f64; 2];
            let mut spans = Vec::new();
            for t in 0..costs.len() {
                let d = t % 2;
                let noise = 1.0 + 0.05 * (t as f64 * 2.399).sin();
                let mut secs = costs[t] / [1.0, 2.0][d] * noise;
                if spike == Some(t) {
                    secs *= 100.0;
                }
                spans.push(span(d as u32, t as u32, clock[d], clock[d] + secs));
                clock[d] += secs;
            }
            Timeline { devices: 2, spans }
        };
        let next = Costs::new((1..=40).map(f64::from).collect()).unwrap();
        let plan = |t: &Timeline, keep: &[bool]| {
            let (speeds, _) = measured_speeds(&[1.0, 1.0], &[0, 1], &costs, t, keep);
            sched::plan_lpt(&next, &sched::Speeds::new(speeds).unwrap())
        };
        let clean = timeline(None);
        let clean_plan = plan(&clean, &learnable(&costs, &clean));
        for spiked_task in [0, 7, 30] {
            let spiked = timeline(Some(spiked_task));
            let keep = learnable(&costs, &spiked);
            assert_eq!(
                keep.iter().filter(|k| !**k).count(),
                1,
                "only the spike is left out"
            );
            assert!(!keep[spiked_task]);
            assert_eq!(
                plan(&spiked, &keep),
                clean_plan,
                "spike on task {spiked_task}"
            );
            // Learnt from, the spike would have changed the plan.
            assert_ne!(plan(&spiked, &vec![true; keep.len()]), clean_plan);
        }
    }
}
