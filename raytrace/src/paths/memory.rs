//! What a path renderer keeps between runs: the speeds and `kB`, `kT` of a [`Calibration`]
//! plan its first frame ([`PathRenderer::recall`]), and what its frames measured goes back
//! into one ([`PathRenderer::remember`]), with what they measured of leaving devices idle
//! (see `choice.rs`).
//!
//! Speeds are relative to the fastest device of a run, so a run keeps each class's paths per
//! second as well, which compare across runs: a class measured alone is the fastest of its
//! run, and its relative speed of 1 planned against another class measured alone gave a GPU
//! and a CPU core equal shares. A first frame plans with the paths per second of its classes
//! where every class has one, and at equal speeds otherwise. A class's model costs the frames
//! only when that class estimates them (the fastest device's), and is fitted only on frames it
//! estimated, since work is counted differently by each kind of device. Within a run the
//! model stays the one the run started with, so that its frames are costed in one unit and
//! compare.

use super::Mode;
use crate::calibration::{Calibration, ChoiceKey, Entry, Key, device_set};

use super::PathRenderer;
use super::choice::SHADERS;

impl PathRenderer<'_> {
    /// Plans the next frame with what `calibration` holds for this renderer's device classes
    /// on `host` for `workload`: their speeds (from their paths per second, where every class
    /// has an entry that holds them), and the estimating class's `kB`, `kT`. Returns how many
    /// entries were used. Frames already rendered are not undone; call it first.
    pub fn recall(&mut self, calibration: &Calibration, host: &str, workload: &str) -> usize {
        let mut classes: Vec<String> = self.devices.iter().map(|d| d.class()).collect();
        classes.sort();
        classes.dedup();
        let wanted = classes.len();
        let entries: Vec<(String, Entry)> = classes
            .into_iter()
            .filter_map(|class| {
                let e = calibration.get(&Key::new(host, &class, workload))?;
                Some((class, *e))
            })
            .collect();
        let rates: Option<Vec<f64>> = entries.iter().map(|(_, e)| e.paths_per_second).collect();
        if let Some(rates) = rates.filter(|_| entries.len() == wanted) {
            let fastest = rates.iter().copied().fold(0.0, f64::max);
            for ((class, _), rate) in entries.iter().zip(rates) {
                self.speeds.insert(class.clone(), rate / fastest);
            }
        }
        for (class, e) in &entries {
            if let Some(m) = e.model() {
                self.models.insert(class.clone(), m);
            }
        }
        // What frames on these classes measured of leaving some idle; the renderer's own
        // measurements (a bench cell's devices kept from the cell before) are fresher.
        for mode in [Mode::Regular, Mode::Cost] {
            for shader in SHADERS {
                let key = self.choice_key(host, workload, mode, shader);
                if let Some(c) = calibration.choice(&key) {
                    self.choices
                        .entry((shader, mode))
                        .or_insert_with(|| c.clone());
                }
            }
        }
        entries.len()
    }

    /// Where the calibration keeps the choices of frames of `workload` in `mode` with
    /// `shader` on this renderer's device classes.
    fn choice_key(&self, host: &str, workload: &str, mode: Mode, shader: &str) -> ChoiceKey {
        let classes: Vec<String> = self.devices.iter().map(|d| d.class()).collect();
        ChoiceKey {
            host: host.to_owned(),
            devices: device_set(classes.iter().map(String::as_str)),
            workload: workload.to_owned(),
            mode: mode.name().to_owned(),
            shader: shader.to_owned(),
        }
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
            let mut entry = Entry {
                speed,
                paths_per_second: h
                    .paths_per_second()
                    .or(old.and_then(|e| e.paths_per_second)),
                samples: old.map_or(0, |e| e.samples) + h.samples,
                spikes: old.map_or(0, |e| e.spikes) + h.spikes,
                ..Entry::default()
            };
            entry.set_model(h.model().or(old.and_then(|e| e.model())));
            if calibration.insert(key, entry) {
                written += 1;
            }
        }
        if let Some(shader) = self.last_shader {
            for mode in [Mode::Regular, Mode::Cost] {
                let Some(choice) = self.choices.get(&(shader, mode)) else {
                    continue;
                };
                let key = self.choice_key(host, workload, mode, shader);
                if calibration.insert_choice(key, choice.clone()) {
                    written += 1;
                }
            }
        }
        written
    }
}

#[cfg(test)]
mod tests {
    use crate::calibration::{Calibration, Entry, Key};
    use crate::devices::parse_devices;
    use crate::paths::Settings;
    use crate::paths::{PathRenderer, build_path_devices};
    use crate::shade::{RenderOptions, Shader};
    use crate::{BuildPreset, Bvh, Camera, Scene, SceneSource};

