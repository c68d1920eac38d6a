//! Where a walk reads its rays ([`Source`]): a batch's columns, or [`Record`]s, each ray's
//! eight floats in one block ([`records`]).

use rayon::prelude::*;

use crate::Ray;
use crate::ray::{RayBatch, Record};
#[cfg(target_arch = "x86_64")]
use crate::traverse::lanes::Lanes;

/// The rays of `rays` as records, in parallel, in this thread's kept buffer ([`SPARE`]).
pub(crate) fn records(rays: &RayBatch) -> Records {
    let n = rays.len();
    let mut out = SPARE.take();
    out.clear();
    out.reserve(n);
    out.spare_capacity_mut()[..n]
        .par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, part)| {
            #[cfg(target_arch = "x86_64")]
            if crate::traverse::simd::avx2() {
                // SAFETY: the CPU has AVX2, just checked.
                unsafe { crate::traverse::lanes::records(rays, c * CHUNK, part) };
                return;
            }
            for (j, to) in part.iter_mut().enumerate() {
                to.write(rays.record(c * CHUNK + j));
            }
        });
    // SAFETY: every record of `0..n` was written above.
    unsafe { out.set_len(n) };
    Records(out)
}

/// A batch's records ([`records`]); their buffer goes back to [`SPARE`] when dropped.
pub(crate) struct Records(Vec<Record>);

impl std::ops::Deref for Records {
    type Target = [Record];

    fn deref(&self) -> &[Record] {
        &self.0
    }
}

impl Drop for Records {
    fn drop(&mut self) {
        if self.0.capacity() <= SPARE_RECORDS {
            SPARE.set(std::mem::take(&mut self.0));
        }
    }
}

thread_local! {
    /// The records' buffer of the last batch this thread traced, kept for its next: a fresh
    /// one's pages are mapped and zeroed by the kernel as they are first written, two threads
    /// contending for the process's page tables (a small mesh's shuffled AO rays, two threads:
    /// 0.85-0.9x of the columns read in place with a fresh buffer each call, 1.02-1.11x with
    /// one kept).
    static SPARE: std::cell::Cell<Vec<Record>> = const { std::cell::Cell::new(Vec::new()) };
}

/// The most records [`SPARE`] keeps (64 MiB); a larger batch's buffer is freed, its tracing
/// long enough that a fresh buffer's pages weigh little.
const SPARE_RECORDS: usize = 1 << 21;

/// Records made a chunk at a time.
const CHUNK: usize = 1024;

/// Rays a walk reads by index.
pub(crate) trait Source {
    /// Ray `i`.
    fn ray(&self, i: usize) -> Ray;

    /// Ray `i`'s `tmin`.
    fn tmin(&self, i: usize) -> f32;

    /// Whether rays `i` and `j` start at the same point, bit for bit.
    fn same_origin(&self, i: usize, j: usize) -> bool;

    /// Lanes `0..idx.len()` become rays `idx[0], idx[1], …` (at most
    /// [`crate::traverse::lanes::PACKET`] of them).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    unsafe fn gather(&self, lanes: &mut Lanes, idx: &[usize]);
}

impl Source for RayBatch {
    fn ray(&self, i: usize) -> Ray {
        self.get(i)
    }

    fn tmin(&self, i: usize) -> f32 {
        self.tmin[i]
    }

    fn same_origin(&self, i: usize, j: usize) -> bool {
        RayBatch::same_origin(self, i, j)
    }

    #[cfg(target_arch = "x86_64")]
    unsafe fn gather(&self, lanes: &mut Lanes, idx: &[usize]) {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { lanes.gather(self, idx) }
    }
}

impl Source for [Record] {
    fn ray(&self, i: usize) -> Ray {
        let r = &self[i];
        Ray {
            origin: glam::Vec3::new(r[0], r[1], r[2]),
            dir: glam::Vec3::new(r[3], r[4], r[5]),
            tmin: r[6],
            tmax: r[7],
        }
    }

    fn tmin(&self, i: usize) -> f32 {
        self[i][6]
    }

    fn same_origin(&self, i: usize, j: usize) -> bool {
        let o = |k: usize| [self[k][0], self[k][1], self[k][2]].map(f32::to_bits);
        o(i) == o(j)
    }

    #[cfg(target_arch = "x86_64")]
    unsafe fn gather(&self, lanes: &mut Lanes, idx: &[usize]) {
        // SAFETY: as the caller states (see `# Safety`).
        unsafe { lanes.gather_records(self, idx) }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::records;
    use crate::{Ray, RayBatch};

    /// Records of batches of many lengths, one after another in the thread's kept buffer (a
    /// longer batch, then shorter ones): each ray's eight floats, bit for bit.
    #[test]
    fn records_hold_each_ray() {
        for len in [3001, 0, 17, 2048, 9] {
            let mut rays = RayBatch::default();
            for i in 0..len {
                let x = i as f32;
                rays.push(&Ray::with_range(
                    Vec3::new(x, -x, 0.5 * x),
                    Vec3::new(1.0, x, -2.0),
                    0.25 * x,
                    x + 1.0,
                ));
            }
            let got = records(&rays);
            assert_eq!(got.len(), len);
            for (i, r) in got.iter().enumerate() {
                assert_eq!(*r, rays.record(i), "ray {i} of {len}");
                assert_eq!(r[..3], rays.get(i).origin.to_array(), "ray {i} of {len}");
            }
        }
    }
}
