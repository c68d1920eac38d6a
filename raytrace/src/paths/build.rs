//! The one place where a `--devices` list becomes path devices: CPU entries become
//! [`CpuPaths`], numbered in list order; GPU entries become [`super::GpuPaths`], one per
//! adapter (with the `gpu` feature).

use super::{CpuPaths, FailAfter, FailingPaths, PathDevice};
use crate::devices::DeviceSpec;
use crate::{Bvh, Error, Result, Scene};

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

/// The GPU devices of one entry, one `GpuPaths` per adapter (see [`open_gpus`]).
#[cfg(feature = "gpu")]
#[allow(clippy::type_complexity)] // two levels of failure: a skippable entry, and an error
fn gpu_devices<'a>(
    scene: &'a Scene,
    bvh: &'a Bvh,
    select: crate::devices::GpuSelect,
    spec: &DeviceSpec,
) -> Result<std::result::Result<Vec<Box<dyn PathDevice + 'a>>, String>> {
    open_gpus(select, spec, |ctx| {
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
    no_gpus(spec)
}

/// What becomes of a device list whatever the devices are: CPU entries made by `cpus(first,
/// count, threads)`, numbered in list order; GPU entries by `gpus`, which answers `Ok(Err(why))`
/// when an entry finds no adapter (skipped, with a note, unless nothing else is left); then
/// each device with a fault wrapped by `fail(device, tasks)`, the earliest of its faults.
fn assemble<D: ?Sized>(
    specs: &[DeviceSpec],
    faults: &[FailAfter],
    mut cpus: impl FnMut(usize, usize, usize) -> Result<Vec<Box<D>>>,
    mut gpus: impl FnMut(
        crate::devices::GpuSelect,
        &DeviceSpec,
    ) -> Result<std::result::Result<Vec<Box<D>>, String>>,
    fail: impl Fn(Box<D>, u64) -> Box<D>,
) -> Result<Vec<Box<D>>> {
    let mut devices: Vec<Box<D>> = Vec::new();
    let mut cpu_count = 0;
    let mut skipped_gpu = None;
    for spec in specs {
        match *spec {
            DeviceSpec::Cpu { count, threads } => {
                let made = cpus(cpu_count, count, threads)?;
                cpu_count += made.len();
                devices.extend(made);
            }
            DeviceSpec::Gpu(select) => match gpus(select, spec)? {
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
    Ok(devices
        .into_iter()
        .enumerate()
        .map(|(i, d)| {
            // The earliest of several faults on one device is the one that happens.
            let fault = faults
                .iter()
                .filter(|f| f.device == i)
                .map(|f| f.tasks)
                .min();
            match fault {
                Some(tasks) => fail(d, tasks),
                None => d,
            }
        })
        .collect())
}

/// Opens the adapters of one GPU entry and makes a device of each with `make`: `Ok(Err(why))`
/// when `gpu:all` finds no adapter (skippable), `Err` naming the entry for anything else that
/// fails.
#[cfg(feature = "gpu")]
fn open_gpus<D: ?Sized>(
    select: crate::devices::GpuSelect,
    spec: &DeviceSpec,
    make: impl FnMut(crate::gpu::GpuContext) -> std::result::Result<Box<D>, crate::gpu::GpuError>,
) -> Result<std::result::Result<Vec<Box<D>>, String>> {
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
    let out = contexts
        .into_iter()
        .map(make)
        .collect::<std::result::Result<_, _>>();
    Ok(Ok(out.map_err(bad)?))
}

/// Without the `gpu` feature, a GPU entry is an error naming it.
#[cfg(not(feature = "gpu"))]
fn no_gpus<D: ?Sized>(spec: &DeviceSpec) -> Result<std::result::Result<Vec<Box<D>>, String>> {
    Err(Error::DeviceArg {
        arg: spec.to_string(),
        why: String::from("this build has no GPU support (the `gpu` feature of raytrace)"),
    })
}
