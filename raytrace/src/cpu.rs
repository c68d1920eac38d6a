//! The CPU device: one independent worker of a `--devices cpu:N[/T]` list, tracing ranges of
//! a generation's rays on one thread or in a rayon pool of its own.
//!
//! `cpu:2` is two devices of one thread each, which a policy balances against each other as
//! the thesis balances a CPU against a GPU; `cpu:2/4` gives each of them four threads. A pool
//! is created once per device and kept for every generation: starting threads per generation
//! would cost more than tracing a small one.

use std::ops::Range;

use rayon::prelude::*;

pub use crate::ray_device::{BadRange, InjectedFault};
use sched::{DeviceError, Sink};

use crate::ray_device::RayDevice;
use crate::{Bvh, Error, HitBatch, RayBatch, RayKind, Result, traverse};

/// Rays per rayon job inside a pool: enough to amortise a steal, few enough that a 512-ray
/// task still spreads over several threads.
const CHUNK: usize = 64;

/// One CPU device. See the module documentation.
pub struct CpuDevice<'a> {
    bvh: &'a Bvh,
    index: usize,
    threads: usize,
    pool: Option<rayon::ThreadPool>,
    done: u64,
}

/// A pool of `threads` threads named `{label}-{i}`: a CPU device's own, so that its work
/// stays on its threads; failing to start one is [`Error::ThreadPool`].
pub(crate) fn thread_pool(label: String, threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |i| format!("{label}-{i}"))
        .build()
        .map_err(|e| Error::ThreadPool {
            threads,
            why: e.to_string(),
        })
}

impl<'a> CpuDevice<'a> {
    /// Device number `index` (named `cpu{index}`) with `threads` threads: one traces on the
    /// runtime's device thread itself, more start a pool of their own.
    pub fn new(bvh: &'a Bvh, index: usize, threads: usize) -> Result<Self> {
        let pool = if threads > 1 {
            Some(thread_pool(format!("cobalt-cpu{index}"), threads)?)
        } else {
            None
        };
        Ok(Self {
            bvh,
            index,
            threads: threads.max(1),
            pool,
            done: 0,
        })
    }

    /// `count` devices of `threads` threads, numbered from `first`.
    pub fn many(bvh: &'a Bvh, first: usize, count: usize, threads: usize) -> Result<Vec<Self>> {
        (first..first + count)
            .map(|i| Self::new(bvh, i, threads))
            .collect()
    }

    /// Threads that trace.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Tasks completed so far, over all generations.
    pub fn tasks_done(&self) -> u64 {
        self.done
    }

    fn check(&self, rays: &RayBatch, range: &Range<usize>) -> Result<(), DeviceError> {
        BadRange::check(|| self.name(), rays, range)?;
        Ok(())
    }

    /// Checks and traces one range but for the rays at `known`, in whatever thread or pool
    /// the caller is in.
    fn one(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        range: &Range<usize>,
        known: &[usize],
    ) -> Result<HitBatch, DeviceError> {
        self.check(rays, range)?;
        // Not `self.pool.is_some()`: `trace_ranges_with` takes the pool out of the device while
        // it runs the launch inside it, so that test read "no pool" and traced every launch on
        // one thread (a `cpu:1/16` device ran at one thread's speed on 16 cores).
        let hits = trace_range(self.bvh, kind, rays, range, known, self.threads > 1);
        self.done += 1;
        Ok(hits)
    }
}

impl RayDevice for CpuDevice<'_> {
    fn trace_range(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        range: &Range<usize>,
    ) -> Result<HitBatch, DeviceError> {
        self.trace_ranges_with(|this| this.one(kind, rays, range, &[]))
    }

    /// Enters the pool once for the whole launch: a static plan's launch is one `install`.
    fn trace_ranges(
        &mut self,
        kind: RayKind,
        rays: &RayBatch,
        ranges: &[&Range<usize>],
        known: &[usize],
        sink: &mut Sink<HitBatch>,
    ) -> Result<(), DeviceError> {
        self.trace_ranges_with(|this| {
            for range in ranges {
                sink.push(this.one(kind, rays, range, known)?);
            }
            Ok(())
        })
    }

    fn skips_known(&self) -> bool {
        true
    }

    fn name(&self) -> String {
        format!("cpu{}", self.index)
    }

    /// Free on one thread: the runtime's device thread traces the launch itself. Entering a
    /// pool hands the launch to other threads, a cost not measured here.
    fn launch_overhead(&self) -> Option<f64> {
        self.pool.is_none().then_some(0.0)
    }

    fn class(&self) -> String {
        format!("cpu/{}", self.threads())
    }
}

