//! The path renderer: a frame's paths cut into tasks, costed, planned by a [`sched::Policy`]
//! and run on path-resident devices by `sched`'s runtime; the devices' values make the film.

use std::collections::{HashMap, VecDeque};
use std::ops::Range;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use sched::{Costs, Runtime, SampleRate, SchedError, Speeds, split_ranges};

use super::choice::{ChoiceKey, choice_key};
use super::frame::FrameKey;
use super::learn::{History, Learnt, launches, learn, relative_speeds};
use super::{
    BoundPaths, Estimate, Frame, FrameStats, PathDevice, PathDeviceStats, TaskValues, Traffic,
    walk_paths,
};
use super::{Mode, Settings, TaskStats};
use crate::calibration::Choice;
use crate::cost::{CostModel, Work};
use crate::shade::RenderOptions;
use crate::{Bvh, Film, Scene, Walk};

/// Parts of a frame's estimate per estimating device whose launches are cheap: enough that a
/// device slowed for a while leaves parts to the others, few enough that each part's fixed
/// work stays small beside its sample.
const PARTS_PER_DEVICE: usize = 4;

/// Estimates a renderer keeps for frames that come again: enough for a bench's round of
/// shaders and task sizes (its repeats come round after round), few enough that looking one
/// up stays free beside a frame.
const ESTIMATES_KEPT: usize = 16;

/// The most of a frame's expected time one task may take on the slowest device rendering it,
/// where devices of several classes do: its last task then never holds the faster devices
/// for long, and they still launch many tasks at once.
const MAX_TASK_SHARE: f64 = 0.02;

/// What an estimate depends on: the frame, its tasks, the sampling and the kind of device
/// that counts the walks. A frame with the same key would be estimated to the same work.
#[derive(Clone, Debug, PartialEq)]
struct EstimateKey {
    frame: FrameKey,
    tasks: Vec<Range<usize>>,
    rate: SampleRate,
    walk: Walk,
    kind: &'static str,
}

/// A rendered frame: the image and how it was made.
#[derive(Clone, Debug)]
pub struct FrameRendering {
    /// The image (linear; encode with [`crate::film::ToneMap::Srgb`]).
    pub film: Film,
    /// The plan, the devices' shares and the traffic.
    pub stats: FrameStats,
}

/// Renders frames over path devices. Device speeds are measured on each frame, per device
/// class, and plan the next one, as a renderer drawing frames of one scene would; a
/// calibration from earlier runs ([`PathRenderer::recall`]) plans the first.
///
/// Each path is rendered whole by whichever device gets its task, so the image is the same
/// whatever the policy, mode, task size and devices.
pub struct PathRenderer<'a> {
    pub(super) devices: Vec<Box<dyn PathDevice + 'a>>,
    settings: Settings,
    /// Relative speed per device class, from the frames rendered so far (or recalled).
    pub(super) speeds: HashMap<String, f64>,
    /// `kB`, `kT` per device class, recalled: the estimating device's class costs the frames.
    pub(super) models: HashMap<String, CostModel>,
    /// What the frames taught, per device class, for the next run's calibration.
    pub(super) history: HashMap<String, History>,
    /// Paths per busy second of each device class and shader, on the latest frame that
    /// measured them (here or in the renderer the devices were kept from): what the next
    /// frame's prediction runs the devices at.
    rates: HashMap<(String, &'static str), f64>,
    pub(super) retired: Vec<bool>,
    /// Devices the frame being rendered leaves idle: the fastest class renders it alone.
    idle: Vec<bool>,
    /// Per shader and mode, the seconds per path of frames on every device and on the fastest
    /// class alone (see `choice.rs`).
    pub(super) choices: HashMap<ChoiceKey, Choice>,
    /// The shader of the latest frame rendered, whose choices a calibration keeps.
    pub(super) last_shader: Option<&'static str>,
    /// The latest estimates (at most [`ESTIMATES_KEPT`], the oldest used first out) and what
    /// each estimated: a frame of the same key takes its work.
    estimates: VecDeque<(EstimateKey, Vec<Work>)>,
    log: Vec<FrameStats>,
    /// [`PathRenderer::ranks`]' last image: its size and each pixel's path.
    ranks: Option<(u32, u32, Vec<u32>)>,
}

