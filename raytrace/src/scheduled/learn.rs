//! What a run teaches the next plan: each device's speed, and `kB`, `kT` per device and ray
//! kind, both from the measured timeline.

use crate::RayKind;
use crate::cost::{Work, calibrate};

use super::DeviceFit;
use sched::{Costs, Timeline};

/// Relative speeds after a run: each device that did measurable work gets `work / busy` (in
/// the run's cost units) of its class (`class[d]`: devices of one class are pooled, see
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
    busy: &[f64],
) -> (Vec<f64>, Vec<Option<f64>>) {
    let classes = class.iter().max().map_or(0, |&c| c + 1);
    let (mut work, mut time) = (vec![0.0; classes], vec![0.0; classes]);
    let mut ran = vec![false; old.len()];
    for s in &timeline.spans {
        work[class[s.device as usize]] += costs[s.task as usize];
        ran[s.device as usize] = true;
    }
    for (d, &b) in busy.iter().enumerate() {
        time[class[d]] += b;
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
/// measured times. Fits that cannot plan (no positive weight, not finite) are left out.
pub(crate) fn fit_devices(
    kind: RayKind,
    names: &[String],
    work: &[Work],
    timeline: &Timeline,
) -> Vec<DeviceFit> {
    let mut per_device: Vec<(Vec<Work>, Vec<f64>)> = vec![Default::default(); names.len()];
    for s in &timeline.spans {
        let (w, y) = &mut per_device[s.device as usize];
        w.push(work[s.task as usize]);
        y.push((s.end - s.start).max(0.0));
    }
    names
        .iter()
        .zip(per_device)
        .filter_map(|(name, (w, y))| {
            let fit = calibrate(&w, &y).ok()?;
            let (kb, kt) = (fit.model.kb, fit.model.kt);
            let usable = kb.is_finite() && kt.is_finite() && kb >= 0.0 && kt >= 0.0;
            (usable && kb + kt > 0.0).then(|| DeviceFit {
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
        let (speeds, measured) =
            measured_speeds(&[1.0, 1.0, 1.0], &[0, 1, 2], &costs, &t, &[2.0, 1.5, 0.0]);
        assert_eq!(measured[2], None);
        assert!((speeds[0] - 2.0 / 3.0).abs() < 1e-12, "{speeds:?}");
        assert!((speeds[1] - 4.0 / 3.0).abs() < 1e-12, "{speeds:?}");
        assert_eq!(speeds[2], 1.0);
        // Nothing measurable: speeds unchanged.
        let (same, _) = measured_speeds(
            &[1.0, 3.0],
            &[0, 1],
            &costs,
            &Timeline::default(),
            &[0.0, 0.0],
        );
        assert_eq!(same, vec![1.0, 3.0]);
        // Devices 0 and 1 of one class share their measurement: 10 units in 3.5 s.
        let (pooled, _) =
            measured_speeds(&[1.0, 1.0, 1.0], &[0, 0, 1], &costs, &t, &[2.0, 1.5, 0.0]);
        assert_eq!(pooled[0], pooled[1]);
        assert_eq!(pooled[2], 1.0);
    }
}
