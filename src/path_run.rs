//! The path pipeline's run, shared by `cobalt render --pipeline paths` and its `mpirun` form:
//! frames rendered through one [`raytrace::paths::PathRenderer`] on path-resident devices
//! (each task's paths made, traced and shaded on the device that runs it; only task lists,
//! costs and the paths' values cross between host and device), and what the run reports.

use serde::Serialize;

use raytrace::Film;
use raytrace::devices::DeviceSpec;
use raytrace::paths::{FrameRendering, FrameStats, PathRenderer, build_path_devices};
use raytrace::scheduled::{FailAfter, Settings};
use raytrace::shade::RenderOptions;
use raytrace::{Bvh, Scene};
use sched::{DeviceFailure, SchedError};

use crate::calibration::Store;
use crate::error::CliError;

/// One device's part of the reported frame.
#[derive(Debug, Serialize)]
pub struct DeviceReport {
    name: String,
    speed: f64,
    tasks: usize,
    launches: u64,
    busy_seconds: f64,
    rays: usize,
    host_to_device_bytes: u64,
    device_to_host_bytes: u64,
    host_waits: u64,
    film_bytes: u64,
    #[serde(skip_serializing_if = "Option::is_none")]
    device_seconds: Option<f64>,
}

/// What the path pipeline reports beside the image: the fastest of `frames` renders.
#[derive(Debug, Serialize)]
pub struct PathRun {
    /// Frames rendered through one renderer (`--repeats`); the figures are the fastest one's.
    pub frames: u32,
    /// Wall time of the first frame (the first plan has no measured speeds).
    pub first_render_seconds: f64,
    /// Wall time of the fastest frame: estimate, plan, run and film.
    pub render_seconds: f64,
    /// Rays traced over every generation and device.
    pub total_rays: usize,
    /// Rendering efficiency: rays over the frame's wall time.
    pub mrays_per_s: f64,
    /// Paths (pixels) and tasks of the frame.
    pub paths: usize,
    pub tasks: usize,
    /// False in regular mode, and in cost mode on one device (its plan needs no costs).
    pub estimated: bool,
    pub estimate_seconds: f64,
    pub plan_seconds: f64,
    pub balance_efficiency: f64,
    pub launches: u64,
    pub reruns: u64,
    /// Launches of the reported frame whose time was far off their planned cost, left out of
    /// the speeds learnt.
    pub spikes: usize,
    /// Every device failed and the frames were rendered on the host (`--host-fallback`).
    pub host_fallback: bool,
    /// Devices that failed, with why.
    pub failures: Vec<String>,
    /// What crossed between the host and the devices, the paths' values excepted.
    pub host_to_device_bytes: u64,
    pub device_to_host_bytes: u64,
    pub host_waits: u64,
    /// Bytes of the paths' values sent to the host.
    pub film_bytes: u64,
    /// Devices the reported frame left idle: the fastest class alone had rendered frames
    /// faster than every device together.
    pub left_idle: Vec<String>,
    pub devices: Vec<DeviceReport>,
}

impl PathRun {
    /// The summary's figures: rays, time, speed, balance and what crossed the links.
    pub fn figures(&self) -> String {
        format!(
            "{} rays in {:.3} s, {:.2} MRays/s, balance {:.1} %; {} B to and {} B from devices, \
             {} waits, {} B of values",
            self.total_rays,
            self.render_seconds,
            self.mrays_per_s,
            100.0 * self.balance_efficiency,
            self.host_to_device_bytes,
            self.device_to_host_bytes,
            self.host_waits,
            self.film_bytes,
        )
    }

    /// The summary's closing lines: a fallback to the host, and each failure.
    pub fn notes(&self) -> String {
        let mut text = String::new();
        if self.host_fallback {
            text += "every device failed: the frames were rendered on the host instead \
                     (--host-fallback)\n";
        }
        for f in &self.failures {
            text += &format!("  failed: {f}\n");
        }
        if !self.left_idle.is_empty() {
            text += &format!(
                "left idle: {} (the fastest devices alone rendered frames faster)\n",
                self.left_idle.join(", ")
            );
        }
        text
    }