impl<'a> PathRenderer<'a> {
    /// A renderer over `devices`, all of speed 1 until the first frame is measured.
    ///
    /// # Errors
    /// [`SchedError::NoDevices`] for an empty list.
    pub fn new(
        devices: Vec<Box<dyn PathDevice + 'a>>,
        settings: Settings,
    ) -> Result<Self, SchedError> {
        if devices.is_empty() {
            return Err(SchedError::NoDevices);
        }
        let m = devices.len();
        // Before the first frame, which would otherwise wait for them.
        Runtime::start_threads(m);
        Ok(Self {
            devices,
            settings,
            speeds: HashMap::new(),
            models: HashMap::new(),
            history: HashMap::new(),
            rates: HashMap::new(),
            retired: vec![false; m],
            idle: vec![false; m],
            choices: HashMap::new(),
            last_shader: None,
            estimates: VecDeque::new(),
            log: Vec::new(),
            ranks: None,
        })
    }

    /// This renderer, for another over its devices ([`PathRenderer::from_kept`]); `None` if a
    /// device failed.
    pub fn into_kept(self) -> Option<Self> {
        (!self.retired.contains(&true)).then_some(self)
    }

    /// A renderer over `kept`'s devices, as [`PathRenderer::new`] but choosing which devices
    /// run a frame from what `kept` measured of running them together and apart.
    ///
    /// # Errors
    /// As [`PathRenderer::new`].
    pub fn from_kept(kept: Self, settings: Settings) -> Result<Self, SchedError> {
        let mut renderer = Self::new(kept.devices, settings)?;
        renderer.choices = kept.choices;
        renderer.rates = kept.rates;
        renderer.estimates = kept.estimates;
        Ok(renderer)
    }

    /// The settings.
    pub fn settings(&self) -> Settings {
        self.settings
    }

    /// Every frame rendered so far, in order.
    pub fn stats(&self) -> &[FrameStats] {
        &self.log
    }

    /// The relative speed the next frame plans device `d` with.
    pub fn speed(&self, d: usize) -> f64 {
        self.devices
            .get(d)
            .and_then(|dev| self.speeds.get(&dev.class()))
            .copied()
            .unwrap_or(1.0)
    }

    /// Renders one frame of `scene` (with its `bvh`) as `options` say.
    ///
    /// A device that fails is retired for this frame and the next, and its tasks are
    /// rendered by the others.
    ///
    /// Where the devices are of more than one class, a frame runs either on all of them or
    /// on the fastest class alone, whichever rendered this shader and mode faster per path
    /// on the latest frame of each (each is tried once first), so that adding a device
    /// never makes frames slower for long; `FrameStats::left_idle` names the devices left
    /// out.
    ///
    /// In cost mode, a frame of the same scene and tree (by address, size and bounds),
    /// options, tasks and sampling as one of the latest frames estimated takes that estimate's
    /// work at no cost (`FrameStats::estimate_reused`): the bench's repeats and an unchanged
    /// interactive view pay for one estimate. Geometry moved in place without a new tree of
    /// other bounds or size is not seen; its plans then use the old work (the image does not
    /// depend on the plan).
    ///
    /// # Errors
    /// [`SchedError::AllDevicesFailed`] (naming each failure) when no device is left to
    /// finish the frame, or [`SchedError::NoDevices`] when every device had failed before.
    pub fn render(
        &mut self,
        scene: &Scene,
        bvh: &Bvh,
        options: &RenderOptions,
    ) -> Result<FrameRendering, SchedError> {
        let start = Instant::now();
        let frame = Frame {
            scene,
            bvh,
            options,
        };
        let paths = frame.paths();
        let key = choice_key(&options.shader, self.settings.mode);
        self.last_shader = Some(key.0);
        let alone = self.choose(key);
        // A frame on every device planned before each class's speed was known (the first,
        // at equal speeds) says nothing of how such frames go once planned: its time is not
        // the figure the choice compares.
        let planned = alone == Some(true) || self.fastest_class().is_some();
        let active = (0..self.devices.len()).filter(|&d| self.runs(d)).count();
        let size = self.settings.task_size_for(paths, active.max(1));
        let size = (self.largest_task(paths, key.0)).map_or(size, |most| size.min(most));
        let tasks = split_ranges(paths, size);
        let mut ran = self.run_tasks(&frame, &tasks);
        self.idle.fill(false);
        // Every device of the fastest class failed: the devices it left idle render the frame.
        if let (Some(true), Err(SchedError::AllDevicesFailed { failures, .. })) = (alone, &ran)
            && self.retired.contains(&false)
        {
            let lost = failures.clone();
            ran = self.run_tasks(&frame, &tasks).map(|(outputs, mut stats)| {
                stats.failures.splice(0..0, lost);
                (outputs, stats)
            });
        }
        for device in &mut self.devices {
            device.end_frame();
        }
        let (outputs, mut stats) = ran?;
        // `tasks` cut the paths in order into runs of `size`: path `r` is value `r % size` of
        // task `r / size` (each task's values are checked to be one per path).
        let ranks = self.ranks(options.width, options.height);
        let value = |r: u32| outputs[r as usize / size][r as usize % size];
        let pixels = ranks.par_iter().map(|&r| value(r)).collect();
        let film = Film::from_pixels(options.width, options.height, pixels);
        stats.seconds = start.elapsed().as_secs_f64();
        if let Some(alone) = alone.filter(|_| planned) {
            let per_path = stats.seconds / paths as f64;
            let fastest = self.fastest_class();
            let times = self.choices.entry(key).or_default();
            times.record(alone, per_path);
            times.fastest = fastest.or(times.fastest.take());
        }
        self.log.push(stats.clone());
        Ok(FrameRendering { film, stats })
    }

