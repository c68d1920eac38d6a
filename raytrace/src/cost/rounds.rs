//! Steps timed in rounds, in turn, and the ratios between steps of one round: how an estimate
//! is timed against the trace it saves (`cobalt estimate`, and the bench's sampling trade).
//!
//! An overhead is a ratio of two steps, and a net overhead the difference of two nearly equal
//! ones. On a shared machine the speed of the whole machine moves between rounds, not only
//! within one (by as much as 1.6× from one round to the next, each side steady to 1 %). The least time of each step may then come from different sides,
//! and their difference measures the machine, not the estimate. Steps of one round run back
//! to back, at one speed; so each ratio is taken within a round (within a pair of rounds,
//! below), and the median reported.
//!
//! Within a round the speed moves too: two identical traces of Conference's AO rays (0.4 s
//! each), timed whole one after the other, came out 0.94 to 1.17 apart in the middle half of
//! twelve rounds. The trace and the rest, whose difference the net overhead is, are therefore
//! timed in slices taken in turn, a slice of one beside the other's slice half the batch away
//! (so that no step follows the same rays, whose nodes the last step left in the cache): cut
//! in sixteen, the same two traces came out 0.97 to 1.02 apart.
//!
//! The order of the sliced steps turns from one round to the next, and a step that follows
//! the other runs a little faster in the caches it left (two identical camera-ray traces, up
//! to 1.6 % apart by their order alone), which splits the rounds' shares into two heaps. So
//! each share is taken over a pair of rounds, one of each order, their times summed: per pair,
//! the mean of its two rounds' own shares weighted by their traces, and the order's part gone.

use std::ops::Range;

use crate::bvh::Bvh;
use crate::ray::RayBatch;
use crate::traverse;

/// How long a timing goes on: at least `repeats` rounds, more while the full trace has taken
/// less than `trace_seconds` in all (at most 128), and an even count (whole pairs).
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    repeats: usize,
    trace_seconds: f64,
}

impl Budget {
    /// `cobalt estimate`'s: at least `repeats` rounds and 1.5 s of trace. Five rounds of a
    /// 25 ms camera-ray trace put two identical traces up to 5 % apart by chance, as much as
    /// the whole net overhead they are to measure; twenty, within 1 %.
    /// A camera-ray round's own net overhead still moves by several percent (its estimate takes
    /// a millisecond or two): with half a second of trace, runs of one scene came out up to 2
    /// points apart, and a second and a half gives three times the pairs.
    pub fn estimate(repeats: usize) -> Self {
        Self {
            repeats,
            trace_seconds: 1.5,
        }
    }

    /// The bench's sampling trade: three rounds and half a second of trace for each of its
    /// points, eleven per ray kind and task size; `cobalt estimate`'s budget doubled the quick
    /// bench's run, to nearly four minutes.
    pub fn trade() -> Self {
        Self {
            repeats: 3,
            trace_seconds: 0.5,
        }
    }

    /// Whether a timing that has taken `rounds` rounds, `spent` seconds of them on the trace,
    /// takes another.
    fn another_round(self, rounds: usize, spent: f64) -> bool {
        rounds < self.repeats.max(1)
            || (spent < self.trace_seconds && rounds < MAX_ROUNDS)
            || rounds % 2 == 1
    }
}

/// Rounds at most, however short the trace.
const MAX_ROUNDS: usize = 128;

/// Rays a slice of the trace holds at least, and slices a round cuts it in at most. A slice is
/// a parallel pass of its own, whose start and end cost time: a 512×512 image's camera rays
/// (20 ms) in 8 slices took 5–8 % longer than whole, and their two identical traces came out
/// no closer (their noise is faster than a slice), so they stay whole; its AO rays (0.3–1.5 s)
/// take 16 slices of 20–90 ms.
const SLICE_RAYS: usize = 1 << 18;
const MAX_SLICES: usize = 16;

