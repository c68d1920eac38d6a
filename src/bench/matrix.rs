//! The thesis experiment on real devices: every (shader, task size, policy, mode) of one scene
//! rendered through the scheduled tracer, one record per run (DESIGN.md, "The thesis
//! experiment"). Whitted runs measure the coherent rays (all its generations), AO runs the
//! diffuse rays (the AO generation; its primary generation is not part of the record).

use std::num::NonZeroUsize;

use raytrace::cost::SampleRate;
use raytrace::scheduled::{GenerationStats, Mode, ScheduledTracer, Settings, build_devices};
use raytrace::shade::{AoSettings, RenderOptions, Shader, WhittedSettings, render};
use raytrace::{Bvh, Camera, RayKind, Scene};
use sched::Policy;
use serde::Serialize;

use super::probe::{ErrorSums, Probe};
use super::repeats;
use crate::error::CliError;

/// The two workloads of the thesis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Workload {
    /// Whitted shading: coherent rays.
    Whitted,
    /// 32-sample ambient occlusion: diffuse rays.
    Ao,
}

impl Workload {
    pub fn name(self) -> &'static str {
        match self {
            Self::Whitted => "whitted",
            Self::Ao => "ao",
        }
    }

    pub fn ray_kind(self) -> &'static str {
        match self {
            Self::Whitted => "coherent",
            Self::Ao => "diffuse",
        }
    }

    /// Whether a generation belongs to this workload's measured rays.
    fn counts(self, kind: RayKind) -> bool {
        match self {
            Self::Whitted => true,
            Self::Ao => kind == RayKind::Ao,
        }
    }
}

/// One run of the matrix: the fields `cobalt bench --json` promises, plus context.
#[derive(Clone, Debug, Serialize)]
pub struct Record {
    /// `measured` (here a run on real devices) or `simulated`.
    pub source: &'static str,
    pub scene: String,
    pub shader: &'static str,
    pub ray_kind: &'static str,
    pub policy: &'static str,
    pub mode: &'static str,
    /// Cost mode's probe of closest-hit rays (`thesis` or `first-leaf`).
    pub probe: &'static str,
    pub task_size: usize,
    pub devices: usize,
    pub device_list: String,
    pub cameras: usize,
    pub width: u32,
    pub height: u32,
    pub rays: usize,
    /// Wall time of the measured generations: estimation, planning and tracing.
    pub seconds: f64,
    /// Rendering efficiency (thesis): rays over `seconds`.
    pub mrays_per_s: f64,
    /// Σ device busy time / Σ (makespan × devices), over the measured generations.
    pub balance_efficiency: f64,
    pub estimate_seconds: f64,
    pub plan_seconds: f64,
    /// Σ|estimated − full| / Σ full (cost mode; the estimates do not depend on the policy).
    pub prediction_error: Option<f64>,
    /// Launches of the median run.
    pub launches: u64,
    /// Tasks re-run after a device failed, over all runs.
    pub reruns: u64,
    /// Runs of this cell (`--repeats`); the figures above are their medians.
    pub repeats: usize,
    /// Every run's MRays/s, in the order they ran.
    pub run_mrays_per_s: Vec<f64>,
    /// Every run's balance efficiency, in the order they ran.
    pub run_balance_efficiency: Vec<f64>,
}

/// Measured tasks of one generation, for the simulator: estimated cost and seconds of each.
#[derive(Clone, Debug, Default)]
pub struct Replay {
    pub rays: usize,
    pub estimate_seconds: f64,
    pub estimated: Vec<f64>,
    pub seconds: Vec<f64>,
}

/// The generations of a run's renders and, when probed, their prediction error sums.
type Rendered = (Vec<GenerationStats>, Vec<(RayKind, ErrorSums)>);

/// The cost-based StaticLpt run of one (workload, task size), kept for the simulator.
#[derive(Clone, Debug)]
pub struct Replays {
    pub workload: Workload,
    pub task_size: usize,
    pub prediction_error: Option<f64>,
    pub gens: Vec<Replay>,
}

