//! A packet's rays by lane ([`Lanes`]), gathered from a batch's columns or from records (a
//! ray's eight floats in one block, made here by [`records`]), and the per-ray parts of their
//! box and triangle tests set up for all of them at once ([`Setup`]).
//!
//! Set up one ray at a time, a packet's rays cost six scalar divisions each, and the choice
//! of each ray's shear axes; for short AO rays that was a quarter of the whole trace. Here
//! every step is one AVX2 operation for eight lanes, the same IEEE operation as the scalar
//! set-up's ([`Box8Ray::new`], [`RayShear::new`]), so every lane's values equal the scalar
//! ones bit for bit (a test below checks it).
//!
//! [`Box8Ray::new`]: crate::traverse::simd::Box8Ray::new
//! [`RayShear::new`]: crate::triangle::RayShear::new

use std::arch::x86_64::{
    __m256, __m256i, _CMP_EQ_OQ, _CMP_GE_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _CMP_NEQ_OQ, _mm256_add_epi32,
    _mm256_and_ps, _mm256_and_si256, _mm256_andnot_ps, _mm256_blendv_ps, _mm256_castps_si256,
    _mm256_castsi256_ps, _mm256_cmp_ps, _mm256_cmpeq_epi32, _mm256_div_ps, _mm256_loadu_ps,
    _mm256_movemask_ps, _mm256_or_ps, _mm256_permutevar8x32_epi32, _mm256_set1_epi32,
    _mm256_set1_ps, _mm256_setr_epi32, _mm256_setzero_ps, _mm256_slli_epi32, _mm256_srai_epi32,
    _mm256_storeu_ps, _mm256_storeu_si256, _mm256_sub_epi32, _mm256_sub_ps,
};
use std::mem::MaybeUninit;

use crate::ray::{RayBatch, Record};
use crate::traverse::simd::{Box8Ray, Shear4, transpose8};

/// Rays walked together at most: one bit each in a node's masks
/// ([`crate::traverse::shared`]), one lane each of four AVX2 registers here.
pub(crate) const PACKET: usize = 32;

/// The groups of eight lanes of a packet: an AVX2 register's worth each.
pub(crate) const GROUPS: usize = PACKET / 8;

/// Up to [`PACKET`] rays, each field a row of lanes.
#[derive(Clone, Copy)]
pub(crate) struct Lanes {
    o: [[f32; PACKET]; 3],
    d: [[f32; PACKET]; 3],
    pub(crate) tmin: [f32; PACKET],
    pub(crate) tmax: [f32; PACKET],
}

impl Lanes {
    pub(crate) const ZERO: Self = Self {
        o: [[0.0; PACKET]; 3],
        d: [[0.0; PACKET]; 3],
        tmin: [0.0; PACKET],
        tmax: [0.0; PACKET],
    };

