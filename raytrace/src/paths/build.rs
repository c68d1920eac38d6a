//! The one place where a `--devices` list becomes path devices: CPU entries become
//! [`CpuPaths`], numbered in list order; GPU entries become [`super::GpuPaths`], one per
//! adapter (with the `gpu` feature).

use super::{CpuPaths, FailingPaths, PathDevice};
use crate::devices::DeviceSpec;
use crate::scheduled::{FailAfter, assemble};
use crate::{Bvh, Result, Scene};

/// The devices of `specs` for `scene` (with its `bvh`), with `faults` injected; the error
/// names the entry or fault at fault.
///
/// GPU entries open adapters (see [`crate::gpu::context`]) and upload the scene to each.
/// Where `gpu:all` finds no usable adapter but the list has other devices, a note says so
/// once on stderr and the others render alone; a list left with no device is an error.
pub fn build_path_devices<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    specs: &[DeviceSpec],
    faults: &[FailAfter],
) -> Result<Vec<Box<dyn PathDevice + 'a>>> {
    assemble(
        specs,
        faults,
        |first, count, threads| {
            Ok(CpuPaths::many(first, count, threads)?
                .into_iter()
                .map(|cpu| Box::new(cpu) as Box<dyn PathDevice + 'a>)
                .collect())
        },
        |select, spec| gpu_devices(scene, bvh, select, spec),
        |d, tasks| Box::new(FailingPaths::new(d, tasks)),
    )
}

/// The GPU devices of one entry, one `GpuPaths` per adapter (see `scheduled::open_gpus`).
#[cfg(feature = "gpu")]
#[allow(clippy::type_complexity)] // the two levels of failure, as the ray devices have them
fn gpu_devices<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    select: crate::devices::GpuSelect,
    spec: &DeviceSpec,
) -> Result<std::result::Result<Vec<Box<dyn PathDevice + 'a>>, String>> {
    crate::scheduled::open_gpus(select, spec, |ctx| {
        Ok(Box::new(super::GpuPaths::new(ctx, scene, bvh)?) as Box<dyn PathDevice + 'a>)
    })
}

/// Without the `gpu` feature, GPU entries are refused.
#[cfg(not(feature = "gpu"))]
#[allow(clippy::type_complexity)]
fn gpu_devices<'a>(
    _: &'a Scene,
    _: &'a Bvh,
    _: crate::devices::GpuSelect,
    spec: &DeviceSpec,
) -> Result<std::result::Result<Vec<Box<dyn PathDevice + 'a>>, String>> {
    crate::scheduled::no_gpus(spec)
}