    /// A small Whitted frame of the Cornell box.
    fn cornell() -> (Scene, Bvh, RenderOptions) {
        let shader = Shader::Whitted(Default::default());
        let scene = SceneSource::parse("builtin:cornell:0.2")
            .unwrap()
            .load(shader.needs())
            .unwrap();
        let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
        let options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 0), shader);
        (scene, bvh, options)
    }

    /// A renderer over two classes: two `cpu/1` devices and one `cpu/2`.
    fn renderer<'a>(scene: &'a Scene, bvh: &'a Bvh) -> PathRenderer<'a> {
        let specs = parse_devices("cpu:2,cpu:1/2").unwrap();
        let devices = build_path_devices(scene, bvh, &specs, &[], &[]).unwrap();
        // Without backups: a device whose every task a copy delivered first learns no speed.
        let settings = Settings {
            backups: false,
            ..Settings::default()
        };
        PathRenderer::new(devices, settings).unwrap()
    }

    #[test]
    fn what_one_renderer_remembers_plans_the_next_ones_first_frame() {
        let (scene, bvh, options) = cornell();
        let mut first = renderer(&scene, &bvh);
        let mut calibration = Calibration::new();
        assert_eq!(first.recall(&calibration, "h", "w"), 0);
        // The first frame, on every device, measures both classes; the second runs on the
        // fastest alone (see `choice.rs`).
        for _ in 0..2 {
            first.render(&scene, &bvh, &options).unwrap();
        }
        // Two classes, `cpu/1` and `cpu/2`, each measured, and the frames' choice of devices.
        assert_eq!(first.remember(&mut calibration, "h", "w"), 3);
        let stored = calibration.get(&Key::new("h", "cpu/2", "w")).unwrap();
        assert!(stored.samples >= 1, "{stored:?}");

        let mut second = renderer(&scene, &bvh);
        assert_eq!(second.recall(&calibration, "h", "other workload"), 0);
        assert_eq!(second.speed(2), 1.0);
        assert_eq!(second.recall(&calibration, "h", "w"), 2);
        let rate = |class| {
            let e = calibration.get(&Key::new("h", class, "w")).unwrap();
            e.paths_per_second.unwrap()
        };
        let (one, two) = (rate("cpu/1"), rate("cpu/2"));
        let fastest = one.max(two);
        let planned = [one / fastest, one / fastest, two / fastest];
        for (d, &speed) in planned.iter().enumerate() {
            assert_eq!(second.speed(d), speed, "device {d}");
        }
        // The first frame may leave the slower class idle (see `choice.rs`); the devices it
        // runs on plan with the recalled speeds.
        let frame = second.render(&scene, &bvh, &options).unwrap();
        for d in &frame.stats.devices {
            assert_eq!(d.speed, planned[d.index], "{}", d.name);
        }
    }

    /// What frames measured of running on every device or on the fastest class alone is kept
    /// per device set, workload and mode, and a later renderer over the same classes starts
    /// from it.
    #[test]
    fn the_choice_of_devices_is_remembered() {
        let (scene, bvh, options) = cornell();
        let mut first = renderer(&scene, &bvh);
        // Every device at equal speeds (not weighed), the fastest class alone, then every
        // device as planned.
        for _ in 0..3 {
            first.render(&scene, &bvh, &options).unwrap();
        }
        let key = ("whitted", Settings::default().mode);
        let measured = first.choices[&key].clone();
        assert!(
            measured.all.is_some() && measured.alone.is_some(),
            "{measured:?}"
        );
        let mut calibration = Calibration::new();
        // Two classes' entries and one choice.
        assert_eq!(first.remember(&mut calibration, "h", "w"), 3);

        let mut second = renderer(&scene, &bvh);
        second.recall(&calibration, "h", "w");
        assert_eq!(second.choices[&key], measured);
        let mut other = renderer(&scene, &bvh);
        other.recall(&calibration, "h", "another workload");
        assert!(other.choices.is_empty());
    }

    /// Each class measured alone is the fastest of its run (speed 1); planned together, they
    /// take their speeds from their paths per second, and from nothing where a class has none.
    #[test]
    fn classes_measured_in_separate_runs_plan_by_their_paths_per_second() {
        let (scene, bvh, _) = cornell();
        let entry = |paths_per_second| Entry {
            speed: 1.0,
            paths_per_second,
            samples: 4,
            ..Entry::default()
        };
        let mut calibration = Calibration::new();
        calibration.insert(Key::new("h", "cpu/1", "w"), entry(Some(1000.0)));
        calibration.insert(Key::new("h", "cpu/2", "w"), entry(Some(4000.0)));
        let mut r = renderer(&scene, &bvh);
        assert_eq!(r.recall(&calibration, "h", "w"), 2);
        assert_eq!([r.speed(0), r.speed(1), r.speed(2)], [0.25, 0.25, 1.0]);

        // An older entry without paths per second: its relative speed of 1 would plan a
        // class against one it never ran beside, so both start at equal speeds.
        calibration.insert(Key::new("h", "cpu/2", "w"), entry(None));
        let mut r = renderer(&scene, &bvh);
        assert_eq!(r.recall(&calibration, "h", "w"), 2);
        assert_eq!([r.speed(0), r.speed(1), r.speed(2)], [1.0; 3]);
    }
}
