//! Sizes given on the command line, checked before anything is allocated: what they would take
//! in memory against what the machine has (each count's own limit is its parser's, in
//! [`crate::args`]). A typo such as an extra zero then ends in an error naming the flag instead
//! of an abort or a swap storm.

use raytrace::SceneSource;

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

/// A frame of `size` (`pixels` in all), with `ao` (the flag and its count) probes a pixel where AO
/// renders it: the film, the rays of a generation and their hits (256 B a pixel), and AO's
/// probes, which a frame holds all at once (about 10 B each at the peak, measured).
pub fn frame(
    size: impl std::fmt::Display,
    pixels: usize,
    ao: Option<(&'static str, u32)>,
) -> Result<(), CliError> {
    memory("size", &size.to_string(), &[(pixels, 256)])?;
    let Some((flag, samples)) = ao else {
        return Ok(());
    };
    let probes = pixels.saturating_mul(samples as usize);
    memory(flag, &samples.to_string(), &[(pixels, 256), (probes, 16)])
}

/// Memory a scene takes per triangle, loaded with its BVH built (positions, indices, normals,
/// obvhs's boxes and build nodes, the flattened and the 8-wide trees): about 400 B measured
/// at its peak on the built-in scenes, with a margin.
const BYTES_PER_TRIANGLE: u64 = 512;

/// The `--scene` argument parsed, with a built-in scene's size at its detail checked against
/// the memory there is before it is generated: allocations inside the generator and obvhs's
/// build cannot fail cleanly, so they are sized here. (A file's scene is bounded by the file's
/// size limit.)
pub fn scene(arg: &str) -> Result<SceneSource, CliError> {
    let source = SceneSource::parse(arg)?;
    if let SceneSource::Builtin { kind, detail } = &source {
        let triangles = usize::try_from(kind.triangles_at(*detail)).unwrap_or(usize::MAX);
        memory("scene", arg, &[(triangles, BYTES_PER_TRIANGLE)])?;
    }
    Ok(source)
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
}

/// Memory available to new allocations: the lower of what the system has free (`MemAvailable`
/// of `/proc/meminfo` on Linux) and what this process's own limits leave it (`RLIMIT_AS`
/// less the address space already mapped, `RLIMIT_DATA` less the data already allocated), so
/// that a size refused under `ulimit -v` is refused here rather than aborting in an allocation.
fn available_memory() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok();
    let system = meminfo
        .as_deref()
        .and_then(|t| kib_field(t, "MemAvailable:"));
    let status = std::fs::read_to_string("/proc/self/status").ok();
    let used = |field| {
        status
            .as_deref()
            .and_then(|t| kib_field(t, field))
            .unwrap_or(0)
    };
    let room = |limit: Option<u64>, used: u64| limit.map(|l| l.saturating_sub(used));
    [
        system,
        room(rlimit(libc::RLIMIT_AS), used("VmSize:")),
        room(rlimit(libc::RLIMIT_DATA), used("VmData:")),
    ]
    .into_iter()
    .flatten()
    .min()
}

/// A `KEY: N kB` field of a `/proc` file, in bytes.
fn kib_field(text: &str, key: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The soft limit of `resource`, if there is one.
fn rlimit(resource: libc::__rlimit_resource_t) -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `limit` is a valid, writable `rlimit` for the call to fill in.
    if unsafe { libc::getrlimit(resource, &mut limit) } != 0
        || limit.rlim_cur == libc::RLIM_INFINITY
    {
        return None;
    }
    Some(limit.rlim_cur)
}
