//! Ambient-occlusion rays: for each primary hit, `n` cosine-weighted directions from the
//! Halton sequence (bases 2 and 3), scrambled per pixel by a random rotation (Cranley–Patterson),
//! length-limited, spawned without self-intersection.

use glam::Vec3;
use rayon::prelude::*;

use crate::spawn::offset_ray_origin;
use crate::triangle::{RayShear, intersect_watertight};
use crate::{Hit, HitBatch, Ray, RayBatch, Rng, Scene};

/// The radical inverse of `i` in `base`: the Halton sequence's coordinate.
pub fn radical_inverse(mut i: u32, base: u32) -> f32 {
    let inv = 1.0 / base as f32;
    let (mut f, mut r) = (inv, 0.0f32);
    while i > 0 {
        r += f * (i % base) as f32;
        i /= base;
        f *= inv;
    }
    r.min(1.0 - f32::EPSILON / 2.0)
}

/// Cosine-weighted direction on the hemisphere around `n` from a point `(u1, u2)` of the unit
/// square (Malley's method: uniform disk, projected up).
pub fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    cosine_hemisphere_in(Basis::around(n), u1, u2)
}

/// A unit vector `n` and two unit vectors orthogonal to it and to each other: the
/// orthonormal basis [`cosine_hemisphere`] builds around `n`, built once for all of a hit's
/// probes. (A basis, not a frame: in this crate a frame is one image of a render.)
#[derive(Clone, Copy, Debug)]
pub struct Basis {
    t: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Basis {
    /// The basis around unit vector `n`.
    pub fn around(n: Vec3) -> Self {
        let (t, b) = n.any_orthonormal_pair();
        Self { t, b, n }
    }
}

/// [`cosine_hemisphere`] around a basis built beforehand: the same direction, bit for bit.
pub fn cosine_hemisphere_in(f: Basis, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let z = (1.0 - u1).max(0.0).sqrt();
    (f.t * (r * phi.cos()) + f.b * (r * phi.sin()) + f.n * z).normalize_or(f.n)
}

/// AO rays and where they came from.
#[derive(Clone, Debug, Default)]
pub struct AoRays {
    /// The rays, `samples` consecutive per source hit.
    pub rays: RayBatch,
    /// Index of the primary ray each came from.
    pub source: Vec<u32>,
}

/// Hits whose probes one parallel job generates: enough to amortise the job and the copy of
/// its part, few enough that a 512×512 image still spreads over every thread.
const CHUNK: usize = 1024;

/// Generates `samples` AO rays of length `max_distance` for each hit in `hits` (rays that
/// missed spawn none). The hemisphere faces the side the primary ray came from. `seed`
/// chooses the per-ray scrambling.
///
/// Runs in the caller's rayon pool, in chunks of hits whose parts are joined in order, so the
/// rays are the same however many threads made them: on one thread, the host's work between
/// an AO render's two generations can take most of the render beside a GPU. Each hit's probes
/// share its basis and their two possible origins, computed once.
pub fn ao_rays(
    scene: &Scene,
    primary: &RayBatch,
    hits: &HitBatch,
    samples: u32,
    max_distance: f32,
    seed: u64,
) -> AoRays {
    ao_rays_of_paths(scene, primary, hits, samples, max_distance, seed, None)
}

/// [`ao_rays`] for primary rays that are paths `ranks` of an image (ray `i` is path
/// `ranks[i]`): each path's probes are scrambled by its rank, so they are the same whatever
/// other paths share the batch. `None` numbers the rays `0..`, as [`ao_rays`] does.
///
/// # Panics
/// Panics if `ranks` is given and shorter than `hits`.
pub fn ao_rays_of_paths(
    scene: &Scene,
    primary: &RayBatch,
    hits: &HitBatch,
    samples: u32,
    max_distance: f32,
    seed: u64,
    ranks: Option<&[u32]>,
) -> AoRays {
    if let Some(r) = ranks {
        assert!(r.len() >= hits.len(), "a rank for every primary ray");
    }
    let halton: Vec<(f32, f32)> = (0..samples)
        .map(|i| (radical_inverse(i + 1, 2), radical_inverse(i + 1, 3)))
        .collect();
    let probes = Probes {
        scene,
        primary,
        hits,
        halton: &halton,
        max_distance,
        seed,
        ranks,
    };
    let parts: Vec<AoRays> = (0..hits.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let most = CHUNK * halton.len();
            let mut part = AoRays {
                rays: RayBatch::with_capacity(most),
                source: Vec::with_capacity(most),
            };
            for i in c * CHUNK..((c + 1) * CHUNK).min(hits.len()) {
                probes.of(i, &mut part);
            }
            part
        })
        .collect();
    let total = parts.iter().map(|p| p.source.len()).sum();
    let mut out = AoRays {
        rays: RayBatch::with_capacity(total),
        source: Vec::with_capacity(total),
    };
    for part in parts {
        out.rays.extend(&part.rays);
        out.source.extend_from_slice(&part.source);
    }
    out
}

/// What every hit's probes are made from.
struct Probes<'a> {
    scene: &'a Scene,
    primary: &'a RayBatch,
    hits: &'a HitBatch,
    halton: &'a [(f32, f32)],
    max_distance: f32,
    seed: u64,
    ranks: Option<&'a [u32]>,
}

