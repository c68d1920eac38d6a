//! What a run reports beside its image: the fastest frame's figures, each device's part, and
//! what crossed between the host and the devices. The JSON field names are what users read.

use serde::Serialize;

use crate::paths::{FrameStats, PathDeviceStats, Traffic};

/// What a run reports beside the image: the fastest of `frames` frames. Every render reports
/// it, in one process or over MPI ranks.
#[derive(Debug, Serialize)]
pub struct RunReport {
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
    /// Paths (pixels) of the frame.
    pub paths: usize,
    /// Tasks the frame was cut into.
    pub tasks: usize,
    /// Paths of the largest task the frame was cut into: `--task-size`, or fewer where the
    /// frame is too small to give every device four tasks of it, or where a task would take
    /// the slowest of devices of several classes over 2 % of the frame's expected time.
    pub task_size: usize,
    /// False in regular mode, and in cost mode on one device (its plan needs no costs).
    pub estimated: bool,
    /// Wall time of the estimate (0 when there was none).
    pub estimate_seconds: f64,
    /// Whether the estimate was the previous frame's, taken at no cost (the same scene,
    /// camera, tasks and sampling).
    pub estimate_reused: bool,
    /// Wall time the policy took to plan.
    pub plan_seconds: f64,
    /// Σ busy time over (makespan × devices).
    pub balance_efficiency: f64,
    /// Launches over every device.
    pub launches: u64,
    /// Task runs lost to failed devices and run again elsewhere.
    pub reruns: u64,
    /// Whether idle devices could run backup copies of the tasks others held (false with
    /// `--no-backups`).
    pub backups: bool,
    /// Backup copies launched in the reported frame.
    pub copies: u64,
    /// Seconds devices spent on task runs whose values were dropped, another copy's having
    /// come first.
    pub wasted_seconds: f64,
    /// Launches of the reported frame whose time was far off their planned cost, left out of
    /// the speeds learnt.
    pub spikes: usize,
    /// Every device failed and the frames were rendered on the host (`--host-fallback`).
    pub host_fallback: bool,
    /// Devices that failed, with why.
    pub failures: Vec<String>,
    /// What crossed between the host and the devices, the paths' values excepted.
    #[serde(flatten)]
    pub traffic: Traffic,
    /// Bytes of the paths' values sent to the host.
    pub film_bytes: u64,
    /// Devices the reported frame left idle: the fastest class alone had rendered frames
    /// faster than every device together.
    pub left_idle: Vec<String>,
    /// Each device's part.
    pub devices: Vec<PathDeviceStats>,
}

impl RunReport {
    /// The summary's figures: rays, time, speed, balance and what crossed the links.
    pub fn figures(&self) -> String {
        format!(
            "{} rays in {:.3} s, {:.2} MRays/s, balance {:.1} %; {} B to and {} B from devices, \
             {} waits, {} B of values",
            self.total_rays,
            self.render_seconds,
            self.mrays_per_s,
            100.0 * self.balance_efficiency,
            self.traffic.host_to_device_bytes,
            self.traffic.device_to_host_bytes,
            self.traffic.host_waits,
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
        if !self.backups {
            text += "no backup copies (--no-backups)\n";
        } else if self.copies > 0 {
            text += &format!(
                "backup copies: {} tasks, {:.3} s of device time wasted on the slower copies\n",
                self.copies, self.wasted_seconds
            );
        }
        if !self.left_idle.is_empty() {
            text += &format!(
                "left idle: {} (the fastest devices alone rendered frames faster)\n",
                self.left_idle.join(", ")
            );
        }
        text
    }

    /// The report of `frames` frames whose first took `first_render_seconds`, from the
    /// reported (fastest) frame's statistics `s`.
    pub fn new(frames: u32, first_render_seconds: f64, s: &FrameStats) -> Self {
        Self {
            frames,
            first_render_seconds,
            render_seconds: s.seconds,
            total_rays: s.rays,
            mrays_per_s: s.mrays_per_s(),
            paths: s.paths,
            tasks: s.tasks,
            task_size: s.task_size,
            estimated: s.estimated,
            estimate_seconds: s.estimate_seconds,
            estimate_reused: s.estimate_reused,
            plan_seconds: s.plan_seconds,
            balance_efficiency: s.balance_efficiency,
            launches: s.launches(),
            reruns: s.reruns,
            backups: s.backups,
            copies: s.copies,
            wasted_seconds: s.wasted_seconds,
            spikes: s.spikes,
            host_fallback: false,
            failures: s.failures.iter().map(ToString::to_string).collect(),
            traffic: s.traffic(),
            film_bytes: s.film_bytes(),
            left_idle: s.left_idle.clone(),
            devices: s.devices.clone(),
        }
    }
}
