//! What a path-resident device is, and how one becomes a [`sched::Executor`] for one frame.
//!
//! A task is a range of paths: indices into the image's Morton order. The device that runs a
//! task makes its primary rays itself (from the camera), traces and shades every generation
//! of those paths where their rays are, and hands back one value per path. Nothing else of a
//! path leaves the device, so what crosses a link grows with the tasks, not with the rays.

use std::ops::Range;

use glam::Vec3;
use sched::{DeviceError, Executor, SampleRate, Sink};

use super::frame::Frame;
use super::{Traffic, walk_paths};
use crate::cost::Work;
use crate::traverse::walk::Walk;

/// What one launch of tasks produced on a device.
#[derive(Clone, Debug, Default)]
pub struct Launch {
    /// Each path's radiance, task after task as launched.
    pub values: Vec<Vec3>,
    /// Rays traced over every generation of the launch's paths (live rays: a slot whose path
    /// ended is not counted where the device can tell).
    pub rays: usize,
    /// What crossed between the host and the device, the values excepted.
    pub traffic: Traffic,
    /// Bytes of the values that crossed to the host (0 for a device in the host's memory).
    pub film_bytes: u64,
    /// Seconds the device measured running its kernels, where it can.
    pub device_seconds: Option<f64>,
}

/// What a device's estimate of some tasks gave.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    /// Each task's estimated work, in order.
    pub work: Vec<Work>,
    /// What crossed between the host and the device to estimate them.
    pub traffic: Traffic,
}

/// A device that renders whole paths. There are two required methods.
///
/// ## Contract
/// A path's value is [`crate::shade::render`]'s for its pixel, whatever launch, task or
/// device it lands in, so the image does not depend on the schedule.
pub trait PathDevice: Send {
    /// Renders the paths of `tasks` of `frame`, in one launch.
    fn render(&mut self, frame: &Frame<'_>, tasks: &[&Range<usize>])
    -> Result<Launch, DeviceError>;

    /// [`PathDevice::render`], for a launch whose values may stop being wanted while it runs
    /// (`wanted()` turns false: another device delivered them first); a device that waits
    /// on something may then return sooner, its values still complete. By default renders
    /// the launch whole.
    fn render_while(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        wanted: &dyn Fn() -> bool,
    ) -> Result<Launch, DeviceError> {
        let _ = wanted;
        self.render(frame, tasks)
    }

    /// A name unique among the devices of a renderer.
    fn name(&self) -> String;

    /// Devices of one class are the same hardware doing the same work (the `N` devices of a
    /// `cpu:N/T` entry): their speed is measured together. By default every device is a class
    /// of its own.
    fn class(&self) -> String {
        self.name()
    }

    /// The estimated work of `tasks` of `frame`, from every path of each at `rate`'s stride
    /// counted as `walk` says ([`walk_paths`]'s sample and scaling), where the device
    /// renders: a device estimates the tasks it holds. By default counted on the host, in the
    /// caller's rayon pool.
    ///
    /// # Errors
    /// A [`DeviceError`] when the device cannot estimate them; the renderer then estimates
    /// them on the host.
    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        rate: SampleRate,
        walk: Walk,
    ) -> Result<Estimate, DeviceError> {
        Ok(Estimate {
            work: walk_paths(frame, tasks, rate, walk),
            traffic: Traffic::default(),
        })
    }

    /// What [`PathDevice::estimate`]'s counts of the trace walk are counted on: devices of
    /// one kind give the same work for the same tasks, devices of different kinds do not (the
    /// host's traces walk its 8-wide tree, the GPU kernels a compressed one whose quantized
    /// boxes let more rays in), so a frame's tasks are all estimated by devices of one kind. The reduced walks count on the binary tree
    /// everywhere. `"host"` by default.
    fn estimate_kind(&self) -> &'static str {
        "host"
    }

    /// Seconds a launch costs beyond its tasks, where known: see
    /// [`sched::Executor::launch_overhead`]. Unknown by default.
    fn launch_overhead(&self) -> Option<f64> {
        None
    }

    /// Whether a launch costs next to nothing (a CPU device's pool), so that a launch may be
    /// rendered in pieces that the other devices see delivered. False by default.
    fn cheap_launches(&self) -> bool {
        false
    }

    /// The frame is done: what the device kept for it (a sample's values) is of no further
    /// use, so that no later frame renders faster for this one's work. Nothing by default.
    fn end_frame(&mut self) {}
}

