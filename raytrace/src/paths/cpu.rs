//! The CPU path device: one worker of a `--devices cpu:N[/T]` list, rendering its tasks'
//! paths with the host's shading ([`crate::shade::render_paths`]) in a rayon pool of its own.
//! Its paths live in the host's memory, so nothing crosses a link.
//!
//! Its estimate renders a sample of each task's paths for real ([`sample_paths`]). Where
//! that sample rendered the frame's own options (a Whitted frame; not an AO one, whose sample
//! keeps fewer probes), the sampled paths' values are kept in the host's memory, shared by the
//! devices of one `cpu:N` entry, and the entry's launch of a task takes them instead of
//! rendering those paths again: for such a task the estimate costs the frame only what its
//! counted, scattered sample costs beyond the render's own work.

use std::collections::HashMap;
use std::ops::Range;
use std::sync::{Arc, Mutex};

use sched::{DeviceError, SampleRate};

use super::frame::FrameKey;
use super::{
    Estimate, Frame, Launch, PathDevice, SampledTask, Traffic, sample_paths, sampled_options,
    walk_paths,
};
use crate::Result;
use crate::shade::{CpuTracer, render_paths};
use crate::traverse::layout::Layout;
use crate::traverse::walk::Walk;

/// One CPU device. See the module documentation.
pub struct CpuPaths {
    index: usize,
    threads: usize,
    pool: rayon::ThreadPool,
    /// Samples with final values, not yet taken by a launch.
    kept: Arc<Mutex<Kept>>,
}

/// The samples of one frame's tasks whose values are the image's, shared by devices, by
/// task (its first and past-the-last path).
#[derive(Debug, Default)]
struct Kept {
    frame: Option<FrameKey>,
    tasks: HashMap<(usize, usize), SampledTask>,
}

impl Kept {
    /// Keeps `sampled` for `frame`, in place of the samples of the same tasks and of every
    /// other frame.
    fn keep(&mut self, frame: FrameKey, sampled: Vec<SampledTask>) {
        if self.frame != Some(frame) {
            self.clear();
            self.frame = Some(frame);
        }
        for s in sampled {
            self.tasks.insert((s.task.start, s.task.end), s);
        }
    }

    /// Takes the samples of `tasks` of `frame`, in the order of `tasks` (`None` for a task
    /// without one).
    fn take(&mut self, frame: FrameKey, tasks: &[&Range<usize>]) -> Vec<Option<SampledTask>> {
        if self.frame != Some(frame) {
            self.clear();
            return vec![None; tasks.len()];
        }
        tasks
            .iter()
            .map(|t| self.tasks.remove(&(t.start, t.end)))
            .collect()
    }

    fn clear(&mut self) {
        self.tasks.clear();
        self.frame = None;
    }
}

impl CpuPaths {
    /// Device number `index` (named `cpu{index}`) with a pool of `threads` threads: even one
    /// thread gets its own pool, so that shading's parallel loops stay on the device's
    /// threads instead of the process's global pool.
    ///
    /// # Errors
    /// [`crate::Error::ThreadPool`] when the threads cannot be started.
    pub fn new(index: usize, threads: usize) -> Result<Self> {
        Self::sharing(index, threads, Arc::default())
    }

    fn sharing(index: usize, threads: usize, kept: Arc<Mutex<Kept>>) -> Result<Self> {
        let threads = threads.max(1);
        let pool = crate::pool::thread_pool(format!("cobalt-cpu{index}"), threads)?;
        Ok(Self {
            index,
            threads,
            pool,
            kept,
        })
    }

    /// `count` devices of `threads` threads, numbered from `first`, sharing the samples
    /// their estimates render (see the module documentation).
    ///
    /// # Errors
    /// As [`CpuPaths::new`].
    pub fn many(first: usize, count: usize, threads: usize) -> Result<Vec<Self>> {
        let kept = Arc::default();
        (first..first + count)
            .map(|i| Self::sharing(i, threads, Arc::clone(&kept)))
            .collect()
    }

