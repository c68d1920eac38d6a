use std::marker::PhantomData;
use std::time::Instant;

use super::cluster::Cluster;
use super::error::ClusterError;
use super::wire::{Wire, WireError};
use crate::{DeviceError, Executor, Sink, Task};

const TASKS: i32 = 1;
const OUTPUTS: i32 = 2;
const DONE: i32 = 3;

const OK: u8 = 0;
const FAILED: u8 = 1;

/// On rank 0, another rank as one device of a [`crate::Runtime`]: a batch is sent as tasks,
/// run there by [`Cluster::serve`] on that rank's own devices, and its outputs come back.
///
/// Tasks travel as values ([`Wire`]), so they should be small handles of data every rank
/// holds (ranges of a ray buffer that every rank built the same way).
pub struct RemoteNode<'c, T, O> {
    cluster: &'c Cluster,
    rank: usize,
    speed: f64,
    kind: PhantomData<fn(&T) -> O>,
}

impl<'c, T, O> RemoteNode<'c, T, O> {
    /// Rank `rank` of `cluster`, planned at relative `speed`.
    pub fn new(cluster: &'c Cluster, rank: usize, speed: f64) -> Self {
        Self {
            cluster,
            rank,
            speed,
            kind: PhantomData,
        }
    }
}

impl<T: Task + Wire + Clone, O: Wire + Send> Executor<T> for RemoteNode<'_, T, O> {
    type Output = O;

    fn run(&mut self, task: &T) -> Result<O, DeviceError> {
        let mut sink = Sink::new(1);
        self.run_batch(&[task], &mut sink)?;
        sink.into_values()
            .pop()
            .ok_or_else(|| DeviceError::msg(format!("rank {}: no output", self.rank)))
    }

    /// One message out, one back: a static plan pays the network once per node and round.
    fn run_batch(&mut self, tasks: &[&T], sink: &mut Sink<O>) -> Result<(), DeviceError> {
        let mut out = Vec::new();
        let owned: Vec<T> = tasks.iter().map(|&t| t.clone()).collect();
        owned.encode(&mut out);
        let start = Instant::now();
        self.cluster.send(self.rank, TASKS, &out);
        let (_, reply) = self.cluster.receive(self.rank, Some(OUTPUTS));
        let round_trip = start.elapsed().as_secs_f64();

        let wire = |e: WireError| {
            DeviceError::from(ClusterError::Wire {
                rank: self.rank,
                why: e.to_string(),
            })
        };
        let mut bytes = &reply[..];
        let status = super::wire::take(&mut bytes, 1, "a status byte").map_err(wire)?[0];
        if status != OK {
            let why = String::decode(&mut bytes).map_err(wire)?;
            self.cluster.record_batch(self.rank, round_trip, 0.0);
            return Err(DeviceError::msg(format!("rank {}: {why}", self.rank)));
        }
        let remote = f64::decode(&mut bytes).map_err(wire)?;
        let outputs = Vec::<O>::decode(&mut bytes).map_err(wire)?;
        self.cluster.record_batch(self.rank, round_trip, remote);
        if outputs.len() != tasks.len() {
            return Err(DeviceError::msg(format!(
                "rank {}: {} outputs for a batch of {}",
                self.rank,
                outputs.len(),
                tasks.len()
            )));
        }
        for o in outputs {
            sink.push(o);
        }
        Ok(())
    }

    /// The node's measured throughput relative to the others (the caller measures it).
    fn speed(&self) -> f64 {
        self.speed
    }

    fn name(&self) -> String {
        format!("rank{}", self.rank)
    }
}

impl Cluster {
    /// On a rank other than 0: runs the batches rank 0 sends with `run` (this node's own
    /// devices and local policy), replying with their outputs in order, until rank 0 calls
    /// [`Cluster::finish`]. Returns the number of batches run. A batch that cannot be read
    /// or fails is answered with its error, so rank 0 re-runs it on another node.
    pub fn serve<T, O, F>(&self, mut run: F) -> usize
    where
        T: Wire,
        O: Wire,
        F: FnMut(Vec<T>) -> Result<Vec<O>, DeviceError>,
    {
        let mut batches = 0;
        loop {
            let (tag, bytes) = self.receive(0, None);
            if tag == DONE {
                return batches;
            }
            batches += 1;
            let start = Instant::now();
            let result = Vec::<T>::decode(&mut &bytes[..])
                .map_err(|e| DeviceError::msg(format!("malformed batch from rank 0: {e}")))
                .and_then(&mut run);
            let mut reply = Vec::new();
            match result {
                Ok(outputs) => {
                    reply.push(OK);
                    start.elapsed().as_secs_f64().encode(&mut reply);
                    outputs.encode(&mut reply);
                }
                Err(e) => {
                    reply.push(FAILED);
                    e.to_string().encode(&mut reply);
                }
            }
            self.send(0, OUTPUTS, &reply);
        }
    }

    /// On rank 0: ends the round every other rank is serving.
    pub fn finish(&self) {
        for rank in 1..self.size() {
            self.send(rank, DONE, &[]);
        }
    }
}