/// One task's share of a launch: its paths' values, and, on the first task of a launch, the
/// launch's totals.
#[derive(Clone, Debug, Default)]
pub struct TaskValues {
    /// The task's paths' values, in path order.
    pub values: Vec<Vec3>,
    /// The launch's rays, traffic, film bytes and device seconds, on its first task only, so
    /// that sums over tasks are the launches' sums.
    pub launch: Option<Launch>,
}

/// A device bound to one frame: the [`Executor`] that `sched`'s runtime drives.
pub struct BoundPaths<'r, 'a> {
    device: &'r mut (dyn PathDevice + 'a),
    frame: &'r Frame<'r>,
    speed: f64,
    pieces: bool,
}

/// A launch is rendered in about this many pieces (see [`BoundPaths::new`]).
const PIECES: usize = 8;

impl<'r, 'a> BoundPaths<'r, 'a> {
    /// `device` rendering `frame`, planned at relative `speed`. With `pieces`, a launch is
    /// rendered in pieces where the device's launches are cheap ([`PathDevice::cheap_launches`]:
    /// a CPU device; a GPU renders a launch whole): each piece's values are delivered as it
    /// ends, so that the other devices see how far it has got and may run backup copies of the
    /// rest, and tasks another device delivered first are skipped. The values do not change.
    pub fn new(
        device: &'r mut (dyn PathDevice + 'a),
        frame: &'r Frame<'r>,
        speed: f64,
        pieces: bool,
    ) -> Self {
        Self {
            device,
            frame,
            speed,
            pieces,
        }
    }

    /// One launch of the device, checked to give a value for every path.
    fn launch(
        &mut self,
        tasks: &[&Range<usize>],
        wanted: &dyn Fn() -> bool,
    ) -> Result<Launch, DeviceError> {
        let launch = self.device.render_while(self.frame, tasks, wanted)?;
        let paths: usize = tasks.iter().map(|t| t.len()).sum();
        if launch.values.len() != paths {
            return Err(DeviceError::msg(format!(
                "{}: a launch of {paths} paths gave {} values",
                self.device.name(),
                launch.values.len()
            )));
        }
        Ok(launch)
    }
}

impl Executor<Range<usize>> for BoundPaths<'_, '_> {
    type Output = TaskValues;

    fn run(&mut self, task: &Range<usize>) -> Result<TaskValues, DeviceError> {
        let mut launch = self.launch(&[task], &|| true)?;
        Ok(TaskValues {
            values: std::mem::take(&mut launch.values),
            launch: Some(launch),
        })
    }

    fn run_batch(
        &mut self,
        tasks: &[&Range<usize>],
        sink: &mut Sink<TaskValues>,
    ) -> Result<(), DeviceError> {
        let piece = if self.pieces && self.device.cheap_launches() {
            tasks.len().div_ceil(PIECES)
        } else {
            tasks.len()
        };
        let mut rest = tasks;
        while !rest.is_empty() {
            if !sink.wanted() {
                sink.skip();
                rest = &rest[1..];
                continue;
            }
            let (now, later) = rest.split_at(piece.min(rest.len()));
            let mut launch = {
                let sink = &*sink;
                self.launch(now, &|| sink.any_wanted(now.len()))?
            };
            let mut values = std::mem::take(&mut launch.values).into_iter();
            let mut totals = Some(launch);
            for task in now {
                sink.push(TaskValues {
                    values: values.by_ref().take(task.len()).collect(),
                    launch: totals.take(),
                });
            }
            rest = later;
        }
        Ok(())
    }

    /// The speed measured on earlier frames (1 before the first).
    fn speed(&self) -> f64 {
        self.speed
    }

    fn launch_overhead(&self) -> Option<f64> {
        self.device.launch_overhead()
    }

    fn name(&self) -> String {
        self.device.name()
    }
}
