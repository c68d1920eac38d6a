//! The one place where a `--devices` list becomes devices: CPU entries become [`CpuDevice`]s,
//! numbered in list order; GPU entries are refused until the wgpu pipeline exists (issue 5).

use crate::cpu::CpuDevice;
use crate::devices::DeviceSpec;
use crate::{Bvh, Error, Result};

use super::RayDevice;

/// Fault injection: device `device` (index in the list) fails after `tasks` tasks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FailAfter {
    /// Index of the device, counting every device of the list in order.
    pub device: usize,
    /// Tasks it completes before failing.
    pub tasks: u64,
}

/// The devices of `specs`, with `faults` injected; the error names the entry or fault at fault.
pub fn build_devices<'a>(
    bvh: &'a Bvh,
    specs: &[DeviceSpec],
    faults: &[FailAfter],
) -> Result<Vec<Box<dyn RayDevice + 'a>>> {
    let mut devices: Vec<CpuDevice<'a>> = Vec::new();
    for spec in specs {
        match *spec {
            DeviceSpec::Cpu { count, threads } => {
                devices.extend(CpuDevice::many(bvh, devices.len(), count, threads)?);
            }
            DeviceSpec::Gpu(_) => {
                return Err(Error::DeviceArg {
                    arg: spec.to_string(),
                    why: String::from("the GPU pipeline is not built yet (issue 5)"),
                });
            }
        }
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
            match faults
                .iter()
                .filter(|f| f.device == i)
                .map(|f| f.tasks)
                .min()
            {
                Some(tasks) => d.failing_after(tasks),
                None => d,
            }
        })
        .map(|d| Box::new(d) as Box<dyn RayDevice + 'a>)
        .collect())
}