    /// The class of the highest speed measured or recalled among the devices not retired
    /// (the first of equals), if every one of their classes has a speed: a class no frame has
    /// measured is not taken for the fastest.
    fn fastest_class(&self) -> Option<String> {
        let live = (0..self.devices.len()).filter(|&d| !self.retired[d]);
        let mut best: Option<(String, f64)> = None;
        for d in live {
            let class = self.devices[d].class();
            let speed = *self.speeds.get(&class)?;
            if best.as_ref().is_none_or(|(_, s)| speed > *s) {
                best = Some((class, speed));
            }
        }
        best.map(|(class, _)| class)
    }

    /// The largest task, in paths, that the slowest device taking part renders within
    /// [`MAX_TASK_SHARE`] of the frame's expected time (its `paths` over the devices' summed
    /// paths per second), at least [`Settings::MIN_TASK_RAYS`]; `None` where the devices are
    /// of one class (the task size is the experiment's) or a class has no rate for `shader`
    /// yet.
    fn largest_task(&self, paths: usize, shader: &'static str) -> Option<usize> {
        let classes: Vec<String> = (0..self.devices.len())
            .filter(|&d| self.runs(d))
            .map(|d| self.devices[d].class())
            .collect();
        if classes.iter().all(|c| *c == classes[0]) {
            return None;
        }
        let rates: Vec<f64> = (classes.into_iter())
            .map(|c| self.rates.get(&(c, shader)).copied())
            .collect::<Option<_>>()?;
        let slowest = rates.iter().copied().fold(f64::INFINITY, f64::min);
        let most = MAX_TASK_SHARE * paths as f64 * slowest / rates.iter().sum::<f64>();
        Some((most.ceil() as usize).max(Settings::MIN_TASK_RAYS))
    }

    /// Whether device `d` takes part in the frame being rendered.
    fn runs(&self, d: usize) -> bool {
        !self.retired[d] && !self.idle[d]
    }