    /// The shared samples, usable whether or not a device panicked while holding them
    /// (each change to them is whole before the lock is let go).
    fn kept(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.kept
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl PathDevice for CpuPaths {
    fn render(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
    ) -> std::result::Result<Launch, DeviceError> {
        let paths = frame.paths();
        if let Some(t) = tasks.iter().find(|t| t.start > t.end || t.end > paths) {
            return Err(DeviceError::msg(format!(
                "{}: task {}..{} is outside the image's {paths} paths",
                self.name(),
                t.start,
                t.end
            )));
        }
        // A task's sample serves one launch of it, in the frame it was made for.
        let kept = self.kept().take(FrameKey::of(frame), tasks);
        // Ranks are below the image's pixels, which fit a u32 (sides of at most 65536).
        let mut ranks: Vec<u32> = Vec::with_capacity(tasks.iter().map(|t| t.len()).sum());
        for (&t, k) in tasks.iter().zip(&kept) {
            let all = t.clone().map(|r| r as u32);
            match k {
                Some(k) => ranks.extend(all.filter(|r| k.ranks.binary_search(r).is_err())),
                None => ranks.extend(all),
            }
        }
        let rendered = self.pool.install(|| {
            render_paths(
                frame.scene,
                &mut CpuTracer::new(frame.bvh),
                frame.options,
                &ranks,
            )
        });
        let mut rays: usize = rendered.generations.iter().map(|g| g.rays).sum();
        if kept.iter().all(Option::is_none) {
            return Ok(Launch {
                values: rendered.values,
                rays,
                ..Launch::default()
            });
        }
        // Task after task, each path's value from the render or from the sample.
        let mut values = Vec::with_capacity(tasks.iter().map(|t| t.len()).sum());
        let mut fresh = rendered.values.into_iter();
        for (&t, k) in tasks.iter().zip(&kept) {
            let Some(k) = k else {
                values.extend(fresh.by_ref().take(t.len()));
                continue;
            };
            rays += k.rays;
            let mut sampled = k.ranks.iter().zip(&k.values).peekable();
            for r in t.clone() {
                match sampled.next_if(|(s, _)| **s as usize == r) {
                    Some((_, v)) => values.push(*v),
                    None => values.extend(fresh.next()),
                }
            }
        }
        Ok(Launch {
            values,
            rays,
            ..Launch::default()
        })
    }

    /// On the device's own threads.
    fn estimate(
        &mut self,
        frame: &Frame<'_>,
        tasks: &[&Range<usize>],
        rate: SampleRate,
        walk: Walk,
    ) -> std::result::Result<Estimate, DeviceError> {
        if !matches!(walk, Walk::Trace { .. }) {
            // The camera rays' walks render no value to keep.
            let work = self.pool.install(|| walk_paths(frame, tasks, rate, walk));
            return Ok(Estimate {
                work,
                traffic: Traffic::default(),
            });
        }
        let sampled = self
            .pool
            .install(|| sample_paths(frame, tasks, rate, Layout::Wide));
        let work = sampled.iter().map(|s| s.work).collect();
        // The sample's values are the image's only where it rendered the frame's options.
        let is_final = sampled_options(frame.options, rate).0 == *frame.options;
        let kept = if is_final { sampled } else { Vec::new() };
        self.kept().keep(FrameKey::of(frame), kept);
        Ok(Estimate {
            work,
            traffic: Traffic::default(),
        })
    }

    /// The entry's kept samples go: a launch of a later frame renders every path it is given.
    fn end_frame(&mut self) {
        self.kept().clear();
    }

    fn name(&self) -> String {
        format!("cpu{}", self.index)
    }

    fn cheap_launches(&self) -> bool {
        true
    }

    fn class(&self) -> String {
        format!("cpu/{}", self.threads)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRACE: Walk = Walk::Trace { any: false };
    use crate::shade::{AoSettings, RenderOptions, Shader, WhittedSettings};
    use crate::{BuildPreset, Bvh, Camera, Scene, SceneSource};

    fn forest(shader: &Shader) -> (Scene, Bvh) {
        let scene = SceneSource::parse("builtin:forest:0.05")
            .and_then(|s| s.load(shader.needs()))
            .expect("built-in scene");
        let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("BVH");
        (scene, bvh)
    }

    fn bits(values: &[glam::Vec3]) -> Vec<[u32; 3]> {
        values
            .iter()
            .map(|v| v.to_array().map(f32::to_bits))
            .collect()
    }

    /// A Whitted task whose sample another device of the entry rendered is launched with the
    /// sample's values in place, bit for bit the values of a launch without it; the sample
    /// serves one launch, and an AO sample (fewer probes) is not kept.
    #[test]
    fn a_sampled_whitted_task_reuses_its_sample_once_and_an_ao_one_never() {
        let whitted = Shader::Whitted(WhittedSettings { bounces: 2 });
        let (scene, bvh) = forest(&whitted);
        let options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 0), whitted);
        let frame = Frame {
            scene: &scene,
            bvh: &bvh,
            options: &options,
        };
        let tasks = sched::split_ranges(32 * 32, 128);
        let all: Vec<&Range<usize>> = tasks.iter().collect();
        let want = CpuPaths::new(9, 1)
            .expect("cpu")
            .render(&frame, &all)
            .expect("render");

        let mut pair = CpuPaths::many(0, 2, 1).expect("cpu");
        let (first, second) = pair.split_at_mut(1);
        let held: Vec<&Range<usize>> = tasks[..4].iter().collect();
        let estimate = first[0]
            .estimate(&frame, &held, SampleRate::THESIS, TRACE)
            .expect("estimate");
        assert_eq!(estimate.work.len(), 4);
        assert_eq!(second[0].kept().tasks.len(), 4, "kept for the entry");
        let got = second[0].render(&frame, &all).expect("render");
        assert_eq!(bits(&got.values), bits(&want.values));
        assert_eq!(
            got.rays, want.rays,
            "the sample's rays count as the launch's"
        );
        assert!(first[0].kept().tasks.is_empty(), "taken by the launch");
        let again = first[0].render(&frame, &all).expect("render");
        assert_eq!(bits(&again.values), bits(&want.values));

        // The frame's end drops what is left; another frame's launch finds nothing of this
        // one's.
        first[0]
            .estimate(&frame, &held, SampleRate::THESIS, TRACE)
            .expect("estimate");
        second[0].end_frame();
        assert!(first[0].kept().tasks.is_empty());
        first[0]
            .estimate(&frame, &held, SampleRate::THESIS, TRACE)
            .expect("estimate");
        let moved = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 1), whitted);
        let other = Frame {
            options: &moved,
            ..frame
        };
        let elsewhere = CpuPaths::new(9, 1)
            .expect("cpu")
            .render(&other, &all)
            .expect("render");
        let got = second[0].render(&other, &all).expect("render");
        assert_eq!(bits(&got.values), bits(&elsewhere.values));
        assert!(first[0].kept().tasks.is_empty());

        let ao = Shader::Ao(AoSettings {
            samples: 8,
            ..Default::default()
        });
        let ao_options = RenderOptions::new(32, 32, Camera::orbit(&scene.bounds(), 0), ao);
        let ao_frame = Frame {
            options: &ao_options,
            ..frame
        };
        first[0]
            .estimate(&ao_frame, &held, SampleRate::THESIS, TRACE)
            .expect("estimate");
        assert!(
            first[0].kept().tasks.is_empty(),
            "an AO sample's values are not the image's"
        );
    }
}