    pub(crate) fn new(frames: u32, first_render_seconds: f64, s: &FrameStats) -> Self {
        let t = s.traffic();
        Self {
            frames,
            first_render_seconds,
            render_seconds: s.seconds,
            total_rays: s.rays,
            mrays_per_s: s.mrays_per_s(),
            paths: s.paths,
            tasks: s.tasks,
            estimated: s.estimated,
            estimate_seconds: s.estimate_seconds,
            plan_seconds: s.plan_seconds,
            balance_efficiency: s.balance_efficiency,
            launches: s.launches(),
            reruns: s.reruns,
            spikes: s.spikes,
            host_fallback: false,
            failures: s.failures.iter().map(ToString::to_string).collect(),
            host_to_device_bytes: t.host_to_device_bytes,
            device_to_host_bytes: t.device_to_host_bytes,
            host_waits: t.host_waits,
            film_bytes: s.film_bytes(),
            left_idle: s.left_idle.clone(),
            devices: s
                .devices
                .iter()
                .map(|d| DeviceReport {
                    name: d.name.clone(),
                    speed: d.speed,
                    tasks: d.tasks,
                    launches: d.launches,
                    busy_seconds: d.busy,
                    rays: d.rays,
                    host_to_device_bytes: d.traffic.host_to_device_bytes,
                    device_to_host_bytes: d.traffic.device_to_host_bytes,
                    host_waits: d.traffic.host_waits,
                    film_bytes: d.film_bytes,
                    device_seconds: d.device_seconds,
                })
                .collect(),
        }
    }
}

/// Where a failed frame may go: when every device of `devices` (the `--devices` text) fails,
/// `host_fallback` finishes the frames on the host's threads; otherwise the failure is an
/// error naming each device.
pub struct Fallback<'s> {
    pub devices: &'s str,
    pub host_fallback: bool,
}

/// Renders `frames` frames of `options` through one path renderer over `specs`, keeping the
/// fastest; a frame whose every device failed goes where `fallback` says. With a
/// `calibration` (and the workload's name), the first frame plans with what it holds and
/// what the frames taught is kept in it.
#[allow(clippy::too_many_arguments)]
pub fn render(
    scene: &Scene,
    bvh: &Bvh,
    options: &RenderOptions,
    specs: &[raytrace::devices::DeviceSpec],
    faults: &[FailAfter],
    settings: Settings,
    frames: u32,
    fallback: &Fallback<'_>,
    mut calibration: Option<(&mut Store, &str)>,
) -> Result<(Film, PathRun), CliError> {
    let devices = build_path_devices(scene, bvh, specs, faults)?;
    let mut renderer = PathRenderer::new(devices, settings)?;
    if let Some((store, workload)) = calibration.as_mut() {
        store.recall(&mut renderer, workload);
    }
    let mut host: Option<PathRenderer> = None;
    let mut lost: Vec<DeviceFailure> = Vec::new();
    let mut best: Option<FrameRendering> = None;
    let mut first_render_seconds = 0.0;
    for k in 0..frames.max(1) {
        let frame = match host.as_mut() {
            Some(host) => host.render(scene, bvh, options)?,
            None => match renderer.render(scene, bvh, options) {
                Ok(frame) => frame,
                Err(e @ (SchedError::AllDevicesFailed { .. } | SchedError::NoDevices)) => {
                    if let SchedError::AllDevicesFailed { failures, .. } = e {
                        lost.extend(failures);
                    }
                    if !fallback.host_fallback {
                        return Err(CliError::devices_failed(fallback.devices, &lost));
                    }
                    let threads = std::thread::available_parallelism().map_or(1, usize::from);
                    let spec = DeviceSpec::Cpu { count: 1, threads };
                    let devices = build_path_devices(scene, bvh, &[spec], &[])?;
                    host.insert(PathRenderer::new(devices, settings)?)
                        .render(scene, bvh, options)?
                }
                Err(e) => return Err(e.into()),
            },
        };
        if k == 0 {
            first_render_seconds = frame.stats.seconds;
        }
        if best
            .as_ref()
            .is_none_or(|b| frame.stats.seconds < b.stats.seconds)
        {
            best = Some(frame);
        }
    }
    // The host fallback's frames measured the host, not the devices asked for.
    if let Some((store, workload)) = calibration {
        store.remember(&renderer, workload);
    }
    let best = best.ok_or_else(|| CliError::Write("no frame was rendered".into()))?;
    let mut run = PathRun::new(frames.max(1), first_render_seconds, &best.stats);
    run.host_fallback = host.is_some();
    run.failures.extend(lost.iter().map(ToString::to_string));
    Ok((best.film, run))
}