    /// Lanes `0..idx.len()` become rays `idx[0], idx[1], …` of `rays` (at most [`PACKET`] of
    /// them). A run of consecutive rays, the usual case, is copied a column at a time.
    ///
    /// Out of line: inlined into both of a caller's walks, it pushed the box test's kernels
    /// out of line there.
    ///
    /// # Panics
    /// Panics if an index is out of `rays`' bounds.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(crate) unsafe fn gather(&mut self, rays: &RayBatch, idx: &[usize]) {
        let n = idx.len().min(PACKET);
        let columns = self.rows().into_iter().zip(rays.columns());
        let first = idx.first().copied().unwrap_or(0);
        // Whether the rays are one run: every index compared, without stopping at the first
        // that differs, so that the comparison vectorises (a fifth of the copy's time as a
        // loop that could stop).
        let run = idx
            .iter()
            .enumerate()
            .fold(true, |run, (r, &i)| run & (i == first + r));
        // A whole packet's run: fixed-length copies, which compile to the vector loads and
        // stores that the set-up's loads then read whole.
        if n == PACKET && run {
            for (lanes, column) in columns {
                lanes.copy_from_slice(&column[first..first + PACKET]);
            }
        } else {
            for (lanes, column) in columns {
                for (lane, &i) in lanes.iter_mut().zip(idx) {
                    *lane = column[i];
                }
            }
        }
    }

    /// [`Lanes::gather`] from records: eight lanes at a time, one 8 × 8 transpose of the
    /// eight rays' blocks (a lane past `idx` repeats the first ray).
    ///
    /// # Panics
    /// Panics if an index is out of `records`' bounds.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(crate) unsafe fn gather_records(&mut self, records: &[Record], idx: &[usize]) {
        let n = idx.len().min(PACKET);
        if n == 0 {
            return;
        }
        for h in (0..n).step_by(8) {
            let mut rows = [_mm256_setzero_ps(); 8];
            for (k, row) in rows.iter_mut().enumerate() {
                let i = if h + k < n { idx[h + k] } else { idx[0] };
                // SAFETY: a record is eight readable floats.
                *row = unsafe { _mm256_loadu_ps(records[i].as_ptr()) };
            }
            for (row, lane) in self.rows().into_iter().zip(transpose8(rows)) {
                store(row, h, lane);
            }
        }
    }

    /// The ray in lane `r`.
    #[cfg(test)]
    pub(crate) fn ray(&self, r: usize) -> crate::ray::Ray {
        let r = r % PACKET;
        crate::ray::Ray {
            origin: glam::Vec3::new(self.o[0][r], self.o[1][r], self.o[2][r]),
            dir: glam::Vec3::new(self.d[0][r], self.d[1][r], self.d[2][r]),
            tmin: self.tmin[r],
            tmax: self.tmax[r],
        }
    }

    /// The first origin of each of `G` groups of `PACKET / G` lanes.
    #[inline(always)]
    pub(crate) fn group_origins<const G: usize>(&self) -> [[f32; 3]; G] {
        let step = PACKET / G;
        std::array::from_fn(|g| {
            [
                self.o[0][step * g],
                self.o[1][step * g],
                self.o[2][step * g],
            ]
        })
    }

    /// Every row of lanes, in the order of a record and of [`RayBatch::columns`].
    fn rows(&mut self) -> [&mut [f32; PACKET]; 8] {
        let [ox, oy, oz] = &mut self.o;
        let [dx, dy, dz] = &mut self.d;
        [ox, oy, oz, dx, dy, dz, &mut self.tmin, &mut self.tmax]
    }
}

/// Rays `first..first + out.len()` of `rays` as records, eight at a time by one 8 × 8
/// transpose of the eight columns.
///
/// # Panics
/// Panics if the rays are out of `rays`' bounds.
///
/// # Safety
/// The CPU must have AVX2.
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn records(rays: &RayBatch, first: usize, out: &mut [MaybeUninit<Record>]) {
    let columns = rays.columns();
    let whole = out.len() / 8 * 8;
    for h in (0..whole).step_by(8) {
        let mut rows = [_mm256_setzero_ps(); 8];
        for (row, column) in rows.iter_mut().zip(columns) {
            let at = &column[first + h..first + h + 8];
            // SAFETY: `at` is eight readable floats.
            *row = unsafe { _mm256_loadu_ps(at.as_ptr()) };
        }
        for (to, record) in out[h..h + 8].iter_mut().zip(transpose8(rows)) {
            // SAFETY: a record is eight writable floats.
            unsafe { _mm256_storeu_ps(to.as_mut_ptr().cast(), record) };
        }
    }
    for (j, to) in out.iter_mut().enumerate().skip(whole) {
        to.write(rays.record(first + j));
    }
}

/// The per-ray parts of the box test ([`Box8Ray`]) and of the triangle test ([`Shear4`]) of
/// every lane, by lane, and the lanes that trace at all.
pub(crate) struct Setup {
    /// Each ray's part of the box test, laid out as the test reads it at every node the ray
    /// enters.
    boxes: [Box8Ray; PACKET],
    /// The shear's origin along `kx`, `ky`, `kz`, those axes, and `sx`, `sy`, `sz`.
    shear_org: [[f32; PACKET]; 3],
    axis: [[u32; PACKET]; 3],
    shear: [[f32; PACKET]; 3],
    /// A bit per lane among the first `n` whose ray [`RayShear::new`] accepts and whose range
    /// is not empty or NaN: the rays the single walk traces at all.
    ///
    /// [`RayShear::new`]: crate::triangle::RayShear::new
    pub(crate) valid: u32,
    /// Whether the first `n` lanes each start where the first lane of their group of eight
    /// does, bit for bit ([`Lanes::group_origins`] of [`GROUPS`]).
    pub(crate) one_origin: bool,
    /// Whether the first `n` lanes each start where the first lane of their four does, bit
    /// for bit ([`Lanes::group_origins`] of eight fours).
    pub(crate) quad_origin: bool,
}

