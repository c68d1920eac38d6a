//! The one place where a `--devices` list becomes path devices: CPU entries become
//! [`CpuPaths`], numbered in list order; GPU entries become [`super::GpuPaths`], one per
//! adapter (with the `gpu` feature).

use super::{CpuPaths, FailAfter, InjectedPaths, PathDevice, SlowBy};
use crate::devices::{DeviceSpec, GpuSelect};
use crate::{Bvh, Error, Result, Scene};

/// A GPU entry's devices, or why it found no adapter (`Err(why)`: skippable).
type GpuEntry<'a> = std::result::Result<Vec<Box<dyn PathDevice + 'a>>, String>;

/// The devices of `specs` for `scene` (with its `bvh`), with `faults` and `slow` injected
/// (each device with a fault or a slowdown made one [`InjectedPaths`]); the error names the
/// entry or fault at fault. The caller checks the indices of `slow`.
///
/// GPU entries open adapters (see [`crate::gpu::context`]) and upload the scene to each.
/// Where `gpu:all` finds no usable adapter but the list has other devices, a note says so
/// once on stderr and the others render alone; a list left with no device is an error.
pub fn build_path_devices<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    specs: &[DeviceSpec],
    faults: &[FailAfter],
    slow: &[SlowBy],
) -> Result<Vec<Box<dyn PathDevice + 'a>>> {
    let mut devices: Vec<Box<dyn PathDevice + 'a>> = Vec::new();
    let mut cpu_count = 0;
    let mut skipped_gpu = None;
    for spec in specs {
        match *spec {
            DeviceSpec::Cpu { count, threads } => {
                for cpu in CpuPaths::many(cpu_count, count, threads)? {
                    devices.push(Box::new(cpu));
                    cpu_count += 1;
                }
            }
            DeviceSpec::Gpu(select) => match gpu_devices(scene, bvh, select, spec)? {
                Ok(made) => devices.extend(made),
                Err(why) => skipped_gpu = Some((spec.to_string(), why)),
            },
        }
    }
    if let Some((arg, why)) = skipped_gpu {
        if devices.is_empty() {
            return Err(Error::DeviceArg { arg, why });
        }
        eprintln!("note: {arg}: {why}; rendering without a GPU");
    }
    let m = devices.len();
    if let Some(f) = faults.iter().find(|f| f.device >= m) {
        return Err(Error::DeviceArg {
            arg: format!("{}@{}", f.device, f.tasks),
            why: format!("no device {} to fail (there are {m})", f.device),
        });
    }
    Ok(InjectedPaths::wrap(devices, faults, slow))
}

/// The GPU devices of one entry, one `GpuPaths` per adapter: `Ok(Err(why))` when `gpu:all`
/// finds no adapter (skippable), `Err` naming the entry for anything else that fails.
#[cfg(feature = "gpu")]
fn gpu_devices<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    select: GpuSelect,
    spec: &DeviceSpec,
) -> Result<GpuEntry<'a>> {
    use crate::gpu::{GpuContext, GpuError, GpuOptions};
    let bad = |e: GpuError| Error::DeviceArg {
        arg: spec.to_string(),
        why: e.to_string(),
    };
    let contexts = match GpuContext::open(select, GpuOptions::from_env()) {
        Ok(c) => c,
        Err(e @ GpuError::NoAdapter { .. }) => return Ok(Err(e.to_string())),
        Err(e) => return Err(bad(e)),
    };
    let made = contexts
        .into_iter()
        .map(|ctx| Ok(Box::new(super::GpuPaths::new(ctx, scene, bvh)?) as Box<dyn PathDevice>))
        .collect::<std::result::Result<_, GpuError>>();
    Ok(Ok(made.map_err(bad)?))
}

/// Without the `gpu` feature, a GPU entry is an error naming it.
#[cfg(not(feature = "gpu"))]
fn gpu_devices<'a>(_: &Scene, _: &Bvh, _: GpuSelect, spec: &DeviceSpec) -> Result<GpuEntry<'a>> {
    Err(Error::DeviceArg {
        arg: spec.to_string(),
        why: String::from("this build has no GPU support (the `gpu` feature of raytrace)"),
    })
}