    /// The devices taking part in the frame being rendered, in order.
    fn running_mut(&mut self) -> Vec<&mut Box<dyn PathDevice + 'a>> {
        let (retired, idle) = (&self.retired, &self.idle);
        (self.devices.iter_mut().enumerate())
            .filter(|(d, _)| !retired[*d] && !idle[*d])
            .map(|(_, device)| device)
            .collect()
    }

    /// Decides whether the next frame of `key` runs on the fastest class alone (see
    /// `choice.rs`) and leaves the other devices idle if so; `None` when the devices left are
    /// of one class, and there is nothing to choose.
    fn choose(&mut self, key: ChoiceKey) -> Option<bool> {
        let live: Vec<usize> = (0..self.devices.len())
            .filter(|&d| !self.retired[d])
            .collect();
        let class: Vec<String> = self.devices.iter().map(|d| d.class()).collect();
        let first = live.first().map(|&d| &class[d])?;
        if live.iter().all(|&d| class[d] == *first) {
            return None;
        }
        let times = self.choices.get(&key).cloned().unwrap_or_default();
        // The class earlier frames found fastest (of this shader and mode, else of any), else
        // the fastest by the speeds known.
        let fastest = times
            .fastest
            .clone()
            .or_else(|| self.choices.values().find_map(|t| t.fastest.clone()))
            .filter(|f| live.iter().any(|&d| class[d] == *f))
            .or_else(|| self.fastest_class());
        let alone = times.alone_next(fastest.is_some());
        if let (true, Some(fastest)) = (alone, &fastest) {
            for &d in &live {
                self.idle[d] = class[d] != *fastest;
            }
        }
        Some(alone && fastest.is_some())
    }

    /// The path (rank in Morton order) of each pixel of a `width x height` image, kept for
    /// the frames that follow, so that a frame's host work is the gather alone.
    fn ranks(&mut self, width: u32, height: u32) -> &[u32] {
        if self
            .ranks
            .as_ref()
            .is_none_or(|(w, h, _)| (*w, *h) != (width, height))
        {
            let order = crate::camera::morton_order(width, height);
            let mut ranks = vec![0; order.len()];
            for (rank, &p) in order.iter().enumerate() {
                ranks[p as usize] = rank as u32;
            }
            self.ranks = Some((width, height, ranks));
        }
        self.ranks.as_ref().map_or(&[], |(_, _, r)| r)
    }

    /// Renders the paths of `tasks` (ranges of `options`' paths in Morton order) as one
    /// frame would: costed, planned and run on the devices, which learn their speeds from it.
    /// Returns each task's values in path order, and the rays traced. A rank of an MPI job
    /// runs the tasks it is sent this way.
    ///
    /// # Errors
    /// As [`PathRenderer::render`].
    pub fn render_tasks(
        &mut self,
        scene: &Scene,
        bvh: &Bvh,
        options: &RenderOptions,
        tasks: &[Range<usize>],
    ) -> Result<(Vec<Vec<Vec3>>, usize), SchedError> {
        let frame = Frame {
            scene,
            bvh,
            options,
        };
        let (outputs, stats) = self.run_tasks(&frame, tasks)?;
        Ok((outputs, stats.rays))
    }

    /// Estimates, plans and runs `tasks` of `frame` on the devices left: each task's values,
    /// and the frame's statistics (their `seconds` from the start of the estimate).
    fn run_tasks(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[Range<usize>],
    ) -> Result<(Vec<Vec<Vec3>>, FrameStats), SchedError> {
        let start = Instant::now();
        let paths = frame.paths();
        let active: Vec<usize> = (0..self.devices.len()).filter(|&d| self.runs(d)).collect();
        if active.is_empty() {
            return Err(SchedError::NoDevices);
        }

        let speeds: Vec<f64> = active.iter().map(|&d| self.speed(d)).collect();
        let estimating = Instant::now();
        // One device runs every task whatever their costs: its estimate would change nothing.
        let estimated = self.settings.mode == Mode::Cost && active.len() > 1;
        // The fastest device's kind estimates: no frame waits on a slow device's estimate.
        // Costs need one unit for all devices: the model of the class that estimates.
        let lead = fastest(&speeds);
        let model = self.cost_model(active[lead]);
        let mut reused = false;
        let (costs, work, estimate_traffic) = if estimated {
            let estimate_key = EstimateKey {
                frame: FrameKey::of(frame),
                tasks: tasks.to_vec(),
                rate: self.settings.rate_for(&frame.options.shader),
                walk: self.settings.walk,
                kind: self.devices[active[lead]].estimate_kind(),
            };
            let known = (self.estimates.iter()).position(|(key, _)| *key == estimate_key);
            reused = known.is_some();
            let (work, traffic) = match known.and_then(|k| self.estimates.remove(k)) {
                Some((_, work)) => (work, vec![Traffic::default(); active.len()]),
                None => self.estimate(frame, tasks, &active, &speeds, lead),
            };
            if self.estimates.len() == ESTIMATES_KEPT {
                self.estimates.pop_front();
            }
            self.estimates.push_back((estimate_key, work.clone()));
            // Counts are finite and non-negative, so only an empty frame could fail.
            let costs =
                Costs::new(model.costs(&work)).unwrap_or_else(|_| Costs::uniform(tasks.len()));
            (costs, work, traffic)
        } else {
            (
                Costs::uniform(tasks.len()),
                Vec::new(),
                vec![Traffic::default(); active.len()],
            )
        };
        let estimate_seconds = if estimated {
            estimating.elapsed().as_secs_f64()
        } else {
            0.0
        };

        let predicted_makespan = self.predict(frame, &active, tasks, &costs);
        let Settings {
            policy, backups, ..
        } = self.settings;
        let mut bound: Vec<BoundPaths<'_, 'a>> = (self.running_mut().into_iter().zip(&speeds))
            .map(|(device, &speed)| BoundPaths::new(device.as_mut(), frame, speed, backups))
            .collect();
        let running = Instant::now();
        let result = Runtime::new(policy)
            .backups(backups)
            .run(tasks, &costs, &mut bound);
        let run_seconds = running.elapsed().as_secs_f64();
        drop(bound);
        let report = match result {
            Ok(report) => report,
            Err(mut e) => {
                for &d in &active {
                    self.retired[d] = true;
                }
                // Failures name devices among the frame's; the renderer's index is kept.
                if let SchedError::AllDevicesFailed { failures, .. } = &mut e {
                    for f in failures {
                        f.device = active.get(f.device).copied().unwrap_or(f.device);
                    }
                }
                return Err(e);
            }
        };
        for f in &report.failures {
            self.retired[active[f.device]] = true;
        }

        let mut devices: Vec<PathDeviceStats> = active
            .iter()
            .zip(&speeds)
            .enumerate()
            .map(|(k, (&d, &speed))| PathDeviceStats {
                index: d,
                name: self.devices[d].name(),
                speed,
                tasks: 0,
                paths: 0,
                launches: report.launches.get(k).copied().unwrap_or(0),
                busy: report.metrics.busy.get(k).copied().unwrap_or(0.0),
                host_cpu: report.cpu_seconds.get(k).copied().flatten(),
                rays: 0,
                traffic: estimate_traffic[k],
                film_bytes: 0,
                device_seconds: None,
                launch_overhead: self.devices[d].launch_overhead(),
            })
            .collect();
        let undelivered = TaskStats {
            cost: 0.0,
            start: 0.0,
            seconds: 0.0,
            device: usize::MAX,
            device_seconds: None,
        };
        let mut task_stats = vec![undelivered; tasks.len()];
        for span in &report.timeline.spans {
            let (k, t) = (span.device as usize, span.task as usize);
            devices[k].tasks += 1;
            devices[k].paths += tasks[t].len();
            task_stats[t] = TaskStats {
                cost: costs.as_slice()[t],
                start: span.start,
                seconds: span.end - span.start,
                device: active[k],
                device_seconds: span.device_seconds,
            };
            if let Some(launch) = &report.outputs[t].launch {
                let d = &mut devices[k];
                d.rays += launch.rays;
                d.traffic += launch.traffic;
                d.film_bytes += launch.film_bytes;
                if let Some(s) = launch.device_seconds {
                    *d.device_seconds.get_or_insert(0.0) += s;
                }
            }
        }
        self.measure_rates(frame, &devices);
        let spikes = self.learn(&active, lead, &report, tasks, costs.as_slice(), &work);
        self.bound_unmeasured(frame, &devices, tasks, report.metrics.makespan);

        let stats = FrameStats {
            paths,
            tasks: tasks.len(),
            task_size: tasks.iter().map(|t| t.len()).max().unwrap_or(0),
            policy: self.settings.policy,
            mode: self.settings.mode,
            estimated,
            estimate_reused: reused,
            rays: devices.iter().map(|d| d.rays).sum(),
            estimate_seconds,
            plan_seconds: report.plan_seconds,
            run_seconds,
            seconds: start.elapsed().as_secs_f64(),
            makespan: report.metrics.makespan,
            predicted_makespan,
            balance_efficiency: report.metrics.balance_efficiency,
            task_stats,
            devices,
            reruns: report.reruns,
            backups: self.settings.backups,
            copies: report.copies,
            wasted_seconds: report.wasted,
            failures: report
                .failures
                .into_iter()
                .map(|f| sched::DeviceFailure {
                    device: active[f.device],
                    ..f
                })
                .collect(),
            cost_model: model,
            spikes,
            left_idle: (0..self.devices.len())
                .filter(|&d| self.idle[d])
                .map(|d| self.devices[d].name())
                .collect(),
        };
        let outputs = report.outputs.into_iter().map(|o| o.values).collect();
        Ok((outputs, stats))
    }

    /// Each task's estimated work, and what crossed to each of the `active` devices (planned
    /// at `speeds`) to estimate it. The devices of the estimate kind of `active[lead]` estimate
    /// the frame (counts of different kinds are not comparable), each where it renders. Where
    /// their launches are cheap (CPU devices), the tasks are cut into a few parts per device
    /// that each device takes in turn as it is free, so that a device slowed by the machine's
    /// other work leaves its parts to the others (a device too slow to end one part before
    /// the others end them all takes none); otherwise each is dealt its share at once,
    /// in proportion to its speed ([`shares`]). A part whose device cannot estimate it is
    /// estimated on the host.
    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[Range<usize>],
        active: &[usize],
        speeds: &[f64],
        lead: usize,
    ) -> (Vec<Work>, Vec<Traffic>) {
        let (rate, walk) = (
            self.settings.rate_for(&frame.options.shader),
            self.settings.walk,
        );
        // The reduced walks count the same on every device; the trace walk's counts are of
        // `lead`'s kind.
        let traced = matches!(walk, Walk::Trace { .. });
        let kind = self.devices[active[lead]].estimate_kind();
        let mut estimating: Vec<f64> = active
            .iter()
            .zip(speeds)
            .map(|(&d, &s)| {
                if !traced || self.devices[d].estimate_kind() == kind {
                    s
                } else {
                    0.0
                }
            })
            .collect();
        let estimators = (0..active.len()).filter(|&k| estimating[k] > 0.0);
        let taken = estimators
            .clone()
            .all(|k| self.devices[active[k]].cheap_launches());
        let parts: Vec<Vec<usize>> = if taken {
            // A device that would take longer over one part than all of them together over
            // the whole estimate does not take one: the frame would wait for it.
            let (total, count): (f64, usize) = (estimating.iter().sum(), estimators.count());
            for s in &mut estimating {
                if *s * ((PARTS_PER_DEVICE * count) as f64) < total {
                    *s = 0.0;
                }
            }
            let count = (0..active.len()).filter(|&k| estimating[k] > 0.0).count();
            let count = (PARTS_PER_DEVICE * count).clamp(1, tasks.len().max(1));
            let size = tasks.len().div_ceil(count).max(1);
            (split_ranges(tasks.len(), size).into_iter())
                .map(Iterator::collect)
                .collect()
        } else {
            shares(tasks.len(), &estimating)
        };
        let held: Vec<Vec<&Range<usize>>> = (parts.iter())
            .map(|part| part.iter().map(|&t| &tasks[t]).collect())
            .collect();
        let next = AtomicUsize::new(0);
        // Device `k`'s next part: the next one not taken, or its own share once.
        let take = |k: usize, first: bool| {
            if taken {
                Some(next.fetch_add(1, Ordering::Relaxed)).filter(|&p| p < parts.len())
            } else {
                first.then_some(k)
            }
        };
        let mine = self.running_mut();
        debug_assert_eq!(mine.len(), active.len());
        let mut done: Vec<Vec<(usize, Estimate)>> = vec![Vec::new(); mine.len()];
        // On the threads the run drives the devices on: new threads woken on a busy machine
        // can start only once another part is done, doubling the estimate's time.
        let jobs: Vec<Box<dyn FnOnce() + Send + '_>> = (mine.into_iter().enumerate())
            .zip(done.iter_mut())
            .filter(|((k, _), _)| estimating[*k] > 0.0)
            .map(|((k, device), out)| {
                let (held, take) = (&held, &take);
                Box::new(move || {
                    let mut first = true;
                    while let Some(p) = take(k, std::mem::take(&mut first)) {
                        if held[p].is_empty() {
                            continue;
                        }
                        // A panic or an error leaves the part to the host: see below.
                        let estimated = catch_unwind(AssertUnwindSafe(|| {
                            device.estimate(frame, &held[p], rate, walk)
                        }));
                        if let Ok(Ok(e)) = estimated {
                            out.push((p, e));
                        }
                    }
                }) as Box<dyn FnOnce() + Send + '_>
            })
            .collect();
        // Threads refused: every part is estimated on the host below.
        let _ = Runtime::on_device_threads(jobs);
        let mut by_part: Vec<Option<Vec<Work>>> = vec![None; parts.len()];
        let mut traffic = vec![Traffic::default(); active.len()];
        for (k, estimates) in done.into_iter().enumerate() {
            for (p, e) in estimates {
                traffic[k] += e.traffic;
                // A device that answered for other tasks than it was given is not believed.
                by_part[p] = Some(e.work).filter(|w| w.len() == parts[p].len());
            }
        }
        let mut work = vec![Work::default(); tasks.len()];
        for ((part, held), estimated) in parts.iter().zip(&held).zip(by_part) {
            let estimated = estimated.unwrap_or_else(|| walk_paths(frame, held, rate, walk));
            for (&t, w) in part.iter().zip(estimated) {
                work[t] = w;
            }
        }
        (work, traffic)
    }

    /// The makespan the frame's plan should take, known before it runs: the frame's paths
    /// shared among its tasks by their costs, each device running at its class's paths per
    /// busy second on an earlier frame of the shader, simulated under the frame's policy with
    /// the devices' declared launch overheads. `None` while a class has no rate.
    fn predict(
        &self,
        frame: &Frame<'_>,
        active: &[usize],
        tasks: &[Range<usize>],
        costs: &Costs,
    ) -> Option<f64> {
        let shader = frame.options.shader.name();
        let rates: Vec<f64> = active
            .iter()
            .map(|&d| self.rates.get(&(self.devices[d].class(), shader)).copied())
            .collect::<Option<_>>()?;
        let paths: Vec<f64> = tasks.iter().map(|t| t.len() as f64).collect();
        let (cost, all): (f64, f64) = (costs.as_slice().iter().sum(), paths.iter().sum());
        // Equal costs say only how many paths a task holds; estimates, how its work compares.
        let work: Vec<f64> = if self.settings.mode == Mode::Cost && cost > 0.0 {
            costs.as_slice().iter().map(|c| c / cost * all).collect()
        } else {
            paths
        };
        let overheads = active
            .iter()
            .map(|&d| self.devices[d].launch_overhead().unwrap_or(0.0))
            .collect();
        let simulation = sched::Simulation::new(self.settings.policy, Speeds::new(rates).ok()?)
            .backups(self.settings.backups)
            .device_latencies(overheads);
        let report = simulation.run(&Costs::new(work).ok()?).ok()?;
        Some(report.metrics.makespan)
    }

    /// Holds down the rate and speed of a class whose devices launched tasks but delivered
    /// none (a faster device's copies came first, or none was done by the frame's end): it
    /// rendered fewer paths than the frame's smallest task in the frame's makespan. Without
    /// this, a device too slow to finish a task before the others copy it would keep its old
    /// speed, and its share, frame after frame. The speed is scaled from the rate as the
    /// speed of the class that delivered most on this frame is; a class this bounds wrongly
    /// (a device that woke too late to take a task) is measured again on its next frame.
    fn bound_unmeasured(
        &mut self,
        frame: &Frame<'_>,
        devices: &[PathDeviceStats],
        tasks: &[Range<usize>],
        makespan: f64,
    ) {
        let smallest = tasks.iter().map(ExactSizeIterator::len).min().unwrap_or(0);
        let Some(best) = (devices.iter())
            .filter(|d| d.busy > 0.0)
            .max_by_key(|d| d.paths)
            .filter(|d| d.paths > 0 && smallest > 0 && makespan > 0.0)
        else {
            return;
        };
        let speed_per_rate = self.speed(best.index) * best.busy / best.paths as f64;
        let bound = smallest as f64 / makespan;
        let shader = frame.options.shader.name();
        let class = |d: &PathDeviceStats| self.devices[d.index].class();
        let delivered: Vec<String> = (devices.iter().filter(|d| d.paths > 0))
            .map(class)
            .collect();
        let silent: Vec<String> = (devices.iter())
            .filter(|d| d.launches > 0 && !self.retired[d.index])
            .map(class)
            .filter(|c| !delivered.contains(c))
            .collect();
        for c in silent {
            let rate = self.rates.entry((c.clone(), shader)).or_insert(bound);
            *rate = rate.min(bound);
            let speed = self.speeds.entry(c).or_insert(bound * speed_per_rate);
            *speed = speed.min(bound * speed_per_rate);
        }
    }

    /// Keeps each device class's paths per busy second on this frame, for predictions.
    fn measure_rates(&mut self, frame: &Frame<'_>, devices: &[PathDeviceStats]) {
        let mut by_class: HashMap<String, (f64, f64)> = HashMap::new();
        for d in devices.iter().filter(|d| !self.retired[d.index]) {
            let entry = by_class.entry(self.devices[d.index].class()).or_default();
            *entry = (entry.0 + d.paths as f64, entry.1 + d.busy);
        }
        let shader = frame.options.shader.name();
        for (class, (paths, busy)) in by_class {
            if paths > 0.0 && busy > 0.0 {
                self.rates.insert((class, shader), paths / busy);
            }
        }
    }

    /// The model the frames are costed with when device `d` estimates: its class's
    /// recalled one, else the default.
    fn cost_model(&self, d: usize) -> CostModel {
        self.devices
            .get(d)
            .and_then(|dev| self.models.get(&dev.class()))
            .copied()
            .unwrap_or_default()
    }

    /// Measures each device class's speed on this frame (planned cost per second of the
    /// launches that were not timing spikes, relative to the fastest class) for the next
    /// frame's plan, and keeps what the launches taught for [`PathRenderer::remember`]. A
    /// class that did no work keeps its speed. `active[k]` is the renderer's index of the
    /// run's device `k`, and `active[lead]` the one whose kind estimated; `tasks`, `costs` and
    /// `work` (empty when not estimated) are per task. Returns the spikes left out.
    fn learn(
        &mut self,
        active: &[usize],
        lead: usize,
        report: &sched::RunReport<TaskValues>,
        tasks: &[Range<usize>],
        costs: &[f64],
        work: &[Work],
    ) -> usize {
        let mut names: Vec<String> = Vec::new();
        let class: Vec<usize> = active
            .iter()
            .map(|&d| {
                let name = self.devices[d].class();
                match names.iter().position(|n| *n == name) {
                    Some(c) => c,
                    None => {
                        names.push(name);
                        names.len() - 1
                    }
                }
            })
            .collect();
        // A device retired during the frame measured its failure, not its speed.
        let paths: Vec<usize> = tasks.iter().map(ExactSizeIterator::len).collect();
        let opens: Vec<bool> = report.outputs.iter().map(|o| o.launch.is_some()).collect();
        let samples: Vec<_> = launches(&report.timeline, costs, work, &paths, &opens)
            .into_iter()
            .filter(|l| !self.retired[active[l.device]])
            .collect();
        let learnt: Vec<Learnt> = learn(&samples, &class, names.len());
        let estimating = class.get(lead).copied();
        for (c, (name, l)) in names.iter().zip(&learnt).enumerate() {
            let h = self.history.entry(name.clone()).or_default();
            // Only the estimating class's fit can cost a later frame: work is counted in its
            // kind of counts.
            h.add(l, Some(c) == estimating && !work.is_empty());
        }
        // Classes measured before but not on this frame keep their speed, rescaled with the
        // others only when they share a frame again.
        for (name, speed) in names.iter().zip(relative_speeds(&learnt)) {
            if let Some(speed) = speed {
                self.speeds.insert(name.clone(), speed);
            }
        }
        learnt.iter().map(|l| l.spikes).sum()
    }
}

