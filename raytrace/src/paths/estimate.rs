//! The cost of a task of paths, from a sample of them traced for real.
//!
//! Every `stride`-th path of a task (at the sample rate) is rendered through all of its
//! generations by a tracer that counts what each ray costs (`B` nodes entered, `T` triangles
//! tested, stopping where the real trace stops), and the counts are scaled to the whole task.
//! AO paths spawn only their share of the probes (the rate of the samples, at least one), so
//! a diffuse frame is estimated at about the rate times a primary ray and a few probes per
//! sampled path. The sample is made on the host from the camera: no ray of a device crosses
//! a link to be estimated.

use std::ops::Range;

use rayon::prelude::*;
use sched::SampleRate;

use super::Frame;
use crate::cost::Work;
use crate::shade::{RenderOptions, Shader, Tracer, render_paths};
use crate::traverse::{any_hits_counted, closest_hits_counted};
use crate::{Bvh, HitBatch, RayBatch, RayKind};

/// A tracer that traces for real and sums the counts of every ray ([`Work::sum`], exact in
/// integers per generation), keeping AO probes apart (they are scaled by the probes left out).
struct Counting<'a> {
    bvh: &'a Bvh,
    paths: Work,
    probes: Work,
}

/// `a + b`, component by component.
fn plus(a: Work, b: Work) -> Work {
    Work {
        nodes: a.nodes + b.nodes,
        tris: a.tris + b.tris,
    }
}

impl Tracer for Counting<'_> {
    fn trace(&mut self, kind: RayKind, rays: &RayBatch) -> HitBatch {
        let (hits, counts) = if kind.is_occlusion() {
            any_hits_counted(self.bvh, rays)
        } else {
            closest_hits_counted(self.bvh, rays)
        };
        let work = Work::sum(&counts);
        match kind {
            RayKind::Ao => self.probes = plus(self.probes, work),
            _ => self.paths = plus(self.paths, work),
        }
        hits
    }
}

/// The estimated work of each of `tasks` (ranges of `frame`'s paths), sampling at `rate`.
/// Tasks are estimated in parallel in the caller's rayon pool.
pub fn estimate_paths(frame: &Frame<'_>, tasks: &[Range<usize>], rate: SampleRate) -> Vec<Work> {
    let stride = rate.stride();
    // AO: the rate's share of each sampled path's probes, at least one.
    let (options, probe_scale) = match frame.options.shader {
        Shader::Ao(s) if s.samples > 0 => {
            let kept = ((f64::from(s.samples) * rate.get()).ceil() as u32).clamp(1, s.samples);
            let mut ao = s;
            ao.samples = kept;
            let options = RenderOptions {
                shader: Shader::Ao(ao),
                ..*frame.options
            };
            (options, f64::from(s.samples) / f64::from(kept))
        }
        _ => (*frame.options, 1.0),
    };
    tasks
        .par_iter()
        .map(|task| {
            let ranks: Vec<u32> = task.clone().step_by(stride).map(|r| r as u32).collect();
            if ranks.is_empty() {
                return Work::default();
            }
            let mut tracer = Counting {
                bvh: frame.bvh,
                paths: Work::default(),
                probes: Work::default(),
            };
            render_paths(frame.scene, &mut tracer, &options, &ranks);
            let paths = tracer.paths.scaled(task.len(), ranks.len());
            let probes = tracer.probes.scaled(task.len(), ranks.len());
            plus(
                paths,
                Work {
                    nodes: probes.nodes * probe_scale,
                    tris: probes.tris * probe_scale,
                },
            )
        })
        .collect()
}