impl Setup {
    /// A set-up to fill with [`Setup::set`].
    pub(crate) const ZERO: Self = Setup {
        boxes: [Box8Ray::ZERO; PACKET],
        shear_org: [[0.0; PACKET]; 3],
        axis: [[0; PACKET]; 3],
        shear: [[0.0; PACKET]; 3],
        valid: 0,
        one_origin: false,
        quad_origin: false,
    };

    /// Becomes the set-up of the first `n` lanes of `l`, every lane overwritten: one set-up
    /// serves packet after packet, not cleared and copied out for each.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(crate) unsafe fn set(&mut self, l: &Lanes, n: usize) {
        // No closures here: they would not be compiled for AVX2, and the intrinsics in them
        // would not inline.
        let s = self;
        s.valid = 0;
        // The lanes that start where their group's first lane does, and where the first lane
        // of their four does.
        let (mut same, mut same4) = (0u32, 0u32);
        // Eight lanes a step.
        for h in (0..PACKET).step_by(8) {
            let o = [load(&l.o[0], h), load(&l.o[1], h), load(&l.o[2], h)];
            let d = [load(&l.d[0], h), load(&l.d[1], h), load(&l.d[2], h)];
            let zero = _mm256_setzero_ps();
            let one = _mm256_set1_ps(1.0);
            let ones = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
            // The box test: `1 / d`, and the near plane the max row where `d`'s sign bit is set,
            // each row as the test reads it, where it starts (eight floats a row).
            let (mut inv, mut near, mut far) = ([zero; 3], [zero; 3], [zero; 3]);
            for (a, &da) in d.iter().enumerate() {
                let neg = _mm256_and_si256(
                    _mm256_srai_epi32::<31>(_mm256_castps_si256(da)),
                    _mm256_set1_epi32(3),
                );
                let row = _mm256_set1_epi32(a as i32);
                inv[a] = _mm256_div_ps(one, da);
                let n = _mm256_add_epi32(row, neg);
                near[a] = _mm256_castsi256_ps(_mm256_slli_epi32::<3>(n));
                let f = _mm256_sub_epi32(_mm256_add_epi32(row, _mm256_set1_epi32(3)), neg);
                far[a] = _mm256_castsi256_ps(_mm256_slli_epi32::<3>(f));
            }
            let boxes: &mut [Box8Ray; 8] = (&mut s.boxes[h..h + 8]).try_into().expect("8 lanes");
            // SAFETY: this function runs on AVX2 (see `# Safety`).
            unsafe { Box8Ray::set8(boxes, o, inv, near, far) };
            // The shear: the dominant axis `kz` (x on a tie with y or z, then y on a tie with z),
            // `kx` and `ky` the next two, swapped where `d[kz] < 0`, as `RayShear::new` picks them.
            let sign = _mm256_set1_ps(-0.0);
            let (ax, ay, az) = (
                _mm256_andnot_ps(sign, d[0]),
                _mm256_andnot_ps(sign, d[1]),
                _mm256_andnot_ps(sign, d[2]),
            );
            let x_wins = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(ax, ay),
                _mm256_cmp_ps::<_CMP_GE_OQ>(ax, az),
            );
            let y_wins = _mm256_cmp_ps::<_CMP_GE_OQ>(ay, az);
            let k = Pick {
                y: _mm256_andnot_ps(x_wins, y_wins),
                z: _mm256_andnot_ps(x_wins, _mm256_andnot_ps(y_wins, ones)),
                swap: zero,
            };
            let dz = k.of(d[0], d[1], d[2]);
            let k = Pick {
                swap: _mm256_cmp_ps::<_CMP_LT_OQ>(dz, zero),
                ..k
            };
            let (dx, dy) = k.next(d);
            let (ox, oy) = k.next(o);
            let axes = [int(0), int(1), int(2)];
            let (kx, ky) = k.next(axes);
            store(&mut s.shear_org[0], h, ox);
            store(&mut s.shear_org[1], h, oy);
            store(&mut s.shear_org[2], h, k.of(o[0], o[1], o[2]));
            store(&mut s.shear[0], h, _mm256_div_ps(dx, dz));
            store(&mut s.shear[1], h, _mm256_div_ps(dy, dz));
            store(&mut s.shear[2], h, _mm256_div_ps(one, dz));
            store_i(&mut s.axis[0], h, _mm256_castps_si256(kx));
            store_i(&mut s.axis[1], h, _mm256_castps_si256(ky));
            store_i(
                &mut s.axis[2],
                h,
                _mm256_castps_si256(k.of(axes[0], axes[1], axes[2])),
            );
            let ok = traced(&o, &d, load(&l.tmin, h), load(&l.tmax, h));
            s.valid |= (_mm256_movemask_ps(ok) as u32) << h;
            let mut at = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
            let mut at4 = at;
            for (a, &oa) in o.iter().enumerate() {
                let oa = _mm256_castps_si256(oa);
                let first = _mm256_set1_epi32(l.o[a][h].to_bits() as i32);
                let equal = _mm256_cmpeq_epi32(oa, first);
                at = _mm256_and_ps(at, _mm256_castsi256_ps(equal));
                // Each lane against the first of its four.
                let first4 =
                    _mm256_permutevar8x32_epi32(oa, _mm256_setr_epi32(0, 0, 0, 0, 4, 4, 4, 4));
                let equal4 = _mm256_cmpeq_epi32(oa, first4);
                at4 = _mm256_and_ps(at4, _mm256_castsi256_ps(equal4));
            }
            same |= (_mm256_movemask_ps(at) as u32) << h;
            same4 |= (_mm256_movemask_ps(at4) as u32) << h;
        }
        let first_n = ((1u64 << n.min(PACKET)) - 1) as u32;
        s.valid &= first_n;
        s.one_origin = same & first_n == first_n;
        s.quad_origin = same4 & first_n == first_n;
    }

    /// Each lane's part of the box test; meaningful where its `valid` bit is set.
    #[inline(always)]
    pub(crate) fn boxes(&self) -> &[Box8Ray; PACKET] {
        &self.boxes
    }

    /// Lane `r`'s part of the triangle test; meaningful where its `valid` bit is set.
    #[inline(always)]
    pub(crate) fn shear(&self, r: usize) -> Shear4 {
        let r = r % PACKET;
        Shear4::from_parts(
            [
                self.shear_org[0][r],
                self.shear_org[1][r],
                self.shear_org[2][r],
            ],
            [self.axis[0][r], self.axis[1][r], self.axis[2][r]],
            [self.shear[0][r], self.shear[1][r], self.shear[2][r]],
        )
    }
}