impl Probes<'_> {
    /// Appends hit `i`'s probes (none if its ray missed) to `out`.
    fn of(&self, i: usize, out: &mut AoRays) {
        let Some((t, prim)) = self.hits.get(i) else {
            return;
        };
        let r = self.primary.get(i);
        // A HitBatch keeps no barycentrics: one more watertight test of the hit triangle gives
        // exactly the traversal's (t, u, v).
        let [p0, p1, p2] = self.scene.vertices(prim as usize).map(|v| v.to_array());
        let Some((t, u, v)) = RayShear::new(r.origin, r.dir)
            .and_then(|s| intersect_watertight(&s, &p0, &p1, &p2, r.tmin, r.tmax.max(t)))
        else {
            return;
        };
        let sp = self.scene.surface_point(&Hit { t, prim, u, v });
        let n = sp.normal;
        let facing = if n.dot(r.dir) < 0.0 { n } else { -n };
        let rank = self.ranks.map_or(i as u64, |r| u64::from(r[i]));
        let mut rng = Rng::new(self.seed ^ rank.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        let (s1, s2) = (rng.f32(), rng.f32());
        // What every probe of this hit shares, computed once: the basis, and the two origins
        // `spawn_ray` chooses between by the side of the surface a direction leaves to.
        let basis = Basis::around(facing);
        let origins = [offset_ray_origin(&sp, n), offset_ray_origin(&sp, -n)];
        for &(h1, h2) in self.halton {
            let d = cosine_hemisphere_in(basis, (h1 + s1).fract(), (h2 + s2).fract());
            let o = origins[usize::from(d.dot(n) < 0.0)];
            out.rays
                .push(&Ray::with_range(o, d, 0.0, self.max_distance));
            out.source.push(i as u32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel chunks join into exactly the rays of one hit after another, on one
    /// thread or several, across chunk boundaries.
    #[test]
    fn probes_are_the_same_on_any_number_of_threads() {
        use crate::{Camera, testkit, traverse};
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
        let primary = Camera::orbit(&scene.bounds(), 0).primary_rays(64, 50).rays;
        assert!(primary.len() > 2 * CHUNK);
        let hits = traverse::closest_hits(&bvh, &primary);
        let make = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| ao_rays(&scene, &primary, &hits, 4, 2.0, 9))
        };
        let (one, three) = (make(1), make(3));
        assert_eq!(one.source, three.source);
        assert_eq!(one.rays, three.rays);
        // One hit after another, each hit's probes together.
        assert!(one.source.windows(2).all(|w| w[0] <= w[1]));
        assert!(one.source.len() > 4 * CHUNK);
    }

    /// A hit's shared basis and origins give exactly the rays of spawning every probe on its
    /// own (`cosine_hemisphere`, then `spawn_ray`).
    #[test]
    fn probes_are_the_rays_spawned_one_by_one() {
        use crate::{Camera, testkit, traverse};
        let (scene, bvh) = testkit::builtin_with_bvh("builtin:forest:0.05").expect("scene");
        let primary = Camera::orbit(&scene.bounds(), 1).primary_rays(40, 30).rays;
        let hits = traverse::closest_hits(&bvh, &primary);
        let (samples, length, seed) = (8, 1.5, 3);
        let got = ao_rays(&scene, &primary, &hits, samples, length, seed);
        let mut want = RayBatch::default();
        for i in 0..hits.len() {
            let Some((t, prim)) = hits.get(i) else {
                continue;
            };
            let r = primary.get(i);
            let [p0, p1, p2] = scene.vertices(prim as usize).map(|v| v.to_array());
            let (t, u, v) = RayShear::new(r.origin, r.dir)
                .and_then(|s| intersect_watertight(&s, &p0, &p1, &p2, r.tmin, r.tmax.max(t)))
                .expect("the hit triangle is hit again");
            let sp = scene.surface_point(&Hit { t, prim, u, v });
            let facing = if sp.normal.dot(r.dir) < 0.0 {
                sp.normal
            } else {
                -sp.normal
            };
            let mut rng = Rng::new(seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let (s1, s2) = (rng.f32(), rng.f32());
            for k in 0..samples {
                let (h1, h2) = (radical_inverse(k + 1, 2), radical_inverse(k + 1, 3));
                let d = cosine_hemisphere(facing, (h1 + s1).fract(), (h2 + s2).fract());
                want.push(&sp.spawn_ray(d, length));
            }
        }
        assert!(want.len() > 1000);
        assert_eq!(got.rays, want);
    }

    #[test]
    fn halton_and_cosine_weighting() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert_eq!(radical_inverse(3, 2), 0.75);
        assert!((radical_inverse(1, 3) - 1.0 / 3.0).abs() < 1e-7);
        // Mean cosine of a cosine-weighted hemisphere is 2/3.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mean: f32 = (1..=4096)
            .map(|i| cosine_hemisphere(n, radical_inverse(i, 2), radical_inverse(i, 3)).dot(n))
            .sum::<f32>()
            / 4096.0;
        assert!((mean - 2.0 / 3.0).abs() < 0.01, "{mean}");
    }
}
