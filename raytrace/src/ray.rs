//! Rays, single and as a structure of arrays, and the hits they produce.

use glam::Vec3;

/// One ray: points `origin + t * dir` for `tmin <= t <= tmax`. `dir` need not be normalised;
/// `t` is measured in units of its length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Direction (any length but zero; a zero direction never hits).
    pub dir: Vec3,
    /// Smallest accepted hit distance.
    pub tmin: f32,
    /// Largest accepted hit distance.
    pub tmax: f32,
}

impl Ray {
    /// A ray over `[0, +inf]`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// A ray over `[tmin, tmax]`.
    pub fn with_range(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self {
            origin,
            dir,
            tmin,
            tmax,
        }
    }

    /// The point at distance `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// A closest or any hit: distance, primitive id (the scene's triangle index) and the barycentric
/// weights of vertices 1 and 2 (vertex 0 gets `1 - u - v`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of the direction's length.
    pub t: f32,
    /// Triangle index in scene (file) order.
    pub prim: u32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

/// Rays as a structure of arrays: the layout of `cobalt trace`'s binary files, of GPU buffers,
/// and of tasks that are ranges of a generation's rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RayBatch {
    /// Origin x.
    pub ox: Vec<f32>,
    /// Origin y.
    pub oy: Vec<f32>,
    /// Origin z.
    pub oz: Vec<f32>,
    /// Direction x.
    pub dx: Vec<f32>,
    /// Direction y.
    pub dy: Vec<f32>,
    /// Direction z.
    pub dz: Vec<f32>,
    /// Smallest accepted distance.
    pub tmin: Vec<f32>,
    /// Largest accepted distance.
    pub tmax: Vec<f32>,
}

/// Bytes of one ray in a ray file: eight little-endian `f32`s, `ox oy oz dx dy dz tmin tmax`.
pub const RAY_RECORD_BYTES: usize = 32;

impl RayBatch {
    /// Appends the ray of one ray-file record, checked as every walk needs it: a finite origin
    /// and direction, a direction whose largest component has a finite reciprocal, and
    /// `0 <= tmin <= tmax` (`tmax` may be infinite). The error names the field and its value.
    pub fn push_record(&mut self, record: &[u8; RAY_RECORD_BYTES]) -> Result<(), String> {
        const FIELDS: [&str; 8] = ["ox", "oy", "oz", "dx", "dy", "dz", "tmin", "tmax"];
        let mut v = [0f32; 8];
        for (k, word) in record.chunks_exact(4).enumerate() {
            v[k] = f32::from_le_bytes([word[0], word[1], word[2], word[3]]);
        }
        if let Some(k) = (0..8).find(|&k| v[k].is_nan() || (k < 7 && v[k].is_infinite())) {
            return Err(format!("{} is {}", FIELDS[k], v[k]));
        }
        // The walks divide by the direction: where its largest component's reciprocal
        // overflows, a hit's distance would come out infinite or NaN.
        let longest = v[3].abs().max(v[4].abs()).max(v[5].abs());
        if longest == 0.0 {
            return Err("direction is zero".into());
        }
        if !(1.0 / longest).is_finite() {
            return Err(format!(
                "direction's largest component {longest:e} is too small (below 2^-128)"
            ));
        }
        if !(v[6] >= 0.0 && v[6] <= v[7]) {
            return Err(format!("tmin {} must be in [0, tmax = {}]", v[6], v[7]));
        }
        self.push(&Ray {
            origin: Vec3::new(v[0], v[1], v[2]),
            dir: Vec3::new(v[3], v[4], v[5]),
            tmin: v[6],
            tmax: v[7],
        });
        Ok(())
    }