/// All ones in the lanes whose ray the single walk traces at all (those `RayShear::new`
/// accepts, with a range that is not empty or NaN): finite origin and direction (`x - x == 0`
/// is false for NaN and infinities), a direction that is not zero, and `tmin <= tmax` (false
/// on NaN).
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn traced(o: &[__m256; 3], d: &[__m256; 3], tmin: __m256, tmax: __m256) -> __m256 {
    let zero = _mm256_setzero_ps();
    let mut nonzero = zero;
    let mut ok = _mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax);
    for a in 0..3 {
        nonzero = _mm256_or_ps(nonzero, _mm256_cmp_ps::<_CMP_NEQ_OQ>(d[a], zero));
        for v in [o[a], d[a]] {
            ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_EQ_OQ>(_mm256_sub_ps(v, v), zero));
        }
    }
    _mm256_and_ps(ok, nonzero)
}

/// Lane-wise choice among three rows by the dominant axis.
#[derive(Clone, Copy)]
struct Pick {
    /// All ones where the dominant axis is y, and where it is z (else x).
    y: __m256,
    z: __m256,
    /// All ones where the next two axes swap.
    swap: __m256,
}

impl Pick {
    /// `[v0, v1, v2][kz]`, lane by lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn of(&self, v0: __m256, v1: __m256, v2: __m256) -> __m256 {
        _mm256_blendv_ps(_mm256_blendv_ps(v0, v1, self.y), v2, self.z)
    }

    /// `(v[kx], v[ky])`, lane by lane: the two axes after `kz`, swapped where `swap` is set.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn next(&self, v: [__m256; 3]) -> (__m256, __m256) {
        let x = self.of(v[1], v[2], v[0]);
        let y = self.of(v[2], v[0], v[1]);
        (
            _mm256_blendv_ps(x, y, self.swap),
            _mm256_blendv_ps(y, x, self.swap),
        )
    }
}