/// The index of the highest of `speeds` (the first of equals; 0 when empty).
fn fastest(speeds: &[f64]) -> usize {
    (0..speeds.len()).fold(0, |b, d| if speeds[d] > speeds[b] { d } else { b })
}

/// `n` tasks dealt out to devices in proportion to `speeds` (a device of speed 0 gets none; a
/// speed that is not finite and positive counts as 1 unless 0): each task in turn goes to the
/// device that would hold the least per unit of speed with it (the first of equals), so every
/// device's share spreads over the whole image, and the parts of the image that cost more are
/// shared out as evenly as the rest.
fn shares(n: usize, speeds: &[f64]) -> Vec<Vec<usize>> {
    let weight = |s: f64| {
        if s == 0.0 {
            0.0
        } else if s.is_finite() && s > 0.0 {
            s
        } else {
            1.0
        }
    };
    let weights: Vec<f64> = speeds.iter().map(|&s| weight(s)).collect();
    let mut out = vec![Vec::new(); speeds.len()];
    if !weights.iter().any(|&w| w > 0.0) {
        return out;
    }
    for task in 0..n {
        let load = |d: usize| (out[d].len() + 1) as f64 / weights[d];
        // `min_by` keeps the first of equals.
        let to = (0..weights.len())
            .filter(|&d| weights[d] > 0.0)
            .min_by(|&a, &b| load(a).total_cmp(&load(b)));
        if let Some(d) = to {
            out[d].push(task);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::shares;

    #[test]
    fn shares_cover_every_task_once_in_proportion() {
        assert_eq!(shares(4, &[1.0, 1.0]), [vec![0, 2], vec![1, 3]]);
        assert_eq!(shares(8, &[3.0, 1.0]), [vec![0, 1, 2, 4, 5, 6], vec![3, 7]]);
        assert_eq!(shares(3, &[1.0; 4]), [vec![0], vec![1], vec![2], vec![]]);
        assert_eq!(shares(4, &[f64::NAN, 1.0]), [vec![0, 2], vec![1, 3]]);
        assert_eq!(
            shares(9, &[2.0, 0.0, 1.0, 0.0]),
            [vec![0, 1, 3, 4, 6, 7], vec![], vec![2, 5, 8], vec![]]
        );
        assert_eq!(shares(0, &[1.0]), vec![Vec::<usize>::new()]);
        assert_eq!(shares(7, &[]), Vec::<Vec<usize>>::new());
        assert_eq!(shares(2, &[0.0, 0.0]), vec![Vec::<usize>::new(); 2]);
    }
}
