//! The thread pools of CPU devices: each device renders in a pool of its own, so that its work
//! stays on its threads and a policy can balance devices against each other.

use crate::{Error, Result};

/// A pool of `threads` threads named `{label}-{i}`; failing to start one is
/// [`Error::ThreadPool`].
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
