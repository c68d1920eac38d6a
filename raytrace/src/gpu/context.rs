//! Which GPU adapters exist, which of them cobalt uses, and opening one as a device.
//!
//! Backends: those named by `WGPU_BACKEND` if it is set (tests pin `vulkan`), else Vulkan,
//! Metal and DX12 — never OpenGL unless asked for, since wgpu would otherwise fall back to it
//! silently where no Vulkan driver is installed; a name that is not a built-in backend is an
//! error naming the variable, not an empty search. Software adapters (device type `Cpu`, such
//! as Mesa's lavapipe) are used only when [`GpuOptions::allow_software`] is set (by
//! `COBALT_GPU_SOFTWARE=1`), by every GPU spec alike: `gpu:all` skips them, and `gpu:K` naming
//! one is an error. A silent software fallback would pass for a GPU in every timing.
//! Each device is opened with its adapter's own limits, not wgpu's defaults.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use crate::devices::GpuSelect;

use super::GpuError;

/// Which adapters may be used.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuOptions {
    /// Use software adapters (device type `Cpu`) for `gpu:all` too.
    pub allow_software: bool,
}

impl GpuOptions {
    /// Options from the environment: `COBALT_GPU_SOFTWARE=1` (or `true`) allows software
    /// adapters.
    pub fn from_env() -> Self {
        let allow_software = std::env::var("COBALT_GPU_SOFTWARE")
            .is_ok_and(|v| matches!(v.trim(), "1" | "true" | "yes"));
        Self { allow_software }
    }
}

/// The backends searched: `WGPU_BACKEND` if set, else Vulkan, Metal and DX12.
///
/// # Errors
/// [`GpuError::BadBackend`] when `WGPU_BACKEND` names anything but those three.
pub fn backends() -> Result<wgpu::Backends, GpuError> {
    match std::env::var("WGPU_BACKEND") {
        Ok(value) => parse_backends(&value),
        Err(_) => Ok(wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12),
    }
}

/// `WGPU_BACKEND`'s comma list, with wgpu's spellings of the backends cobalt is built with.
/// wgpu's own parser skips unknown names, which turns a typo into "no adapter".
fn parse_backends(value: &str) -> Result<wgpu::Backends, GpuError> {
    let mut backends = wgpu::Backends::empty();
    for item in value.split(',') {
        backends |= match item.trim().to_lowercase().as_str() {
            "vulkan" | "vk" => wgpu::Backends::VULKAN,
            "metal" | "mtl" => wgpu::Backends::METAL,
            "dx12" | "d3d12" => wgpu::Backends::DX12,
            _ => {
                return Err(GpuError::BadBackend {
                    value: value.to_string(),
                    item: item.trim().to_string(),
                });
            }
        };
    }
    Ok(backends)
}

fn allowed(options: GpuOptions, adapter: &wgpu::Adapter) -> bool {
    options.allow_software || adapter.get_info().device_type != wgpu::DeviceType::Cpu
}

fn instance(backends: wgpu::Backends) -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    wgpu::Instance::new(desc)
}

fn backend_names(b: wgpu::Backends) -> String {
    format!("{b:?}")
}

/// True when at least one adapter that [`GpuContext::open`] with `GpuSelect::All` would use
/// exists.
pub fn adapters_available(options: GpuOptions) -> bool {
    let Ok(b) = backends() else { return false };
    pollster::block_on(instance(b).enumerate_adapters(b))
        .iter()
        .any(|a| allowed(options, a))
}

/// One opened adapter: its device and queue, and what the kernels need to know about it.
/// Clones share the device and queue.
#[derive(Clone)]
pub struct GpuContext {
    /// Index of the adapter in wgpu's enumeration (the `K` of `gpu:K`).
    pub index: usize,
    /// The adapter's description (name, backend, device type, driver).
    pub info: wgpu::AdapterInfo,
    /// The device, with the adapter's own limits.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The limits the device was opened with.
    pub limits: wgpu::Limits,
    /// True when timestamp queries are enabled (per-launch GPU time).
    pub timestamps: bool,
    /// Which opening of a device in this process this is: clones share it.
    opening: u64,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("index", &self.index)
            .field("name", &self.info.name)
            .field("backend", &self.info.backend)
            .field("device_type", &self.info.device_type)
            .finish_non_exhaustive()
    }
}