/// Slices to time a trace of `rays` rays in.
fn slice_count(rays: usize) -> usize {
    (rays / SLICE_RAYS).clamp(1, MAX_SLICES)
}

/// The full trace of one or more batches and the trace left after their samples (the rest),
/// each batch cut in the same number of slices: the two sliced steps of an estimate's rounds,
/// both in the wide tree's batch loop ([`traverse::hits_skipping_in`]).
pub struct SlicedTraces<'a> {
    bvh: &'a Bvh,
    parts: Vec<Part<'a>>,
    count: usize,
}

/// One batch of [`SlicedTraces`].
struct Part<'a> {
    batch: &'a RayBatch,
    /// Traced for any hits, else the closest.
    any: bool,
    /// The sampled rays, sorted indices into `batch`: what the rest skips.
    known: &'a [usize],
    slices: Vec<Range<usize>>,
}

impl<'a> SlicedTraces<'a> {
    /// The traces of `parts`, each a batch, whether it is traced for any hits and its sampled
    /// rays, cut in slices of all their rays (2^18 rays or more each, at most 16).
    pub fn new(
        bvh: &'a Bvh,
        parts: impl IntoIterator<Item = (&'a RayBatch, bool, &'a [usize])>,
    ) -> Self {
        let parts: Vec<_> = parts.into_iter().collect();
        let count = slice_count(parts.iter().map(|(batch, _, _)| batch.len()).sum());
        let parts = parts
            .into_iter()
            .map(|(batch, any, known)| Part {
                batch,
                any,
                known,
                slices: traverse::slices(batch.len(), count),
            })
            .collect();
        Self { bvh, parts, count }
    }

    /// Slices each batch is cut in (fewer for a batch of too few chunks).
    pub fn count(&self) -> usize {
        self.count
    }

    /// Slice `s` of every batch: its full trace, or with `rest` the trace left after its
    /// sample.
    pub fn run(&self, s: usize, rest: bool) {
        for part in &self.parts {
            let Some(range) = part.slices.get(s) else {
                continue;
            };
            let skip = if rest { part.known } else { &[] };
            std::hint::black_box(traverse::hits_skipping_in(
                self.bvh,
                part.batch,
                part.any,
                range.clone(),
                skip,
            ));
        }
    }
}

/// Every step's time in every round (`times[round][step]`; step 0 is the trace).
#[derive(Clone, Debug)]
pub struct Rounds {
    times: Vec<Vec<f64>>,
}

/// A step timed in slices: `run(s)` does slice `s` of `slices`; its error ends the timing.
pub type SlicedStep<'a, E> = &'a mut dyn FnMut(usize) -> Result<(), E>;

/// A step timed whole; its error ends the timing.
pub type WholeStep<'a, E> = &'a mut dyn FnMut() -> Result<(), E>;

