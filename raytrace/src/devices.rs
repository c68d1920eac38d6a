//! The `--devices` list: which devices render, e.g. `cpu:2`, `cpu:2/4`, `cpu:14,gpu:all`.
//!
//! A CPU device is an independent worker with its own threads (one by default), so `cpu:2` is
//! two devices that a policy balances, as the thesis balances a CPU against a GPU.

use std::fmt;

use crate::{Error, Result};

/// Which GPU adapters to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuSelect {
    /// Every adapter found that may be used: hardware ones, and software ones where allowed
    /// (see `gpu::GpuOptions`).
    All,
    /// The adapter with this index in wgpu's enumeration.
    Index(usize),
}

/// One entry of a device list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceSpec {
    /// `cpu:N` or `cpu:N/T`: `count` CPU devices of `threads` threads each.
    Cpu {
        /// Number of devices.
        count: usize,
        /// Threads per device.
        threads: usize,
    },
    /// `gpu:all` or `gpu:K`.
    Gpu(GpuSelect),
}

impl fmt::Display for DeviceSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cpu { count, threads: 1 } => write!(f, "cpu:{count}"),
            Self::Cpu { count, threads } => write!(f, "cpu:{count}/{threads}"),
            Self::Gpu(GpuSelect::All) => write!(f, "gpu:all"),
            Self::Gpu(GpuSelect::Index(k)) => write!(f, "gpu:{k}"),
        }
    }
}

/// Parses a comma-separated device list; the error names the entry at fault.
pub fn parse_devices(arg: &str) -> Result<Vec<DeviceSpec>> {
    let bad = |entry: &str, why: &str| Error::DeviceArg {
        arg: entry.to_string(),
        why: why.to_string(),
    };
    let positive = |entry: &str, text: &str, what: &str| -> Result<usize> {
        match text.parse::<usize>() {
            Ok(n) if n > 0 => Ok(n),
            _ => Err(bad(
                entry,
                &format!("{what} must be a positive integer, not `{text}`"),
            )),
        }
    };
    let mut out = Vec::new();
    for entry in arg.split(',').map(str::trim) {
        let (kind, rest) = entry
            .split_once(':')
            .ok_or_else(|| bad(entry, "expected cpu:N, cpu:N/T, gpu:all or gpu:K"))?;
        let spec = match kind {
            "cpu" => {
                let (n, t) = rest.split_once('/').unwrap_or((rest, "1"));
                DeviceSpec::Cpu {
                    count: positive(entry, n, "the device count")?,
                    threads: positive(entry, t, "the thread count")?,
                }
            }
            "gpu" if rest == "all" => DeviceSpec::Gpu(GpuSelect::All),
            "gpu" => match rest.parse::<usize>() {
                Ok(k) => DeviceSpec::Gpu(GpuSelect::Index(k)),
                Err(_) => return Err(bad(entry, "expected gpu:all or gpu:K (an adapter index)")),
            },
            _ => {
                return Err(bad(
                    entry,
                    "the kind must be `cpu` or `gpu`: cpu:N, cpu:N/T, gpu:all or gpu:K",
                ));
            }
        };
        out.push(spec);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        assert_eq!(
            parse_devices("cpu:2").unwrap(),
            vec![DeviceSpec::Cpu {
                count: 2,
                threads: 1
            }]
        );
        let both = parse_devices("cpu:14/2, gpu:all").unwrap();
        assert_eq!(both[0].to_string(), "cpu:14/2");
        assert_eq!(both[1], DeviceSpec::Gpu(GpuSelect::All));
        assert_eq!(
            parse_devices("gpu:1").unwrap(),
            vec![DeviceSpec::Gpu(GpuSelect::Index(1))]
        );
        for (arg, needle) in [
            ("cpu", "expected"),
            ("cpu:0", "`0`"),
            ("cpu:2/x", "`x`"),
            ("tpu:1", "`cpu` or `gpu`"),
            ("gpu:first", "gpu:all"),
            ("cpu:2,", "expected"),
        ] {
            let e = parse_devices(arg).unwrap_err().to_string();
            assert!(e.contains(needle), "{arg}: {e}");
        }
    }
}