impl GpuContext {
    /// Opens the adapters `select` names (see the module docs for which are used).
    ///
    /// # Errors
    /// [`GpuError::BadBackend`] for a bad `WGPU_BACKEND`, [`GpuError::NoAdapter`] when
    /// `gpu:all` finds none that may be used, [`GpuError::NoSuchAdapter`] for a `gpu:K` beyond
    /// the list, [`GpuError::SoftwareAdapter`] for a `gpu:K` that may not be used, and
    /// [`GpuError::RequestDevice`] when an adapter refuses to open.
    ///
    /// The adapters are opened once per process and selection: a later call returns clones
    /// sharing their devices. Opening them anew each time was not only slow: a driver may find
    /// no adapter any more after some dozens of opens in one process, and a long bench would
    /// then go on without the GPU.
    pub fn open(select: GpuSelect, options: GpuOptions) -> Result<Vec<Self>, GpuError> {
        type Opened = Vec<((GpuSelect, GpuOptions), Vec<GpuContext>)>;
        static OPENED: Mutex<Opened> = Mutex::new(Vec::new());
        // A panic while the lock was held left at worst a missing entry, never a bad one.
        let mut opened = OPENED.lock().unwrap_or_else(PoisonError::into_inner);
        let key = (select, options);
        if let Some((_, contexts)) = opened.iter().find(|(k, _)| *k == key) {
            return Ok(contexts.clone());
        }
        let contexts = Self::open_anew(select, options)?;
        opened.push((key, contexts.clone()));
        Ok(contexts)
    }

    /// [`GpuContext::open`] without the process's cache: a device of its own, which a test may
    /// lose without losing every other test's.
    pub(crate) fn open_anew(select: GpuSelect, options: GpuOptions) -> Result<Vec<Self>, GpuError> {
        let b = backends()?;
        let adapters = pollster::block_on(instance(b).enumerate_adapters(b));
        let chosen: Vec<(usize, &wgpu::Adapter)> = match select {
            GpuSelect::Index(index) => match adapters.get(index) {
                Some(a) if allowed(options, a) => vec![(index, a)],
                Some(a) => {
                    return Err(GpuError::SoftwareAdapter {
                        index,
                        name: a.get_info().name,
                    });
                }
                None => {
                    return Err(GpuError::NoSuchAdapter {
                        index,
                        count: adapters.len(),
                        backends: backend_names(b),
                    });
                }
            },
            GpuSelect::All => {
                let usable: Vec<_> = adapters
                    .iter()
                    .enumerate()
                    .filter(|(_, a)| allowed(options, a))
                    .collect();
                if usable.is_empty() {
                    let skipped = adapters.len();
                    return Err(GpuError::NoAdapter {
                        backends: backend_names(b),
                        skipped: if skipped > 0 {
                            format!(" ({skipped} software adapter(s) skipped)")
                        } else {
                            String::new()
                        },
                    });
                }
                usable
            }
        };
        chosen
            .into_iter()
            .map(|(index, adapter)| Self::from_adapter(index, adapter))
            .collect()
    }

    /// Opens `adapter` (number `index` of the enumeration) with its own limits, and timestamp
    /// queries where it has them.
    ///
    /// # Errors
    /// [`GpuError::RequestDevice`] when the adapter refuses.
    pub fn from_adapter(index: usize, adapter: &wgpu::Adapter) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let limits = adapter.limits();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let required_features = if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        };
        let label = format!("cobalt gpu{index} ({})", info.name);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some(&label),
            required_features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice {
            adapter: info.name.clone(),
            why: e.to_string(),
        })?;
        static OPENINGS: AtomicU64 = AtomicU64::new(0);
        Ok(Self {
            index,
            info,
            device,
            queue,
            limits,
            timestamps,
            opening: OPENINGS.fetch_add(1, Ordering::Relaxed),
        })
    }

    /// Whether `self` and `other` share one opened device (one is a clone of the other).
    pub fn same_device(&self, other: &Self) -> bool {
        self.opening == other.opening
    }

    /// The device's name in cobalt: `gpu{index}`.
    pub fn name(&self) -> String {
        format!("gpu{}", self.index)
    }
}

#[cfg(test)]
mod backend_tests {
    use super::*;

    #[test]
    fn backend_names_parse_and_typos_are_named() {
        assert_eq!(
            parse_backends("Vulkan, metal").unwrap(),
            wgpu::Backends::VULKAN | wgpu::Backends::METAL
        );
        for bad in ["vulcan", "vulkan,gl", "", "webgpu"] {
            let e = parse_backends(bad).unwrap_err();
            assert!(matches!(e, GpuError::BadBackend { .. }), "{bad}: {e}");
            assert!(e.to_string().contains("vulkan, metal, dx12"), "{e}");
        }
    }
}
