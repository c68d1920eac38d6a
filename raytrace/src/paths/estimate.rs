//! The cost of a task of paths, from a sample of them.
//!
//! Every `stride`-th path of a task (at the sample rate) is sampled, and its counts (`B`
//! nodes entered, `T` triangles tested) are scaled to the whole task. How a sampled path is
//! counted is the estimate's [`Walk`]:
//! - [`Walk::Trace`] (the default): the path is rendered through all of its generations by a
//!   tracer that counts what each ray costs, stopping where the real trace stops. AO paths
//!   spawn only their share of the probes (the rate of the samples, at least one), so a
//!   diffuse frame is estimated at about the rate times a primary ray and a few probes per
//!   sampled path.
//! - [`Walk::Reduced`] and [`Walk::FirstLeaf`]: the thesis's method, its camera ray alone
//!   walked without triangle tests (the whole ray, or up to the first leaf it reaches), in
//!   packets. Cheaper, but blind to the work of the generations its hit would spawn.
//!
//! The sample is made on the host from the camera: no ray of a device crosses a link to be
//! estimated.

use std::borrow::Borrow;
use std::ops::Range;

use sched::SampleRate;

use super::Frame;
use crate::cost::Work;
use crate::shade::{PathRendering, RenderOptions, Shader, Tracer, render_paths_at};
use crate::traverse::batch::{hits_counted_in, reduced_counts};
use crate::traverse::layout::Layout;
use crate::traverse::walk::Walk;
use crate::{Bvh, HitBatch, RayBatch, RayKind};

/// A tracer that traces for real and sums the counts of every ray by the path it belongs to
/// (exact, in integers), keeping AO probes apart (they are scaled by the probes left out).
struct Counting<'a> {
    bvh: &'a Bvh,
    layout: Layout,
    /// Per sampled path: nodes, triangles and rays of its own rays, then of its kept probes.
    sums: Vec<[[u64; 3]; 2]>,
}

impl Tracer for Counting<'_> {
    /// The shaders always name each ray's path; a bare generation counts for the first.
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        self.trace_paths(kind, rays, &|_| 0)
    }

    fn trace_paths(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        path_of: &dyn Fn(usize) -> u32,
    ) -> HitBatch {
        let (hits, counts) = hits_counted_in(self.bvh, rays, kind.is_occlusion(), self.layout);
        let part = usize::from(kind == RayKind::Ao);
        for (i, c) in counts.iter().enumerate() {
            let sum = &mut self.sums[path_of(i) as usize][part];
            sum[0] += u64::from(c.nodes);
            sum[1] += u64::from(c.tris);
            sum[2] += 1;
        }
        hits
    }
}

/// What a sample at `rate` renders: `options`, an AO shader keeping the rate's share of each
/// path's probes (at least one); and the factor that scales the kept probes' work to all.
pub fn sampled_options(options: &RenderOptions, rate: SampleRate) -> (RenderOptions, f64) {
    match options.shader {
        Shader::Ao(s) if s.samples > 0 => {
            let kept = ((f64::from(s.samples) * rate.get()).ceil() as u32).clamp(1, s.samples);
            let mut ao = s;
            ao.samples = kept;
            let options = RenderOptions {
                shader: Shader::Ao(ao),
                ..*options
            };
            (options, f64::from(s.samples) / f64::from(kept))
        }
        _ => (*options, 1.0),
    }
}

/// A task of `len` paths' work from its `sampled` paths' counts: those of their paths'
/// rays, and of their kept AO probes (scaled by `probe_scale` to every probe). Its `R` is
/// its paths, whatever rays they trace: the GPU, which counts the same `B` and `T`, does not
/// count the rays a path spawns.
pub fn task_work(paths: Work, probes: Work, len: usize, sampled: usize, probe_scale: f64) -> Work {
    if sampled == 0 {
        return Work::default();
    }
    let (paths, probes) = (paths.scaled(len, sampled), probes.scaled(len, sampled));
    Work {
        nodes: paths.nodes + probes.nodes * probe_scale,
        tris: paths.tris + probes.tris * probe_scale,
        rays: len as f64,
    }
}

