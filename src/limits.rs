//! Sizes given on the command line, checked before anything is allocated: what they would take
//! in memory against what the machine has (each count's own limit is its parser's, in
//! [`crate::args`]). A typo such as an extra zero then ends in an error naming the flag instead
//! of an abort or a swap storm.

use crate::error::CliError;

/// Threads a command starts for its CPU devices, in all: beyond this, the operating system
/// refuses threads before any speed is gained.
pub const MAX_THREADS: usize = 4096;

/// The memory that `parts` (item counts times bytes per item) add up to must fit in the
/// machine's available memory; the sum is computed with checked arithmetic, so a size that
/// wraps past 2^64 is refused rather than allocated short.
pub fn memory(flag: &'static str, value: &str, parts: &[(usize, u64)]) -> Result<(), CliError> {
    let bytes = parts.iter().try_fold(0u64, |sum, &(n, each)| {
        u64::try_from(n)
            .ok()
            .and_then(|n| n.checked_mul(each))
            .and_then(|b| sum.checked_add(b))
    });
    let available = available_memory();
    let fits = match (bytes, available) {
        (None, _) => false,
        (Some(b), Some(a)) => b <= a,
        (Some(b), None) => b <= u64::from(u32::MAX) * 16,
    };
    if fits {
        return Ok(());
    }
    let need = bytes.map_or("more than 2^64 bytes".to_string(), gib);
    let have = available.map_or(String::new(), |a| format!(", and {} is available", gib(a)));
    Err(CliError::Arg {
        flag,
        value: value.to_string(),
        message: format!("this needs about {need} of memory{have}; choose a smaller size"),
    })
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// Memory available to new allocations, where the system says (`MemAvailable` of
/// `/proc/meminfo` on Linux).
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}