/// The integer `k` in every lane, as floats' bits.
#[target_feature(enable = "avx2")]
#[inline]
fn int(k: i32) -> __m256 {
    _mm256_castsi256_ps(_mm256_set1_epi32(k))
}

/// Eight lanes from a row.
#[target_feature(enable = "avx2")]
#[inline]
fn load(a: &[f32; PACKET], h: usize) -> __m256 {
    // SAFETY: lanes `h..h + 8` of `a` are readable (the callers step `h` by eight).
    unsafe { _mm256_loadu_ps(a[h..h + 8].as_ptr()) }
}

/// Eight lanes into a row.
#[target_feature(enable = "avx2")]
#[inline]
fn store(out: &mut [f32; PACKET], h: usize, v: __m256) {
    // SAFETY: lanes `h..h + 8` of `out` are writable.
    unsafe { _mm256_storeu_ps(out[h..h + 8].as_mut_ptr(), v) }
}

/// Eight integer lanes into a row.
#[target_feature(enable = "avx2")]
#[inline]
fn store_i(out: &mut [u32; PACKET], h: usize, v: __m256i) {
    // SAFETY: lanes `h..h + 8` of `out` are writable.
    unsafe { _mm256_storeu_si256(out[h..h + 8].as_mut_ptr().cast(), v) }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::triangle::RayShear;
    use crate::{Ray, Rng, testkit};

    /// Every lane's set-up equals the scalar one bit for bit, and a lane is valid exactly where
    /// the single walk traces its ray: random rays, and rays with zero, negative-zero, tied,
    /// infinite and NaN components, and empty and NaN ranges, in packets of one to [`PACKET`].
    #[test]
    fn lanes_set_up_as_each_ray_alone() {
        let mut rng = Rng::new(testkit::seed(41));
        let odd = [0.0, -0.0, 1.0, -1.0, f32::INFINITY, f32::NAN, 1e-30, -3e30];
        let any = |rng: &mut Rng| {
            if rng.below(4) == 0 {
                odd[rng.below(odd.len() as u32) as usize]
            } else {
                rng.range(-2.0, 2.0)
            }
        };
        let mut rays = RayBatch::default();
        for _ in 0..4003 {
            let o = Vec3::new(any(&mut rng), any(&mut rng), any(&mut rng));
            let mut d = Vec3::new(any(&mut rng), any(&mut rng), any(&mut rng));
            if rng.below(5) == 0 {
                // Ties between the dominant axes.
                d = Vec3::new(d.x, d.x.abs() * [1.0, -1.0][rng.below(2) as usize], d.z);
            }
            let (a, b) = (any(&mut rng), any(&mut rng));
            rays.push(&Ray::with_range(
                o,
                d,
                a.min(b),
                if rng.below(6) == 0 { a } else { a.max(b) },
            ));
        }
        // Records made eight at a time by transposes, from starts that are not a multiple of
        // eight and with tails that are not a whole eight.
        if !crate::traverse::simd::avx2() {
            return;
        }
        let mut records = vec![MaybeUninit::<Record>::uninit(); rays.len()];
        for (first, end) in [(0, 1000), (1000, 1003), (1003, 2995), (2995, rays.len())] {
            // SAFETY: the CPU has AVX2, just checked.
            unsafe { super::records(&rays, first, &mut records[first..end]) };
        }
        // SAFETY: the four ranges above cover every record, and each was written.
        let records: Vec<Record> = records
            .into_iter()
            .map(|r| unsafe { r.assume_init() })
            .collect();
        let mut valid = 0;
        for (k, first) in (0..rays.len()).step_by(7).enumerate() {
            // Whole packets and shorter ones, their rays in order (a whole packet's are
            // copied as a run) or reversed (gathered ray by ray).
            let n = if k % 3 == 0 {
                PACKET
            } else {
                1 + first % PACKET
            };
            let n = n.min(rays.len() - first);
            let mut lanes = Lanes::ZERO;
            let idx: Vec<usize> = if k % 2 == 0 {
                (first..first + n).collect()
            } else {
                (first..first + n).rev().collect()
            };
            // SAFETY: the CPU has AVX2, checked above.
            unsafe { lanes.gather(&rays, &idx) };
            // The same rays gathered from their records, bit for bit.
            let mut from_records = Lanes::ZERO;
            // SAFETY: the CPU has AVX2, checked above.
            unsafe { from_records.gather_records(&records, &idx) };
            for (r, &i) in idx.iter().enumerate() {
                assert_eq!(
                    records[i].map(f32::to_bits),
                    record_bits(&rays.get(i)),
                    "ray {i}"
                );
                let bits = |l: &Lanes| record_bits(&l.ray(r));
                assert_eq!(bits(&from_records), bits(&lanes), "lane {r} of {idx:?}");
            }
            if k % 4 == 1 || k % 4 == 3 {
                // Groups of eight (or four) of one origin each, one lane moved by a unit in
                // the last place in half of them.
                let group = if k % 4 == 1 { 8 } else { 4 };
                for r in 0..n {
                    for a in 0..3 {
                        lanes.o[a][r] = lanes.o[a][r - r % group];
                    }
                }
                if k % 8 == 5 || k % 8 == 7 {
                    let r = n - 1;
                    lanes.o[1][r] = f32::from_bits(lanes.o[1][r].to_bits() ^ 1);
                }
            }
            let from = |lanes: &Lanes, group: usize| {
                (0..n).all(|r| {
                    (0..3).all(|a| lanes.o[a][r].to_bits() == lanes.o[a][r - r % group].to_bits())
                })
            };
            let (one_origin, quad_origin) = (from(&lanes, 8), from(&lanes, 4));
            // SAFETY: as above.
            let setup = unsafe {
                let mut setup = Setup::ZERO;
                setup.set(&lanes, n);
                setup
            };
            assert_eq!(setup.one_origin, one_origin, "lanes {idx:?}");
            assert_eq!(setup.quad_origin, quad_origin, "lanes {idx:?}");
            for (r, &i) in idx.iter().enumerate() {
                // The gathered ray (its origin moved where its group's was).
                let ray = lanes.ray(r);
                let ranged = ray.tmin.partial_cmp(&ray.tmax).is_some_and(|o| o.is_le());
                let shear = RayShear::new(ray.origin, ray.dir).filter(|_| ranged);
                assert_eq!(setup.valid >> r & 1 == 1, shear.is_some(), "{ray:?}");
                assert_eq!(
                    ray.dir.to_array().map(f32::to_bits),
                    rays.get(i).dir.to_array().map(f32::to_bits)
                );
                if let Some(s) = shear {
                    valid += 1;
                    assert_eq!(setup.shear(r).bits(), Shear4::new(s).bits(), "{ray:?}");
                    assert_eq!(
                        setup.boxes()[r].bits(),
                        Box8Ray::new(&ray).bits(),
                        "{ray:?}"
                    );
                }
            }
            assert_eq!(u64::from(setup.valid) >> n, 0);
        }
        assert!(valid > 300, "{valid} valid rays");
    }

    /// A ray's eight floats as bits, in the order of a record.
    fn record_bits(r: &Ray) -> [u32; 8] {
        let [ox, oy, oz] = r.origin.to_array();
        let [dx, dy, dz] = r.dir.to_array();
        [ox, oy, oz, dx, dy, dz, r.tmin, r.tmax].map(f32::to_bits)
    }
}