/// The estimated work of each of `tasks` from its sampled paths' camera rays, walked by
/// `walk` on the binary tree (the thesis's reduced traversal, or first-leaf; see the module
/// documentation), in the caller's rayon pool; a GPU counts the same on the device.
/// [`Walk::Trace`] renders the sampled paths instead, as [`sample_paths`] does.
pub fn walk_paths<T>(frame: &Frame<'_>, tasks: &[T], rate: SampleRate, walk: Walk) -> Vec<Work>
where
    T: Borrow<Range<usize>> + Sync,
{
    if let Walk::Trace { .. } = walk {
        let sampled = sample_paths(frame, tasks, rate, Layout::Wide);
        return sampled.into_iter().map(|s| s.work).collect();
    }
    let options = frame.options;
    let (w, h) = (options.width, options.height);
    let stride = rate.stride();
    let ranks: Vec<usize> = tasks
        .iter()
        .flat_map(|t| t.borrow().clone().step_by(stride))
        .collect();
    let rays = options
        .camera
        .primary_rays_of(w, h, ranks.iter().copied())
        .rays;
    let counts = reduced_counts(frame.bvh, &rays, walk, 0..rays.len());
    let mut next = 0;
    tasks
        .iter()
        .map(|t| {
            let task: &Range<usize> = t.borrow();
            let sampled = task.clone().step_by(stride).len();
            let work = Work::sum(&counts[next..next + sampled]);
            next += sampled;
            task_work(work, Work::default(), task.len(), sampled, 1.0)
        })
        .collect()
}

/// One task's sample: its estimated work, and the paths rendered for it with their values
/// and rays, which are the render's own where the sample renders the frame's options
/// ([`sampled_options`] left them as they were: a Whitted frame, not an AO one, whose sample
/// keeps only its rate's share of each path's probes).
#[derive(Clone, Debug, Default)]
pub struct SampledTask {
    /// The task's paths.
    pub task: Range<usize>,
    /// Its estimated work.
    pub work: Work,
    /// The sampled paths, ascending.
    pub ranks: Vec<u32>,
    /// Their values, in the order of `ranks`.
    pub values: Vec<glam::Vec3>,
    /// Rays their paths traced.
    pub rays: usize,
}

/// The estimated work of each of `tasks` (ranges of `frame`'s paths), sampling at `rate`,
/// and what each task's sample rendered ([`SampledTask`]): traced on the host on the tree
/// `layout` names (the 8-wide one its hit queries walk, or the binary one), in the
/// caller's rayon pool. Every task's sampled paths are rendered at once: a render per task
/// cost more than its few paths where tasks are small.
pub fn sample_paths<T>(
    frame: &Frame<'_>,
    tasks: &[T],
    rate: SampleRate,
    layout: Layout,
) -> Vec<SampledTask>
where
    T: Borrow<Range<usize>> + Sync,
{
    let stride = rate.stride();
    let (options, probe_scale) = sampled_options(frame.options, rate);
    let ao_distance = options.shader.ao_distance(frame.scene);
    let ranks: Vec<u32> = tasks
        .iter()
        .flat_map(|t| t.borrow().clone().step_by(stride).map(|r| r as u32))
        .collect();
    let mut tracer = Counting {
        bvh: frame.bvh,
        layout,
        sums: vec![[[0; 3]; 2]; ranks.len()],
    };
    let rendered = if ranks.is_empty() {
        PathRendering::default()
    } else {
        render_paths_at(frame.scene, &mut tracer, &options, &ranks, ao_distance)
    };
    let mut next = 0;
    tasks
        .iter()
        .map(|task| {
            let task: &Range<usize> = task.borrow();
            let sampled = next..next + task.clone().step_by(stride).len();
            next = sampled.end;
            let sum = |part: usize| {
                let [b, t, r] = tracer.sums[sampled.clone()].iter().fold([0u64; 3], |a, s| {
                    [a[0] + s[part][0], a[1] + s[part][1], a[2] + s[part][2]]
                });
                Work {
                    nodes: b as f64,
                    tris: t as f64,
                    rays: r as f64,
                }
            };
            let (paths, probes) = (sum(0), sum(1));
            SampledTask {
                task: task.clone(),
                work: task_work(paths, probes, task.len(), sampled.len(), probe_scale),
                ranks: ranks[sampled.clone()].to_vec(),
                values: rendered.values[sampled].to_vec(),
                rays: (paths.rays + probes.rays) as usize,
            }
        })
        .collect()
}
