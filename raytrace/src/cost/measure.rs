//! Measured trace time of each task: what estimates are finally judged against.
//!
//! Tasks are traced one after another on the calling thread, each by a single thread. That is
//! the cleanest measurement: no task shares a core or a cache with another, and no rayon
//! scheduling lands inside a timing. The query is the one the ray kind needs (closest hit
//! for primary and reflection rays, any hit for shadow and AO rays). Each task is timed
//! `repeats` times and the least time is kept, which filters out interruptions by other
//! processes and the cold first pass. [`sched::Clock::ProcessCpu`] times tasks on the CPU
//! time they used, which other processes on a shared machine disturb far less.

use std::hint::black_box;
use std::ops::Range;

use super::CostError;
use super::sample::check_tasks;
use crate::{Bvh, RayBatch, RayKind};

/// Seconds each task takes to trace on one thread; see the module docs.
pub fn measure_seconds(
    bvh: &Bvh,
    rays: &RayBatch,
    tasks: &[Range<usize>],
    kind: RayKind,
    repeats: usize,
    clock: sched::Clock,
) -> Result<Vec<f64>, CostError> {
    check_tasks(rays, tasks)?;
    let trace = |r: &Range<usize>| {
        let mut hits = 0u32;
        for i in r.clone() {
            let ray = rays.get(i);
            let hit = if kind.is_occlusion() {
                bvh.any_hit(&ray)
            } else {
                bvh.closest_hit(&ray)
            };
            hits += u32::from(black_box(hit).is_some());
        }
        black_box(hits);
    };
    Ok(tasks
        .iter()
        .map(|r| {
            (0..repeats.max(1))
                .map(|_| clock.time(|| trace(r)).0)
                .fold(f64::INFINITY, f64::min)
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildPreset, Camera, SceneNeeds, SceneSource};

    #[test]
    fn longer_tasks_take_longer_and_bad_tasks_are_errors() {
        let scene = SceneSource::parse("builtin:cornell:0.2")
            .and_then(|s| s.load(SceneNeeds::AO))
            .expect("builtin scene");
        let bvh = Bvh::build(&scene, BuildPreset::Fast).expect("bvh");
        let rays = Camera::orbit(&scene.bounds(), 0).primary_rays(64, 64).rays;
        let t = measure_seconds(
            &bvh,
            &rays,
            &[0..64, 0..4096],
            RayKind::Primary,
            3,
            sched::Clock::Wall,
        )
        .unwrap();
        assert!(t[0] > 0.0 && t[1] > t[0], "{t:?}");
        let err = measure_seconds(
            &bvh,
            &rays,
            &[0..1, 0..0],
            RayKind::Ao,
            1,
            sched::Clock::Wall,
        )
        .unwrap_err();
        assert_eq!(err, CostError::EmptyTask { task: 1 });
    }
}