impl CpuDevice<'_> {
    /// Runs `f` inside this device's pool, if it has one.
    fn trace_ranges_with<R: Send>(&mut self, f: impl FnOnce(&mut Self) -> R + Send) -> R {
        // The pool is taken out for the call so `f` can borrow the device mutably; it is
        // put back whatever `f` returns (a panic retires the device anyway).
        match self.pool.take() {
            Some(pool) => {
                let out = pool.install(|| f(self));
                self.pool = Some(pool);
                out
            }
            None => f(self),
        }
    }
}

/// Traces `rays[range]` but for the rays at `known` (left as misses), each ray by itself (so
/// the result cannot depend on how rays were grouped), in parallel chunks when `parallel`
/// (inside a pool) or sequentially.
fn trace_range(
    bvh: &Bvh,
    kind: RayKind,
    rays: &RayBatch,
    range: &Range<usize>,
    known: &[usize],
    parallel: bool,
) -> HitBatch {
    let any = kind.is_occlusion();
    let fill = |first: usize, ts: &mut [f32], ps: &mut [u32]| {
        #[cfg(test)]
        tests::note_fill(ts.len());
        traverse::fill_skipping(bvh, rays, any, first, known, ts, ps);
    };
    let mut out = HitBatch::misses(range.len());
    if parallel {
        out.t
            .par_chunks_mut(CHUNK)
            .zip(out.prim.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (ts, ps))| fill(range.start + c * CHUNK, ts, ps));
    } else {
        fill(range.start, &mut out.t, &mut out.prim);
    }
    out
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;
    use crate::ray_device::RayDevice;
    use crate::{Camera, testkit};

    /// Every fill of hits on a pool thread, from every test in this process: the thread's
    /// name and the rays it filled.
    static FILLS: Mutex<Vec<(String, usize)>> = Mutex::new(Vec::new());

    pub(super) fn note_fill(rays: usize) {
        if let Some(name) = std::thread::current().name()
            && name.starts_with("cobalt-cpu")
            && let Ok(mut fills) = FILLS.lock()
        {
            fills.push((name.to_string(), rays));
        }
    }

    /// Rays at known indices stay misses, inside the range or not, on one thread or many;
    /// every other ray is traced as without them.
    #[test]
    fn known_rays_are_left_as_misses_and_the_rest_traced_as_ever() {
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
        let rays = Camera::orbit(&scene.bounds(), 0).primary_rays(64, 64).rays;
        let range = 100..3000;
        let known = [5, 100, 101, 517, 2999, 4000];
        for kind in [RayKind::Primary, RayKind::Shadow] {
            for parallel in [false, true] {
                let got = trace_range(&bvh, kind, &rays, &range, &known, parallel);
                let want = trace_range(&bvh, kind, &rays, &range, &[], parallel);
                for i in range.clone() {
                    let k = i - range.start;
                    if known.contains(&i) {
                        assert_eq!(got.get(k), None, "ray {i}");
                    } else {
                        assert_eq!(got.get(k), want.get(k), "ray {i}");
                    }
                }
                assert!((0..want.len()).filter(|&k| want.get(k).is_some()).count() > 100);
            }
        }
    }

    /// A device of two threads cuts a task into chunks that its pool's threads take (which
    /// of them takes how many is the scheduler's business, so not asserted), with the hits of
    /// a device of one thread.
    #[test]
    fn a_device_of_two_threads_traces_in_parallel_chunks() {
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
        let rays = Camera::orbit(&scene.bounds(), 0).primary_rays(64, 64).rays;
        let all = 0..rays.len();
        // An index no other test uses, so the thread names are this device's alone.
        let mut two = CpuDevice::new(&bvh, 9001, 2).expect("pool");
        let mut one = CpuDevice::new(&bvh, 9002, 1).expect("device");
        let hits = two
            .trace_range(RayKind::Primary, &rays, &all)
            .expect("trace");
        let want = one
            .trace_range(RayKind::Primary, &rays, &all)
            .expect("trace");
        assert_eq!(hits, want);
        let fills: Vec<usize> = FILLS
            .lock()
            .expect("lock")
            .iter()
            .filter(|(thread, _)| thread.starts_with("cobalt-cpu9001-"))
            .map(|&(_, rays)| rays)
            .collect();
        assert_eq!(fills.len(), rays.len().div_ceil(CHUNK), "{fills:?}");
        assert!(fills.iter().all(|&n| n <= CHUNK), "{fills:?}");
    }
}