/// What to run on one scene.
pub struct Plan<'a> {
    pub scene_name: &'a str,
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    pub devices: &'a [raytrace::devices::DeviceSpec],
    pub device_list: &'a str,
    pub workloads: &'a [Workload],
    pub task_sizes: &'a [usize],
    pub policies: &'a [Policy],
    pub cameras: usize,
    pub width: u32,
    pub height: u32,
    pub ao_samples: u32,
    pub sample_rate: SampleRate,
    /// Where cost mode's estimate runs.
    pub estimate_on: raytrace::scheduled::EstimateOn,
    /// Cost mode's probe of closest-hit rays.
    pub probe: raytrace::Probe,
    /// Runs of every cell, in rounds that each run every cell of the matrix once.
    pub repeats: usize,
}

impl Plan<'_> {
    /// Runs in the matrix, repeats included.
    pub fn runs(&self) -> usize {
        self.workloads.len()
            * self.task_sizes.len()
            * self.policies.len()
            * Mode::ALL.len()
            * self.repeats
    }

    fn shader(&self, w: Workload) -> Shader {
        match w {
            Workload::Whitted => Shader::Whitted(WhittedSettings::default()),
            Workload::Ao => Shader::Ao(AoSettings {
                samples: self.ao_samples,
                ..Default::default()
            }),
        }
    }

    /// Renders every camera once with `settings`, one after another through one tracer (as a
    /// renderer draws frames: each camera's plans use the device speeds measured so far, per
    /// ray kind); the generations traced and, when `probe`, the prediction error sums of each.
    fn render_all(
        &self,
        w: Workload,
        settings: Settings,
        probe: bool,
    ) -> Result<Rendered, CliError> {
        let bounds = self.scene.bounds();
        let devices = build_devices(self.bvh, self.devices, &[])?;
        let tracer = ScheduledTracer::new(self.bvh, devices, settings)?;
        let mut p = Probe::new(tracer, self.bvh, &settings, probe);
        let mut seen = 0;
        for cam in 0..self.cameras {
            let options = RenderOptions::new(
                self.width,
                self.height,
                Camera::thesis(&bounds, cam),
                self.shader(w),
            );
            render(self.scene, &mut p, &options);
            // A device that failed is retired for the rest of the run, which changes what the
            // run measures: say so, rather than leave a row of fewer devices unexplained.
            let gens = p.inner.stats();
            for f in gens[seen..].iter().flat_map(|g| &g.failures) {
                eprintln!(
                    "cobalt bench: {} {} {} {}, camera {cam}: {f}",
                    self.scene_name,
                    w.name(),
                    settings.policy.name(),
                    settings.mode.name(),
                );
            }
            seen = gens.len();
        }
        Ok((p.inner.stats().to_vec(), p.sums))
    }

    /// Runs the whole matrix, calling `tick` after each run; returns one record per cell (the
    /// medians of its repeats) and, per (workload, task size), the replay of the cost-based
    /// StaticLpt run of median time.
    pub fn run(&self, mut tick: impl FnMut(&str)) -> Result<(Vec<Record>, Vec<Replays>), CliError> {
        // Untimed warm-up: page in the scene, the BVH and the thread pools.
        if let Some(&w) = self.workloads.first() {
            self.render_all(w, Settings::default(), false)?;
        }
        // Every cell of the matrix: (workload, task size) blocks of policies and modes.
        let mut cells: Vec<(Workload, Settings)> = Vec::new();
        for &w in self.workloads {
            for &task_size in self.task_sizes {
                let size = NonZeroUsize::new(task_size).ok_or_else(|| CliError::Arg {
                    flag: "task-sizes",
                    value: task_size.to_string(),
                    message: "task sizes must be positive".into(),
                })?;
                for &policy in self.policies {
                    for mode in Mode::ALL {
                        let settings = Settings {
                            policy,
                            mode,
                            task_size: size,
                            sample_rate: self.sample_rate,
                            estimate_on: self.estimate_on,
                            probe: self.probe,
                        };
                        cells.push((w, settings));
                    }
                }
            }
        }
        let block = |(w, s): &(Workload, Settings)| (*w, s.task_size.get());
        let mut errors: Vec<((Workload, usize), f64)> = Vec::new();
        let mut runs: Vec<Vec<Record>> = vec![Vec::new(); cells.len()];
        let mut lpt_gens: Vec<Vec<Vec<Replay>>> = vec![Vec::new(); cells.len()];
        // Round after round of the whole matrix, so that a spell of load on the machine falls
        // on every cell alike instead of on all the runs of one cell or one task size.
        for _ in 0..self.repeats {
            for (cell, c) in cells.iter().enumerate() {
                let ((w, settings), key) = (*c, block(c));
                let known = errors.iter().any(|(k, _)| *k == key);
                let probe = settings.mode == Mode::Cost && !known;
                let (stats, sums) = self.render_all(w, settings, probe)?;
                if probe {
                    let (d, f) = sums
                        .iter()
                        .filter(|(k, _)| w.counts(*k))
                        .fold((0.0, 0.0), |(d, f), (_, s)| (d + s.diff, f + s.full));
                    errors.push((key, if f > 0.0 { d / f } else { 0.0 }));
                }
                let measured: Vec<&GenerationStats> =
                    stats.iter().filter(|g| w.counts(g.kind)).collect();
                if settings.mode == Mode::Cost && settings.policy == Policy::StaticLpt {
                    lpt_gens[cell].push(measured.iter().map(|g| replay(g)).collect());
                }
                runs[cell].push(self.record(w, settings, &measured));
                tick(&format!(
                    "{} {} {} {}",
                    w.name(),
                    settings.task_size,
                    settings.policy.name(),
                    settings.mode.name()
                ));
            }
        }
        let mut records = Vec::new();
        let mut replays = Vec::new();
        for (cell, c) in cells.iter().enumerate() {
            let (w, settings) = c;
            let Some(mut r) = repeats::combine(&runs[cell]) else {
                continue;
            };
            // The estimates, and so their error, depend on neither the policy nor the run.
            let error = errors.iter().find(|(k, _)| *k == block(c)).map(|&(_, e)| e);
            r.prediction_error = error.filter(|_| settings.mode == Mode::Cost);
            if let Some(mid) =
                repeats::median_run(&runs[cell]).filter(|_| !lpt_gens[cell].is_empty())
            {
                replays.push(Replays {
                    workload: *w,
                    task_size: settings.task_size.get(),
                    prediction_error: error,
                    gens: std::mem::take(&mut lpt_gens[cell][mid]),
                });
            }
            records.push(r);
        }
        Ok((records, replays))
    }

    fn record(&self, w: Workload, settings: Settings, gens: &[&GenerationStats]) -> Record {
        let (mut rays, mut seconds, mut est, mut plan) = (0usize, 0.0, 0.0, 0.0);
        let (mut busy, mut capacity, mut launches, mut reruns) = (0.0, 0.0, 0u64, 0u64);
        for g in gens {
            rays += g.rays;
            seconds += g.estimate_seconds + g.run_seconds;
            est += g.estimate_seconds;
            plan += g.plan_seconds;
            busy += g.devices.iter().map(|d| d.busy).sum::<f64>();
            capacity += g.makespan * g.devices.len() as f64;
            launches += g.launches();
            reruns += g.reruns;
        }
        let balance = if capacity > 0.0 { busy / capacity } else { 1.0 };
        Record {
            source: "measured",
            scene: self.scene_name.to_string(),
            shader: w.name(),
            ray_kind: w.ray_kind(),
            policy: settings.policy.name(),
            mode: settings.mode.name(),
            probe: settings.probe.name(),
            task_size: settings.task_size.get(),
            devices: gens.first().map_or(0, |g| g.devices.len()),
            device_list: self.device_list.to_string(),
            cameras: self.cameras,
            width: self.width,
            height: self.height,
            rays,
            seconds,
            mrays_per_s: rays as f64 / seconds.max(1e-12) / 1e6,
            balance_efficiency: balance,
            estimate_seconds: est,
            plan_seconds: plan,
            prediction_error: None,
            launches,
            reruns,
            repeats: 1,
            run_mrays_per_s: vec![rays as f64 / seconds.max(1e-12) / 1e6],
            run_balance_efficiency: vec![balance],
        }
    }
}

pub fn replay(g: &GenerationStats) -> Replay {
    Replay {
        rays: g.rays,
        estimate_seconds: g.estimate_seconds,
        estimated: g.task_stats.iter().map(|t| t.cost).collect(),
        seconds: g.task_stats.iter().map(|t| t.seconds).collect(),
    }
}