impl Rounds {
    /// Times the `sliced` steps (the first is the trace) slice by slice and the `whole` ones
    /// in one go each, on `clock`, for as many rounds as `budget` gives. A round's times are
    /// the sliced steps' sums, then the whole steps'.
    ///
    /// In a round, slice `p` of the first sliced step runs beside slice `p + k·slices / m` of
    /// the `k`-th of the `m` sliced steps, their order turning with `p` and the round; the
    /// whole steps run halfway through (first, where there is one slice), so that a drift of
    /// the machine's speed across the round falls on them as on the sliced steps' middle.
    pub fn time<E>(
        budget: Budget,
        clock: sched::Clock,
        slices: usize,
        sliced: &mut [SlicedStep<'_, E>],
        whole: &mut [WholeStep<'_, E>],
    ) -> Result<Self, E> {
        let slices = slices.max(1);
        let m = sliced.len();
        let mut times = Vec::new();
        let mut spent = 0.0;
        while budget.another_round(times.len(), spent) {
            let mut round = vec![0.0; m + whole.len()];
            for p in 0..slices {
                if p == slices / 2 {
                    for (w, step) in whole.iter_mut().enumerate() {
                        let (seconds, done) = clock.time(&mut **step);
                        done?;
                        round[m + w] = seconds;
                    }
                }
                for j in 0..m {
                    let k = (j + p + times.len()) % m;
                    let slice = (p + k * slices / m) % slices;
                    let (seconds, done) = clock.time(|| sliced[k](slice));
                    done?;
                    round[k] += seconds;
                }
            }
            spent += round.first().copied().unwrap_or(0.0);
            times.push(round);
        }
        Ok(Self { times })
    }

    /// Rounds taken.
    #[allow(clippy::len_without_is_empty)] // a timing takes one round at least
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// The least time of step `step` over the rounds.
    pub fn least(&self, step: usize) -> f64 {
        self.times
            .iter()
            .map(|r| r[step])
            .fold(f64::INFINITY, f64::min)
    }

    /// The first quartile, the median and the third quartile over the pairs of rounds of
    /// `part(pair) / pair[0]`, each step's times summed over the pair: a share of the trace,
    /// each pair's steps against its own trace. The middle half tells how far the machine
    /// moved the median's parts.
    pub fn quartile_shares(&self, part: impl Fn(&[f64]) -> f64) -> [f64; 3] {
        let mut shares: Vec<f64> = self
            .times
            .chunks(2)
            .map(|pair| {
                let summed: Vec<f64> = (0..pair[0].len())
                    .map(|step| pair.iter().map(|r| r[step]).sum())
                    .collect();
                part(&summed) / summed[0].max(1e-12)
            })
            .collect();
        shares.sort_by(f64::total_cmp);
        [0.25, 0.5, 0.75].map(|p| quantile(&shares, p))
    }
}

/// The `p`-quantile of `sorted`, interpolated between neighbours (the median of an even count
/// is the mean of the middle two); NaN for none.
fn quantile(sorted: &[f64], p: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else {
        return f64::NAN;
    };
    let at = p * last as f64;
    let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
    sorted[lo] + (sorted[hi] - sorted[lo]) * (at - lo as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rounds(times: &[[f64; 3]]) -> Rounds {
        Rounds {
            times: times.iter().map(|r| r.to_vec()).collect(),
        }
    }

    /// The machine's speed changes between rounds: the least times pair a fast trace with a
    /// slow rest, the shares taken over each pair's own times do not.
    #[test]
    fn a_change_of_speed_between_rounds_leaves_the_shares_alone() {
        // (trace, rest, estimate): the rest is 0.97 of its round's trace and the estimate
        // 0.05, but in one round of the fast side the rest met a slow moment.
        let r = rounds(&[
            [66.0, 64.02, 3.3],
            [41.0, 50.0, 2.05],
            [41.5, 40.255, 2.075],
            [66.0, 64.02, 3.3],
            [65.0, 63.05, 3.25],
        ]);
        let net = r.quartile_shares(|t| t[2] + t[1] - t[0])[1];
        assert!((net - 0.02).abs() < 1e-9, "{net}");
        assert!((r.quartile_shares(|t| t[2])[1] - 0.05).abs() < 1e-9);
        // The least times pair the trace of one round with the rest of another.
        let least = (r.least(2) + r.least(1) - r.least(0)) / r.least(0);
        assert!((least - 0.0318).abs() < 1e-3, "{least}");
        assert_eq!((r.least(0), r.least(1), r.len()), (41.0, 40.255, 5));
    }

    /// The step that runs second gains 1 % from the first's caches, and the order turns each
    /// round: the rounds' own net overheads split into two heaps, a pair's do not.
    #[test]
    fn the_order_of_a_round_cancels_within_its_pair() {
        // (trace, rest, estimate), the rest 0.97 of the trace and the estimate 0.03: no net
        // overhead but for the order.
        let r = rounds(&[
            [100.0, 96.0, 3.0],
            [99.0, 97.0, 3.0],
            [100.0, 96.0, 3.0],
            [99.0, 97.0, 3.0],
        ]);
        let own: Vec<f64> = r
            .times
            .iter()
            .map(|t| (t[2] + t[1] - t[0]) / t[0])
            .collect();
        assert!(own[0] < -0.009 && own[1] > 0.01, "{own:?}");
        let [q1, net, q3] = r.quartile_shares(|t| t[2] + t[1] - t[0]);
        for q in [q1, net, q3] {
            assert!(q.abs() < 1e-12, "{q1} {net} {q3}");
        }
    }

    #[test]
    fn quantiles_of_odd_even_and_no_rounds() {
        assert_eq!(quantile(&[1.0, 2.0, 3.0], 0.5), 2.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.25), 2.0);
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.75), 4.0);
        assert_eq!(quantile(&[7.0], 0.25), 7.0);
        assert!(quantile(&[], 0.5).is_nan());
        // Pairs of shares 0.1 and 0.2, 0.3 and 0.1, then 0.2 alone: 0.15, 0.2, 0.2.
        let r = rounds(&[
            [10.0, 0.0, 1.0],
            [10.0, 0.0, 2.0],
            [10.0, 0.0, 3.0],
            [10.0, 0.0, 1.0],
            [10.0, 0.0, 2.0],
        ]);
        let q = r.quartile_shares(|t| t[2]);
        for (got, want) in q.into_iter().zip([0.175, 0.2, 0.2]) {
            assert!((got - want).abs() < 1e-12, "{q:?}");
        }
    }

