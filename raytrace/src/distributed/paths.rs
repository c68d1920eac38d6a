//! The path pipeline over the ranks of an MPI job: on rank 0, every other rank is one more
//! path device ([`RankPaths`]) beside rank 0's own; each rank renders the paths of the tasks
//! it is sent on its own devices ([`serve_paths`]) and sends back their values. Ranks keep
//! their paths as devices do: only task ranges go out and the paths' values come back, never
//! a ray or a hit.
//!
//! Every rank loads the same scene, builds the same BVH and parses the same command line, so a
//! task range means the same paths everywhere, and each path is rendered whole by one device:
//! the image is one process's, byte for byte.

use std::ops::Range;

use glam::Vec3;
use sched::mpi::{Cluster, RemoteNode, Wire, WireError, take};
use sched::{DeviceError, Executor, Sink};

use sched::SchedError;

use crate::paths::Settings;
use crate::paths::{Frame, Launch, PathDevice, PathRenderer, Traffic};

/// One task's paths rendered on a rank: their values (bit patterns travel) and the rays traced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PathOutput {
    /// The values, in path order.
    pub values: Vec<Vec3>,
    /// Rays the task's paths traced.
    pub rays: u64,
}

impl Wire for PathOutput {
    fn encode(&self, out: &mut Vec<u8>) {
        self.rays.encode(out);
        (self.values.len() as u64).encode(out);
        out.reserve(12 * self.values.len());
        for v in &self.values {
            for c in v.to_array() {
                out.extend_from_slice(&c.to_bits().to_le_bytes());
            }
        }
    }

    fn decode(bytes: &mut &[u8]) -> Result<Self, WireError> {
        let rays = u64::decode(bytes)?;
        let n = usize::try_from(u64::decode(bytes)?).unwrap_or(usize::MAX);
        let raw = take(bytes, n.saturating_mul(12), "path values")?;
        let word = |c: &[u8]| f32::from_bits(u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        let values = raw
            .chunks_exact(12)
            .map(|c| Vec3::new(word(&c[0..4]), word(&c[4..8]), word(&c[8..12])))
            .collect();
        Ok(Self { values, rays })
    }
}

/// On rank 0, another rank of the job as a path device: a launch's task ranges go to it in
/// one message and its values come back in one.
pub struct RankPaths<'c> {
    node: RemoteNode<'c, Range<usize>, PathOutput>,
    rank: usize,
}

impl<'c> RankPaths<'c> {
    /// Rank `rank` of `cluster`.
    pub fn new(cluster: &'c Cluster, rank: usize) -> Self {
        Self {
            node: RemoteNode::new(cluster, rank, 1.0),
            rank,
        }
    }
}

impl PathDevice for RankPaths<'_> {
    fn render(&mut self, _: &Frame<'_>, tasks: &[&Range<usize>]) -> Result<Launch, DeviceError> {
        let mut sink = Sink::new(tasks.len());
        self.node.run_batch(tasks, &mut sink)?;
        let mut values = Vec::new();
        let mut rays = 0u64;
        for out in sink.into_values() {
            rays += out.rays;
            values.extend(out.values);
        }
        let film_bytes = 12 * values.len() as u64;
        Ok(Launch {
            values,
            rays: usize::try_from(rays).unwrap_or(usize::MAX),
            traffic: Traffic {
                // The batch's ranges (two words each, and its length) out; one reply waited for.
                host_to_device_bytes: 8 + 16 * tasks.len() as u64,
                device_to_host_bytes: 0,
                host_waits: 1,
            },
            film_bytes,
            device_seconds: None,
        })
    }

    fn name(&self) -> String {
        format!("rank{}", self.rank)
    }

    /// Each rank is its own class: its speed is its devices', measured frame by frame.
    fn class(&self) -> String {
        self.name()
    }
}

/// On a rank other than 0: renders the task ranges rank 0 sends, with this rank's devices
/// (`renderer`, planned there by its own settings), until rank 0 ends the frame
/// ([`Cluster::finish`]). A batch whose devices all failed is answered with the error, so
/// rank 0 renders its paths elsewhere. Returns the batches served.
pub fn serve_paths(cluster: &Cluster, renderer: &mut PathRenderer<'_>, frame: &Frame<'_>) -> usize {
    cluster.serve(|tasks: Vec<Range<usize>>| {
        let (values, rays) = renderer
            .render_tasks(frame.scene, frame.bvh, frame.options, &tasks)
            .map_err(|e| DeviceError::msg(e.to_string()))?;
        // The rays of the batch go with its first task, so that their sum is the batch's.
        Ok(values
            .into_iter()
            .enumerate()
            .map(|(k, values)| PathOutput {
                values,
                rays: if k == 0 { rays as u64 } else { 0 },
            })
            .collect())
    })
}

/// Every rank takes part in what rank 0 renders with `devices` and `settings`: on rank 0 the
/// other ranks are path devices beside its own `devices`, and `on_root` renders with that
/// renderer (a frame, or a [`Run`](crate::run::Run)'s frames) and its result is returned;
/// every other rank renders the task ranges of `frame` it is sent on its `devices` until rank
/// 0 ends the frame, and gets `None`. Rank 0 ends the frame whatever happened to it, so that
/// no rank is left waiting.
///
/// # Errors
/// As [`PathRenderer::new`], and whatever `on_root` returns.
pub fn render_over_ranks<'a, T, E: From<SchedError>>(
    cluster: &'a Cluster,
    mut devices: Vec<Box<dyn PathDevice + 'a>>,
    settings: Settings,
    frame: &Frame<'_>,
    on_root: impl FnOnce(PathRenderer<'a>) -> Result<T, E>,
) -> Result<Option<T>, E> {
    if !cluster.is_root() {
        serve_paths(cluster, &mut PathRenderer::new(devices, settings)?, frame);
        return Ok(None);
    }
    for rank in 1..cluster.size() {
        devices.push(Box::new(RankPaths::new(cluster, rank)));
    }
    let rendered = PathRenderer::new(devices, settings)
        .map_err(E::from)
        .and_then(on_root);
    cluster.finish();
    rendered.map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_values_round_trip_bit_for_bit() {
        let out = PathOutput {
            values: vec![
                Vec3::new(0.25, -0.0, f32::from_bits(0x7fc0_0001)),
                Vec3::ONE,
            ],
            rays: 17,
        };
        let mut bytes = Vec::new();
        out.encode(&mut bytes);
        let back = PathOutput::decode(&mut &bytes[..]).expect("decodes");
        assert_eq!(back.rays, 17);
        let bits = |o: &PathOutput| -> Vec<[u32; 3]> {
            o.values
                .iter()
                .map(|v| v.to_array().map(f32::to_bits))
                .collect()
        };
        assert_eq!(bits(&back), bits(&out));
        assert!(PathOutput::decode(&mut &bytes[..bytes.len() - 1]).is_err());
    }
}
