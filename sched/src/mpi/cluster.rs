use std::fmt::Display;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use mpi::Count;
use mpi::collective::{CommunicatorCollectives, Root};
use mpi::datatype::PartitionMut;
use mpi::environment::{Threading, Universe};
use mpi::point_to_point::{Destination, MatchedReceiveVec, Source};
use mpi::topology::{Communicator, SimpleCommunicator};

use super::error::ClusterError;
use super::link::Link;

/// How long an idle rank sleeps between polls for a message. Open MPI's blocking receive
/// spins on a core; with ranks oversubscribed on one host (tests, CI) that spinning would
/// take the cores the tracing needs, and on a cluster 20 µs is small against a task.
const POLL: Duration = Duration::from_micros(20);

/// `MPI_COMM_WORLD`, made shareable between the runtime's device threads.
struct World(SimpleCommunicator);

// SAFETY: the handle names `MPI_COMM_WORLD`, valid on every thread of the process. `Cluster`
// only hands it out through a `Mutex`, so no two threads call MPI at once, which is what the
// `Threading::Serialized` level checked in `Cluster::init` allows.
unsafe impl Send for World {}

/// The ranks of an MPI job, each a node of one run. See the [module documentation](super).
///
/// Every MPI call goes through one lock, and the time spent in them is counted
/// ([`comm_seconds`](Cluster::comm_seconds)).
pub struct Cluster {
    // Dropped before the universe, which finalises MPI.
    world: Mutex<World>,
    _universe: Universe,
    rank: usize,
    size: usize,
    comm_nanos: AtomicU64,
    links: Mutex<Vec<Link>>,
}

impl Cluster {
    /// Initialises MPI. Under `mpirun` every rank calls it; run alone, the process is a
    /// cluster of one (rank 0 and nothing else).
    pub fn init() -> Result<Self, ClusterError> {
        let (universe, threading) =
            mpi::initialize_with_threading(Threading::Multiple).ok_or(ClusterError::Init)?;
        if threading < Threading::Serialized {
            return Err(ClusterError::Threading {
                got: format!("{threading:?}"),
            });
        }
        let world = universe.world();
        let rank = usize::try_from(world.rank()).unwrap_or(0);
        let size = usize::try_from(world.size()).unwrap_or(1).max(1);
        Ok(Self {
            world: Mutex::new(World(world)),
            _universe: universe,
            rank,
            size,
            comm_nanos: AtomicU64::new(0),
            links: Mutex::new(vec![Link::default(); size]),
        })
    }

    /// This process's rank, `0..size`.
    pub fn rank(&self) -> usize {
        self.rank
    }

    /// Ranks in the job.
    pub fn size(&self) -> usize {
        self.size
    }

    /// True on rank 0, which plans, serves the queue and writes results.
    pub fn is_root(&self) -> bool {
        self.rank == 0
    }

    /// Seconds this rank has spent inside MPI calls (waits between polls excluded).
    pub fn comm_seconds(&self) -> f64 {
        self.comm_nanos.load(Ordering::Relaxed) as f64 * 1e-9
    }