    /// An empty batch with room for `n` rays.
    pub fn with_capacity(n: usize) -> Self {
        let v = || Vec::with_capacity(n);
        Self {
            ox: v(),
            oy: v(),
            oz: v(),
            dx: v(),
            dy: v(),
            dz: v(),
            tmin: v(),
            tmax: v(),
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.ox.len()
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.ox.is_empty()
    }

    /// Appends a ray.
    pub fn push(&mut self, r: &Ray) {
        self.ox.push(r.origin.x);
        self.oy.push(r.origin.y);
        self.oz.push(r.origin.z);
        self.dx.push(r.dir.x);
        self.dy.push(r.dir.y);
        self.dz.push(r.dir.z);
        self.tmin.push(r.tmin);
        self.tmax.push(r.tmax);
    }

    /// Starts loading ray `i` into the cache for a reader that takes rays out of order (a
    /// sample read in place), so that its loads overlap the work on the rays before it. Does
    /// nothing where `i` is beyond the batch.
    #[inline(always)]
    pub(crate) fn prefetch(&self, i: usize) {
        for c in self.columns() {
            prefetch(c, i);
        }
    }

    /// The eight columns, in the order of the fields.
    pub(crate) fn columns(&self) -> [&Vec<f32>; 8] {
        [
            &self.ox, &self.oy, &self.oz, &self.dx, &self.dy, &self.dz, &self.tmin, &self.tmax,
        ]
    }

    /// Ray `i` as a [`Record`].
    ///
    /// # Panics
    /// Panics if `i` is out of bounds.
    #[inline(always)]
    pub(crate) fn record(&self, i: usize) -> Record {
        [
            self.ox[i],
            self.oy[i],
            self.oz[i],
            self.dx[i],
            self.dy[i],
            self.dz[i],
            self.tmin[i],
            self.tmax[i],
        ]
    }

    /// Whether rays `i` and `j` start at the same point, bit for bit.
    ///
    /// # Panics
    /// Panics if either is out of bounds.
    #[inline(always)]
    pub(crate) fn same_origin(&self, i: usize, j: usize) -> bool {
        let o = |k: usize| [self.ox[k], self.oy[k], self.oz[k]].map(f32::to_bits);
        o(i) == o(j)
    }

    /// Appends all rays of `other`.
    pub fn extend(&mut self, other: &RayBatch) {
        self.ox.extend_from_slice(&other.ox);
        self.oy.extend_from_slice(&other.oy);
        self.oz.extend_from_slice(&other.oz);
        self.dx.extend_from_slice(&other.dx);
        self.dy.extend_from_slice(&other.dy);
        self.dz.extend_from_slice(&other.dz);
        self.tmin.extend_from_slice(&other.tmin);
        self.tmax.extend_from_slice(&other.tmax);
    }

    /// Ray `i`.
    ///
    /// # Panics
    /// Panics if `i >= self.len()` or the columns have different lengths.
    #[inline(always)]
    pub fn get(&self, i: usize) -> Ray {
        Ray {
            origin: Vec3::new(self.ox[i], self.oy[i], self.oz[i]),
            dir: Vec3::new(self.dx[i], self.dy[i], self.dz[i]),
            tmin: self.tmin[i],
            tmax: self.tmax[i],
        }
    }

    /// True when all eight columns have the same length (batch functions panic otherwise).
    pub fn is_consistent(&self) -> bool {
        let n = self.ox.len();
        self.columns().iter().all(|c| c.len() == n)
    }
}

impl FromIterator<Ray> for RayBatch {
    fn from_iter<I: IntoIterator<Item = Ray>>(iter: I) -> Self {
        let iter = iter.into_iter();
        let mut b = Self::with_capacity(iter.size_hint().0);
        for r in iter {
            b.push(&r);
        }
        b
    }
}

/// Results of a batch, as a structure of arrays matching `cobalt trace`'s hit files:
/// `t = +inf` and `prim = u32::MAX` on a miss.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HitBatch {
    /// Hit distance, `+inf` on a miss.
    pub t: Vec<f32>,
    /// Primitive id, [`HitBatch::MISS`] on a miss.
    pub prim: Vec<u32>,
}

impl HitBatch {
    /// The hits as a hit file: per ray, `t` (`f32`, +inf for a miss) and the triangle (`u32`,
    /// `u32::MAX` for a miss), little-endian.
    pub fn to_records(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.len() * 8);
        for (t, prim) in self.t.iter().zip(&self.prim) {
            let t = if *prim == u32::MAX { f32::INFINITY } else { *t };
            out.extend_from_slice(&t.to_le_bytes());
            out.extend_from_slice(&prim.to_le_bytes());
        }
        out
    }

    /// The primitive id written for a miss.
    pub const MISS: u32 = u32::MAX;

    /// `n` misses, to be overwritten by the hits found.
    pub fn misses(n: usize) -> Self {
        HitBatch {
            t: vec![f32::INFINITY; n],
            prim: vec![Self::MISS; n],
        }
    }

    /// Hit `i` as an option.
    pub fn get(&self, i: usize) -> Option<(f32, u32)> {
        (self.prim[i] != Self::MISS).then(|| (self.t[i], self.prim[i]))
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }
}

/// What a generation of rays is for: decides the query that traces it (closest hit or any
/// hit) and the thesis's two classes, coherent and diffuse, whose costs are calibrated apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum RayKind {
    /// Camera rays: coherent, closest hit.
    Primary,
    /// Rays towards a light: coherent, any hit.
    Shadow,
    /// Mirror bounces: coherent, closest hit.
    Reflection,
    /// Ambient-occlusion (Halton diffuse) rays: diffuse, any hit.
    Ao,
}

impl RayKind {
    /// All kinds, for listings and tests.
    pub const ALL: [Self; 4] = [Self::Primary, Self::Shadow, Self::Reflection, Self::Ao];

    /// The thesis's "coherent rays": primary, shadow and reflection; AO rays are diffuse.
    pub fn is_coherent(self) -> bool {
        !matches!(self, Self::Ao)
    }

    /// True when any hit answers the query (occlusion: shadow and AO rays).
    pub fn is_occlusion(self) -> bool {
        matches!(self, Self::Shadow | Self::Ao)
    }

    /// The lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Primary => "primary",
            Self::Shadow => "shadow",
            Self::Reflection => "reflection",
            Self::Ao => "ao",
        }
    }
}

impl std::fmt::Display for RayKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for RayKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!("unknown ray kind `{s}` (expected primary, shadow, reflection or ao)")
            })
    }
}

/// One ray's origin, direction, `tmin` and `tmax` in one block, in the order of
/// [`RayBatch::columns`]: what a walk in an order other than the batch's reads a ray from.
pub(crate) type Record = [f32; 8];

/// Starts loading `column[i]` into the cache; nothing where `i` is beyond the column or the
/// CPU has no prefetch instruction.
#[inline(always)]
pub(crate) fn prefetch<T>(column: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(x) = column.get(i) {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: the address is of an element of the column; a prefetch only hints the cache
        // and never reads or faults.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(std::ptr::from_ref(x).cast()) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (column, i);
}
