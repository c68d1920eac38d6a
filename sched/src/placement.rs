//! Keeping the device threads off the CPU of the thread that runs device 0.
//!
//! The calling thread runs device 0 and wakes the parked threads of the others. Linux tends to
//! wake a thread on the waker's CPU, where it then waits for the waker to stop: on a machine
//! with few CPUs, a second device can start only once the first has finished its share,
//! which serialises a run that was planned to be parallel (a balance near 0.5 for two
//! devices). Kept off the caller's CPU, it starts within microseconds.
//!
//! So before a run wakes them, the device threads are allowed every CPU the caller may use but
//! the one it is on, when there are CPUs enough for that (with more devices than CPUs the OS
//! shares them out as it likes); once running elsewhere, each allows itself them all again.
//! Elsewhere than on Linux this does nothing.

/// A thread's id for [`keep_off_caller`]; `None` where placement is not supported.
pub(crate) type ThreadId = Option<i32>;

/// The id of the calling thread.
pub(crate) fn this_thread() -> ThreadId {
    imp::this_thread()
}

/// Allows `threads` every CPU of the caller's but the one it runs on, if `devices` (the
/// caller's and theirs) fit the caller's CPUs, and returns the caller's CPUs, which each
/// thread gives itself back once it runs ([`allow_this_thread`]): what it starts, such as a
/// thread pool, then inherits them all. Returns `None` when it restricted nothing. Failures
/// are ignored: placement is a hint, and the run is correct without it.
pub(crate) fn keep_off_caller(threads: &[ThreadId], devices: usize) -> Option<Mask> {
    if threads.is_empty() {
        return None;
    }
    let all = imp::allowed()?;
    let cpu = imp::current_cpu().filter(|&c| devices <= all.count() && all.has(c))?;
    let mut others = all;
    others.clear(cpu);
    let mut any = false;
    for &t in threads {
        any |= imp::allow(t, &others);
    }
    any.then_some(all)
}

/// Allows the calling thread the CPUs of `mask`.
pub(crate) fn allow_this_thread(mask: &Mask) {
    imp::allow(this_thread(), mask);
}

/// A CPU mask: bit `c` of word `c / 64` for CPU `c`, laid out like the kernel's `cpu_set_t`
/// (1024 CPUs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Mask([u64; 16]);

impl Mask {
    fn has(&self, cpu: usize) -> bool {
        self.0
            .get(cpu / 64)
            .is_some_and(|w| w >> (cpu % 64) & 1 == 1)
    }

    fn clear(&mut self, cpu: usize) {
        if let Some(w) = self.0.get_mut(cpu / 64) {
            *w &= !(1 << (cpu % 64));
        }
    }

    fn count(&self) -> usize {
        self.0.iter().map(|w| w.count_ones() as usize).sum()
    }
}

#[cfg(target_os = "linux")]
mod imp {
    use super::{Mask, ThreadId};

    const _: () = assert!(size_of::<Mask>() == size_of::<libc::cpu_set_t>());

    pub(super) fn this_thread() -> ThreadId {
        // SAFETY: `gettid` has no preconditions and cannot fail.
        Some(unsafe { libc::gettid() })
    }

    pub(super) fn current_cpu() -> Option<usize> {
        // SAFETY: `sched_getcpu` has no preconditions; it returns -1 on failure.
        let cpu = unsafe { libc::sched_getcpu() };
        usize::try_from(cpu).ok()
    }

    /// The CPUs the calling thread may run on.
    pub(super) fn allowed() -> Option<Mask> {
        let mut mask = Mask([0; 16]);
        // SAFETY: the kernel writes at most `size_of::<Mask>()` bytes into `mask`, a plain
        // array of that size (the size of `cpu_set_t`, as asserted above).
        let ok = unsafe {
            libc::sched_getaffinity(
                0,
                size_of::<Mask>(),
                (&raw mut mask).cast::<libc::cpu_set_t>(),
            )
        } == 0;
        ok.then_some(mask)
    }

    /// Restricts thread `thread` to `mask`; false if it could not.
    pub(super) fn allow(thread: ThreadId, mask: &Mask) -> bool {
        let Some(tid) = thread else {
            return false;
        };
        // SAFETY: the kernel reads `size_of::<Mask>()` bytes from `mask`, which has that size.
        unsafe {
            libc::sched_setaffinity(
                tid,
                size_of::<Mask>(),
                (&raw const *mask).cast::<libc::cpu_set_t>(),
            ) == 0
        }
    }
}

#[cfg(not(target_os = "linux"))]
mod imp {
    use super::{Mask, ThreadId};

    pub(super) fn this_thread() -> ThreadId {
        None
    }

    pub(super) fn current_cpu() -> Option<usize> {
        None
    }

    pub(super) fn allowed() -> Option<Mask> {
        None
    }

    pub(super) fn allow(_: ThreadId, _: &Mask) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_count_and_clear_single_cpus() {
        let mut m = Mask([0; 16]);
        m.0[0] = 0b1011;
        m.0[15] = 1 << 63;
        assert_eq!(m.count(), 4);
        assert!(m.has(1) && !m.has(2) && m.has(1023) && !m.has(5000));
        m.clear(1);
        m.clear(5000);
        assert_eq!(m.count(), 3);
        assert!(!m.has(1));
    }

    /// A thread is allowed every CPU of the caller's but one while the devices fit them (and
    /// none is taken away when they do not), and gives itself all of them back.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_thread_is_kept_off_one_cpu_while_the_devices_fit_then_gets_all_back() {
        let Some(all) = imp::allowed() else {
            return;
        };
        let (id_tx, id_rx) = std::sync::mpsc::channel();
        let (tx, rx) = std::sync::mpsc::channel();
        let (go, wait) = std::sync::mpsc::channel::<Option<Mask>>();
        let worker = std::thread::spawn(move || {
            id_tx.send(this_thread()).ok();
            for restore in wait {
                let before = imp::allowed().map(|m| m.count());
                if let Some(m) = restore {
                    allow_this_thread(&m);
                }
                tx.send((before, imp::allowed().map(|m| m.count()))).ok();
            }
        });
        let tid = id_rx.recv().expect("the worker's id");
        let ask = |restore| {
            go.send(restore).expect("worker alive");
            rx.recv().expect("reply")
        };
        let restore = keep_off_caller(&[tid], 2);
        let n = all.count();
        if n >= 2 {
            assert_eq!(restore, Some(all));
            assert_eq!(ask(restore), (Some(n - 1), Some(n)));
        }
        assert_eq!(keep_off_caller(&[tid], n + 1), None);
        assert_eq!(ask(None), (Some(n), Some(n)));
        drop(go);
        worker.join().expect("worker ends");
    }
}