    /// Every slice of every sliced step once a round, no step twice on the same slice in a
    /// row, the whole steps halfway, and each step's time its own.
    #[test]
    fn a_round_takes_each_slice_once_beside_the_other_steps_far_slice() {
        let log = std::cell::RefCell::new(Vec::new());
        let mut trace = |s: usize| -> Result<(), ()> {
            log.borrow_mut().push(format!("t{s}"));
            Ok(())
        };
        let mut rest = |s: usize| -> Result<(), ()> {
            log.borrow_mut().push(format!("r{s}"));
            Ok(())
        };
        let mut estimate = || -> Result<(), ()> {
            log.borrow_mut().push("e".into());
            Ok(())
        };
        let timed = Rounds::time(
            Budget::estimate(2),
            sched::Clock::Wall,
            4,
            &mut [&mut trace, &mut rest],
            &mut [&mut estimate],
        )
        .unwrap();
        assert!(timed.len() >= 2);
        let log = log.into_inner();
        let first: Vec<&str> = log[..9].iter().map(String::as_str).collect();
        assert_eq!(first, ["t0", "r2", "r3", "t1", "e", "t2", "r0", "r1", "t3"]);
        let second: Vec<&str> = log[9..18].iter().map(String::as_str).collect();
        assert_eq!(
            second,
            ["r2", "t0", "t1", "r3", "e", "r0", "t2", "t3", "r1"]
        );
        assert!(timed.times.iter().all(|r| r.len() == 3));
    }

    #[test]
    fn long_traces_are_cut_in_slices_of_a_quarter_million_rays_at_most_sixteen() {
        assert_eq!(slice_count(0), 1);
        assert_eq!(slice_count(512 * 512), 1);
        assert_eq!(slice_count(1920 * 1080), 7);
        assert_eq!(slice_count(512 * 512 * 32), 16);
    }

    #[test]
    fn rounds_go_on_while_the_trace_is_short() {
        let b = Budget::estimate(5);
        assert!(
            Budget::estimate(0).another_round(0, 10.0),
            "at least one round"
        );
        assert!(b.another_round(4, 10.0));
        assert!(b.another_round(5, 0.1));
        assert!(b.another_round(5, b.trace_seconds), "a whole pair");
        assert!(!b.another_round(6, b.trace_seconds));
        assert!(!b.another_round(MAX_ROUNDS, 0.0));
        assert!(!Budget::trade().another_round(4, 0.5));
    }
}