    /// On rank 0: what the dispatch to each rank cost so far (index = rank; rank 0's own
    /// entry stays empty).
    pub fn links(&self) -> Vec<Link> {
        self.links.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    pub(super) fn record_batch(&self, rank: usize, round_trip: f64, remote: f64) {
        let mut links = self.links.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(l) = links.get_mut(rank) {
            l.batches += 1;
            l.round_trip_seconds += round_trip;
            l.remote_seconds += remote;
        }
    }

    /// Runs `f` on the communicator under the lock, counting its time as communication.
    pub(super) fn with<R>(&self, f: impl FnOnce(&SimpleCommunicator) -> R) -> R {
        let world = self.lock();
        let start = Instant::now();
        let r = f(&world.0);
        self.comm_nanos
            .fetch_add(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
        r
    }

    fn lock(&self) -> MutexGuard<'_, World> {
        // MPI calls cannot panic half-way through a Rust invariant, so a poisoned lock still
        // guards a usable communicator.
        self.world.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Waits for a message from `from` (any tag when `tag` is `None`) and returns its tag and
    /// bytes, polling so that a waiting rank leaves the cores to the ones that work.
    pub(super) fn receive(&self, from: usize, tag: Option<i32>) -> (i32, Vec<u8>) {
        let from = from as i32;
        loop {
            let got = self.with(|w| {
                let p = w.process_at_rank(from);
                let probe = match tag {
                    Some(t) => p.immediate_matched_probe_with_tag(t),
                    None => p.immediate_matched_probe(),
                };
                probe.map(|m| {
                    let tag = m.1.tag();
                    (tag, m.matched_receive_vec::<u8>().0)
                })
            });
            if let Some(got) = got {
                return got;
            }
            std::thread::sleep(POLL);
        }
    }

    /// Sends `bytes` to rank `to` with `tag`.
    pub(super) fn send(&self, to: usize, tag: i32, bytes: &[u8]) {
        self.with(|w| w.process_at_rank(to as i32).send_with_tag(bytes, tag));
    }

    /// Every rank calls this at the same step with its own outcome; all of them get `Ok` only
    /// if every rank succeeded. Otherwise every rank gets the same error, naming each rank
    /// that failed and why, so the whole job can stop instead of some ranks waiting forever
    /// for the others, and whichever rank reports first reports everything.
    pub fn agree<T, E: Display>(&self, step: &str, local: Result<T, E>) -> Result<T, ClusterError> {
        // A flag byte, then the reason: never an empty buffer, whose dangling address (1 for
        // bytes) Open MPI would take for `MPI_IN_PLACE`.
        let mut mine = vec![u8::from(local.is_err())];
        if let Err(e) = &local {
            mine.extend_from_slice(e.to_string().as_bytes());
        }
        let reasons: Vec<(usize, String)> = self
            .all_gather_bytes(&mine)
            .into_iter()
            .enumerate()
            .filter(|(_, m)| m.first() == Some(&1))
            .map(|(rank, m)| {
                let why = String::from_utf8_lossy(&m[1..]).into_owned();
                let why = if why.is_empty() {
                    "(no message)".into()
                } else {
                    why
                };
                (rank, why)
            })
            .collect();
        match local {
            Ok(value) if reasons.is_empty() => Ok(value),
            _ => Err(ClusterError::Failed {
                step: step.to_string(),
                reasons,
            }),
        }
    }

    /// Every rank's `local` bytes, in rank order, on every rank.
    fn all_gather_bytes(&self, local: &[u8]) -> Vec<Vec<u8>> {
        let (counts, all) = self.all_gather_varcount(local);
        let mut at = 0;
        counts
            .iter()
            .map(|&c| {
                let part = all[at..at + c].to_vec();
                at += c;
                part
            })
            .collect()
    }

    /// Concatenates every rank's `local` values in rank order, on every rank (the slices may
    /// differ in length).
    pub fn all_gather_f64(&self, local: &[f64]) -> Vec<f64> {
        self.all_gather_varcount(local).1
    }

    /// Each rank's count and the concatenation of every rank's `local`, on every rank.
    fn all_gather_varcount<V>(&self, local: &[V]) -> (Vec<usize>, Vec<V>)
    where
        V: mpi::datatype::Equivalence + Default + Clone,
    {
        let n = Count::try_from(local.len()).unwrap_or(Count::MAX);
        let mut counts: Vec<Count> = vec![0; self.size];
        self.with(|w| w.all_gather_into(&n, &mut counts[..]));
        let displs: Vec<Count> = counts
            .iter()
            .scan(0, |acc, &c| {
                let d = *acc;
                *acc += c;
                Some(d)
            })
            .collect();
        let sizes: Vec<usize> = counts.iter().map(|&c| c as usize).collect();
        let mut all = vec![V::default(); sizes.iter().sum()];
        if all.is_empty() {
            // Nothing to move, and an empty buffer's address could read as `MPI_IN_PLACE`.
            return (sizes, all);
        }
        self.with(|w| {
            let mut part = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            w.all_gather_varcount_into(local, &mut part);
        });
        (sizes, all)
    }

    /// Rank 0's `bytes` on every rank (the others pass anything; it is replaced).
    pub fn broadcast(&self, bytes: &mut Vec<u8>) {
        let mut len = bytes.len() as u64;
        self.with(|w| w.process_at_rank(0).broadcast_into(&mut len));
        bytes.resize(len as usize, 0);
        if !bytes.is_empty() {
            self.with(|w| w.process_at_rank(0).broadcast_into(&mut bytes[..]));
        }
    }

    /// One-way latency from rank 0 to each rank, half the median of `rounds` blocking
    /// round trips of one byte (index = rank; 0 for rank 0, and on the other ranks an empty
    /// list). Every rank must call it.
    pub fn latency(&self, rounds: usize) -> Vec<f64> {
        const PING: i32 = 90;
        let rounds = rounds.max(1);
        let byte = [0u8; 1];
        if !self.is_root() {
            for _ in 0..rounds {
                self.with(|w| {
                    let p = w.process_at_rank(0);
                    let _ = p.receive_vec_with_tag::<u8>(PING);
                    p.send_with_tag(&byte[..], PING);
                });
            }
            return Vec::new();
        }
        let mut out = vec![0.0; self.size];
        for (rank, slot) in out.iter_mut().enumerate().skip(1) {
            let mut trips: Vec<f64> = (0..rounds)
                .map(|_| {
                    self.with(|w| {
                        let p = w.process_at_rank(rank as i32);
                        let start = Instant::now();
                        p.send_with_tag(&byte[..], PING);
                        let _ = p.receive_vec_with_tag::<u8>(PING);
                        start.elapsed().as_secs_f64()
                    })
                })
                .collect();
            trips.sort_by(f64::total_cmp);
            *slot = trips[trips.len() / 2] / 2.0;
        }
        out
    }
}

impl Cluster {
    /// True when this process was started by an MPI launcher (`mpirun`, `srun`, Hydra), whose
    /// environment names the job; a process started alone runs without MPI.
    pub fn launched() -> bool {
        ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
            .iter()
            .any(|v| std::env::var_os(v).is_some())
    }

    /// A barrier in which the other ranks sleep between polls instead of spinning: they call
    /// it at once and wait; rank 0 calls it when it is done with work it measures alone (with
    /// the cores to itself, where ranks share a host), which releases them. Every rank calls
    /// it once per hold.
    pub fn hold(&self) {
        if self.is_root() {
            self.finish();
        } else {
            let _: usize = self.serve(|_: Vec<u64>| -> Result<Vec<u64>, crate::DeviceError> {
                Err(crate::DeviceError::msg(
                    "no batch is expected while holding",
                ))
            });
        }
    }
}
