//! Scenes, seeds and an f64 reference for tests and benches (shared, like obvhs's
//! `test_util`), so every crate tests against the same ground truth.

use glam::{DVec3, Vec3};

use crate::builtin::MeshBuilder;
use crate::{LoadReport, Ray, Result, Rng, Scene};

/// The seed for randomised tests: `COBALT_SEED` if set (decimal), else `default`. Tests print
/// it on failure so a run can be repeated.
pub fn seed(default: u64) -> u64 {
    std::env::var("COBALT_SEED")
        .ok()
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(default)
}

/// A scene from a mesh under construction.
pub fn scene_of(name: &str, m: MeshBuilder) -> Result<Scene> {
    Scene::from_parts(name.into(), m.positions, m.triangles, LoadReport::default())
}

/// A built-in scene (`builtin:NAME[:detail]`, loaded for AO) and its BVH (medium preset).
///
/// # Errors
/// An unknown name, or a scene that cannot be built.
pub fn builtin_with_bvh(name: &str) -> Result<(Scene, crate::Bvh)> {
    let scene = crate::SceneSource::parse(name)?.load(crate::SceneNeeds::AO)?;
    let bvh = crate::Bvh::build(&scene, crate::bvh::preset::BuildPreset::Medium)?;
    Ok((scene, bvh))
}

/// A closed, watertight icosphere (`20 * 4^level` triangles).
pub fn icosphere(level: u32, center: Vec3, radius: f32) -> Scene {
    let mut m = MeshBuilder::default();
    m.icosphere(center, radius, level, 0);
    scene_of("icosphere", m).expect("an icosphere has triangles")
}

/// `n` random triangles of roughly `size` inside a cube of half side `extent`.
pub fn random_triangles(rng: &mut Rng, n: usize, extent: f32, size: f32) -> Scene {
    let mut m = MeshBuilder::default();
    for _ in 0..n {
        let c = Vec3::new(
            rng.range(-extent, extent),
            rng.range(-extent, extent),
            rng.range(-extent, extent),
        );
        let a = c + Vec3::from(rng.unit_vector()) * size * rng.range(0.3, 1.0);
        let b = c + Vec3::from(rng.unit_vector()) * size * rng.range(0.3, 1.0);
        let d = c + Vec3::from(rng.unit_vector()) * size * rng.range(0.3, 1.0);
        m.tri_points(a, b, d, 0);
    }
    scene_of("random", m).expect("n > 0")
}

/// The scene with every vertex mapped to `p * scale + offset` (in f64, rounded once).
pub fn transformed(scene: &Scene, scale: f64, offset: DVec3) -> Scene {
    let mut s = scene.clone();
    for p in &mut s.positions {
        *p = (p.as_dvec3() * scale + offset).as_vec3();
    }
    s
}

/// The distance at which `ray` meets triangle `prim` of `scene` by the watertight test alone
/// (`None` where it does not): what any traversal that reports a hit on `prim` must report.
pub fn retest(scene: &Scene, prim: u32, ray: &Ray) -> Option<f32> {
    let [a, b, c] = scene.vertices(prim as usize);
    crate::RayShear::new(ray.origin, ray.dir).and_then(|s| {
        crate::intersect_watertight(
            &s,
            &a.to_array(),
            &b.to_array(),
            &c.to_array(),
            ray.tmin,
            ray.tmax,
        )
        .map(|(t, _, _)| t)
    })
}

/// The f64 reference's answer for one ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference {
    /// Nearest hit `(t, prim)`.
    pub hit: Option<(f64, u32)>,
    /// True when a nearly-hit edge or a near tie makes the answer depend on rounding, so an
    /// f32 tracer may fairly differ.
    pub ambiguous: bool,
}

/// Brute-force closest hit in f64 over all triangles (Möller–Trumbore in double precision).
/// `margin` is the barycentric distance to an edge, and `t_tol` the relative distance, below
/// which an answer counts as ambiguous.
pub fn reference_closest(scene: &Scene, ray: &Ray, margin: f64, t_tol: f64) -> Reference {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let (tmin, tmax) = (ray.tmin as f64, ray.tmax as f64);
    let mut best: Option<(f64, u32)> = None;
    let mut near: Vec<f64> = Vec::new(); // distances of nearly-hit or hit triangles
    for i in 0..scene.len() {
        let [a, b, c] = scene.vertices(i).map(|v| v.as_dvec3());
        let Some((t, bary)) = moller_trumbore(o, d, a, b, c) else {
            continue;
        };
        if !(t >= tmin * (1.0 - t_tol) && t <= tmax * (1.0 + t_tol)) {
            continue;
        }
        let m = bary.min_element();
        if m >= -margin {
            near.push(t);
        }
        if m >= 0.0 && t >= tmin && t <= tmax && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, i as u32));
        }
    }
    let ambiguous = match best {
        // A near miss or another hit at about the same distance.
        Some((bt, bp)) => {
            let m = {
                let [a, b, c] = scene.vertices(bp as usize).map(|v| v.as_dvec3());
                moller_trumbore(o, d, a, b, c).map_or(0.0, |(_, b)| b.min_element())
            };
            m < margin
                || near
                    .iter()
                    .filter(|&&t| t <= bt * (1.0 + t_tol) + 1e-30)
                    .count()
                    > 1
        }
        None => !near.is_empty(),
    };
    Reference {
        hit: best,
        ambiguous,
    }
}

/// Plane hit distance and barycentrics `(b0, b1, b2)` of the ray's line, or `None` if parallel.
fn moller_trumbore(o: DVec3, d: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<(f64, DVec3)> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    let t = e2.dot(q) * inv;
    Some((t, DVec3::new(1.0 - u - v, u, v)))
}

/// Path of a real scene from the shared folder beside the workspace
/// (`../shared/scenes/NAME`, or `$COBALT_SCENES/NAME`), or `None` with a note on stderr when it
/// is absent: tests and benches that use real scenes say so instead of silently passing.
pub fn shared_scene(name: &str) -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("COBALT_SCENES").map_or_else(
        || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes"),
        std::path::PathBuf::from,
    );
    let path = dir.join(name);
    if path.is_file() {
        Some(path)
    } else {
        eprintln!("note: {} is absent; skipping what needs it", path.display());
        None
    }
}
