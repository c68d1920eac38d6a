// Robustness at the extremes: watertightness, transforms, axis-parallel and grazing rays,
// degenerate triangles, agreement with an f64 reference, counting, and ray spawning.

use std::collections::HashSet;

use glam::{DVec3, Vec3};

use crate::builtin::MeshBuilder;
use crate::builtin::mesh::icosphere as unit_icosphere;
use crate::bvh::validate;
use crate::testkit::{self, reference_closest};
use crate::traverse::{
    any_hits, any_hits_counted, closest_hits, closest_hits_counted, reduced_counts,
};
use crate::{BuildPreset, Bvh, Ray, RayBatch, RayShear, Rng, Scene, Walk, intersect_watertight};

fn build(scene: &Scene) -> Bvh {
    let bvh = Bvh::build(scene, BuildPreset::Medium).unwrap();
    validate(&bvh, scene).unwrap();
    bvh
}

/// Targets on a closed icosphere where watertightness is hardest: every vertex and every edge
/// midpoint.
fn vertices_and_edge_midpoints(scene: &Scene) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = scene.positions.clone();
    let mut edges = HashSet::new();
    for t in &scene.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if edges.insert((a.min(b), a.max(b))) {
                out.push((scene.positions[a as usize] + scene.positions[b as usize]) * 0.5);
            }
        }
    }
    out
}

#[test]
fn no_ray_escapes_a_closed_sphere() {
    let seed = testkit::seed(1);
    let mut rng = Rng::new(seed);
    for (center, radius) in [
        (Vec3::ZERO, 1.0),
        (Vec3::splat(1e5), 1e3),
        (Vec3::splat(-3e-3), 1e-4),
    ] {
        let scene = testkit::icosphere(5, center, radius);
        let bvh = build(&scene);
        let targets = vertices_and_edge_midpoints(&scene);
        let mut origins = vec![center];
        for _ in 0..8 {
            origins.push(center + Vec3::from(rng.unit_vector()) * radius * rng.range(0.0, 0.9));
        }
        let rays: RayBatch = origins
            .iter()
            .flat_map(|&o| targets.iter().map(move |&t| Ray::new(o, t - o)))
            .collect();
        let hits = closest_hits(&bvh, &rays);
        let any = any_hits(&bvh, &rays);
        let missed = (0..rays.len()).filter(|&i| hits.get(i).is_none()).count();
        let any_missed = (0..rays.len()).filter(|&i| any.get(i).is_none()).count();
        assert_eq!(
            (missed, any_missed),
            (0, 0),
            "{missed} of {} rays escaped the sphere at {center} r {radius} (COBALT_SEED={seed})",
            rays.len()
        );
        // The hit is where the target is: t close to 1.
        for i in (0..rays.len()).step_by(97) {
            let t = hits.t[i];
            assert!((t - 1.0).abs() < 1e-2, "t = {t} (COBALT_SEED={seed})");
        }
    }
}

#[test]
fn grazing_rays_inside_a_closed_sphere_hit() {
    let seed = testkit::seed(2);
    let mut rng = Rng::new(seed);
    let scene = testkit::icosphere(4, Vec3::ZERO, 1.0);
    let bvh = build(&scene);
    let mut rays = RayBatch::default();
    for &v in &scene.positions {
        // Just inside a vertex, heading along the surface.
        let o = v * (1.0 - 1e-4 * rng.f32());
        let tangent = v.any_orthonormal_vector();
        let a = rng.range(0.0, std::f32::consts::TAU);
        let d = tangent * a.cos() + v.cross(tangent) * a.sin() + v * rng.range(-1e-3, 1e-3);
        rays.push(&Ray::new(o, d));
    }
    let hits = closest_hits(&bvh, &rays);
    let missed = (0..rays.len()).filter(|&i| hits.get(i).is_none()).count();
    assert_eq!(missed, 0, "grazing rays escaped (COBALT_SEED={seed})");
}

#[test]
fn grazing_a_large_plane() {
    let mut m = MeshBuilder::default();
    let s = 1000.0;
    m.quad(
        [
            Vec3::new(-s, 0.0, -s),
            Vec3::new(-s, 0.0, s),
            Vec3::new(s, 0.0, s),
            Vec3::new(s, 0.0, -s),
        ],
        0,
    );
    let scene = testkit::scene_of("plane", m).unwrap();
    let bvh = build(&scene);
    for slope in [1e-2f32, 1e-4, 2e-6] {
        let h = 1e-3;
        let down = Ray::new(Vec3::new(0.0, h, 0.0), Vec3::new(1.0, -slope, 0.3));
        let hit = bvh.closest_hit(&down).expect("grazing ray hits the plane");
        let want = h / slope;
        if want < 900.0 {
            assert!((hit.t - want).abs() / want < 1e-3, "t {} vs {want}", hit.t);
        }
        let up = Ray::new(Vec3::new(0.0, h, 0.0), Vec3::new(1.0, slope, 0.3));
        assert!(bvh.closest_hit(&up).is_none());
    }
}

/// A closed cube `[-1, 1]^3` of 4 x 4 grids whose coordinates are exact in binary, so the
/// faces share their edge vertices bit for bit.
fn cube() -> Scene {
    let mut m = MeshBuilder::default();
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let lo = Vec3::splat(-1.0);
    m.grid(lo, z, x, 4, 0);
    m.grid(Vec3::new(-1.0, 1.0, -1.0), x, z, 4, 0);
    m.grid(lo, x, y, 4, 0);
    m.grid(Vec3::new(-1.0, -1.0, 1.0), y, x, 4, 0);
    m.grid(lo, y, z, 4, 0);
    m.grid(Vec3::new(1.0, -1.0, -1.0), z, y, 4, 0);
    testkit::scene_of("cube", m).unwrap()
}

#[test]
fn axis_parallel_rays_and_signed_zeros() {
    let scene = cube();
    let bvh = build(&scene);
    let signs = [0.0f32, -0.0];
    let mut n = 0;
    // Origins on grid lines and planes (where boxes and edges sit), including on the faces.
    for ox in [-1.0f32, -0.5, 0.0, 0.25, 0.5, 1.0] {
        for oy in [-1.0f32, -0.5, 0.0, 0.5, 1.0] {
            for oz in [-0.5f32, 0.0, 0.5] {
                let o = Vec3::new(ox, oy, oz);
                for axis in 0..3 {
                    for dir_sign in [1.0f32, -1.0] {
                        for &z1 in &signs {
                            for &z2 in &signs {
                                let mut d = [z1, z2, z1];
                                d[axis] = dir_sign;
                                if axis == 1 {
                                    d[2] = z2;
                                }
                                let d = Vec3::from(d);
                                let r = Ray::new(o, d);
                                // The exit distance to the cube wall along that axis.
                                let want = 1.0 - dir_sign * o[axis];
                                n += 1;
                                if o.abs().max_element() == 1.0 {
                                    // Starting on a wall: t = 0 is a fair hit; check any hit.
                                    assert!(bvh.any_hit(&r).is_some(), "{o} {d:?}");
                                    continue;
                                }
                                let h = bvh.closest_hit(&r).unwrap_or_else(|| {
                                    panic!("axis ray from {o} along {d:?} missed")
                                });
                                // Rays lying in a face plane may hit that face's far edge
                                // first at the same distance; t is what matters.
                                assert_eq!(h.t, want, "ray from {o} along {d:?}");
                                assert!(bvh.any_hit(&r).is_some());
                            }
                        }
                    }
                }
            }
        }
    }
    assert!(n > 1000);
}

#[test]
fn degenerate_triangles_are_never_hit() {
    let mut m = MeshBuilder::default();
    let a = Vec3::new(0.0, 0.0, 0.0);
    m.tri_points(a, Vec3::X, Vec3::X * 2.0, 0); // collinear
    m.tri_points(Vec3::Y, Vec3::Y, Vec3::Y, 0); // a point
    m.tri_points(Vec3::Z, Vec3::Z, Vec3::ONE, 0); // repeated vertex
    m.tri_points(
        Vec3::new(0.0, 0.0, -5.0),
        Vec3::new(3.0, 0.0, -5.0),
        Vec3::new(0.0, 3.0, -5.0),
        0,
    );
    // Enough real triangles that obvhs builds a tree, with degenerate ids among them.
    m.icosphere(Vec3::new(50.0, 0.0, 0.0), 1.0, 1, 0);
    m.tri_points(Vec3::NEG_ONE, Vec3::NEG_ONE, Vec3::NEG_ONE, 0);
    let scene = testkit::scene_of("degenerate", m).unwrap();
    assert_eq!(scene.report.degenerate, 4);
    let bvh = build(&scene);
    for target in [
        Vec3::X,
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::Y,
        Vec3::Z,
        Vec3::splat(0.5),
    ] {
        for o in [target + Vec3::Z * 2.0, target + Vec3::new(0.3, 0.2, 2.0)] {
            let h = bvh.closest_hit(&Ray::new(o, target - o));
            assert!(h.is_none_or(|h| h.prim == 3), "{h:?}");
        }
    }
}

/// Rays from random points inside a big sphere towards random points, with clutter inside.
fn cluttered(seed: u64) -> (Scene, Vec<Ray>) {
    let mut rng = Rng::new(seed);
    let mut m = MeshBuilder::default();
    m.icosphere(Vec3::ZERO, 100.0, 3, 0);
    let clutter = testkit::random_triangles(&mut rng, 300, 60.0, 10.0);
    let mut c = MeshBuilder::default();
    c.positions = clutter.positions;
    c.triangles = clutter.triangles;
    c.material_ids = vec![0; c.triangles.len()];
    m.append(c);
    let scene = testkit::scene_of("cluttered", m).unwrap();
    let rays = (0..2000)
        .map(|_| {
            let o = Vec3::from(rng.unit_vector()) * rng.range(0.0, 80.0);
            let t = Vec3::from(rng.unit_vector()) * rng.range(0.0, 80.0);
            Ray::new(o, t - o)
        })
        .collect();
    (scene, rays)
}

#[test]
fn translated_and_scaled_scenes_give_the_same_hits() {
    let seed = testkit::seed(3);
    let (scene, rays) = cluttered(seed);
    let base_bvh = build(&scene);
    let base: Vec<_> = rays.iter().map(|r| base_bvh.closest_hit(r)).collect();
    // Keep rays whose answer does not hinge on rounding (after a 1e5 shift f32 coordinates
    // move by up to 0.004, about 1e-3 of a triangle).
    let keep: Vec<usize> = (0..rays.len())
        .filter(|&i| !reference_closest(&scene, &rays[i], 1e-2, 1e-3).ambiguous)
        .collect();
    assert!(
        keep.len() > rays.len() * 3 / 4,
        "only {} clear rays",
        keep.len()
    );
    for (scale, offset) in [
        (1.0, DVec3::splat(1e5)),
        (1e-4, DVec3::ZERO),
        (1e4, DVec3::ZERO),
    ] {
        let moved = testkit::transformed(&scene, scale, offset);
        let bvh = build(&moved);
        for &i in &keep {
            let r = rays[i];
            let o = (r.origin.as_dvec3() * scale + offset).as_vec3();
            let h = bvh.closest_hit(&Ray::new(o, r.dir));
            let b = base[i];
            assert_eq!(
                h.map(|h| h.prim),
                b.map(|b| b.prim),
                "ray {i} at scale {scale} offset {offset} (COBALT_SEED={seed})"
            );
            if let (Some(h), Some(b)) = (h, b) {
                let want = b.t as f64 * scale;
                // Relative error from scaling, absolute (in distance) from the shift's rounding.
                let allowed = 1e-4 * want + offset.max_element() * 1e-6 / r.dir.length() as f64;
                let err = (h.t as f64 - want).abs();
                assert!(
                    err <= allowed,
                    "ray {i}: t {} vs {want} (COBALT_SEED={seed})",
                    h.t
                );
            }
        }
    }
}

#[test]
fn closest_hits_agree_with_an_f64_reference() {
    let seed = testkit::seed(4);
    let mut rng = Rng::new(seed);
    for round in 0..3 {
        let scene = testkit::random_triangles(&mut rng, 1500, 10.0, [0.2, 2.0, 8.0][round]);
        let bvh = build(&scene);
        let rays: RayBatch = (0..3000)
            .map(|_| {
                let o = Vec3::from(rng.unit_vector()) * 15.0;
                let t = Vec3::from(rng.unit_vector()) * rng.range(0.0, 10.0);
                Ray::with_range(o, t - o, 0.0, rng.range(0.5, 2.0))
            })
            .collect();
        let hits = closest_hits(&bvh, &rays);
        let (counted, _) = closest_hits_counted(&bvh, &rays);
        assert_eq!(
            hits, counted,
            "counting changed the answer (COBALT_SEED={seed})"
        );
        let mut checked = 0;
        for i in 0..rays.len() {
            let r = reference_closest(&scene, &rays.get(i), 1e-5, 1e-5);
            if r.ambiguous {
                continue;
            }
            checked += 1;
            match (r.hit, hits.get(i)) {
                (None, None) => {}
                (Some((t, p)), Some((ht, hp))) => {
                    assert_eq!(p, hp, "ray {i} round {round} (COBALT_SEED={seed})");
                    // f32 rounding of positions near |o| ~ 15 bounds the distance error.
                    let ray = rays.get(i);
                    let d = ray.dir.length() as f64;
                    let scale = ray.origin.length() as f64 + t * d + 1.0;
                    assert!(
                        (ht as f64 - t).abs() * d <= 1e-5 * scale,
                        "ray {i}: t {ht} vs {t} (COBALT_SEED={seed})"
                    );
                }
                (want, got) => {
                    panic!("ray {i}: f64 says {want:?}, traversal {got:?} (COBALT_SEED={seed})")
                }
            }
        }
        assert!(checked > 2900, "only {checked} rays were unambiguous");
    }
}

#[test]
fn counts_and_reduced_traversal() {
    let seed = testkit::seed(5);
    let (scene, rays) = cluttered(seed);
    let bvh = build(&scene);
    let batch: RayBatch = rays.into_iter().collect();
    let (hits, counts) = closest_hits_counted(&bvh, &batch);
    let reduced = reduced_counts(&bvh, &batch, Walk::Reduced, 0..batch.len());
    let part = reduced_counts(&bvh, &batch, Walk::Reduced, 100..300);
    assert_eq!(&reduced[100..300], &part[..]);
    for i in 0..batch.len() {
        let (c, r) = (counts[i], reduced[i]);
        // Rays start inside the closed sphere: each enters the root and tests a triangle.
        assert!(hits.get(i).is_some());
        assert!(c.nodes >= 1 && c.tris >= 1, "{c:?}");
        // Without shortening, the reduced traversal reaches a superset of the nodes.
        assert!(
            r.nodes >= c.nodes && r.tris >= c.tris,
            "ray {i}: {c:?} vs {r:?}"
        );
        assert_eq!(r, bvh.reduced_traversal(&batch.get(i)));
        // Ending at the first leaf's exit enters a subset of those nodes, and at least the
        // first leaf on the way.
        let f = bvh.first_leaf_traversal(&batch.get(i));
        assert!(f.nodes >= 2 && f.tris >= 1 && f.nodes <= r.nodes && f.tris <= r.tris);
    }
    let first = reduced_counts(&bvh, &batch, Walk::FirstLeaf, 0..batch.len());
    assert!(first.iter().zip(&reduced).any(|(f, r)| f.nodes < r.nodes));
    // An any-hit query stops at its first hit: it hits where `any_hit` does (a triangle the
    // ray meets, not always the same one: rays walked together visit nodes in another order),
    // it enters only nodes the reduced traversal enters, and it often enters fewer than the
    // closest hit. (It takes the nearest child first but leaves the others unsorted, so after
    // a dead end its walk may part from the closest hit's: a ray can enter more nodes than
    // that one.)
    let (any, any_counts) = any_hits_counted(&bvh, &batch);
    let mut fewer = 0;
    for i in 0..batch.len() {
        let (a, c, r) = (any_counts[i], counts[i], reduced[i]);
        let ray = batch.get(i);
        assert_eq!(any.get(i).is_some(), bvh.any_hit(&ray).is_some());
        if let Some((t, prim)) = any.get(i) {
            assert_eq!(testkit::retest(&scene, prim, &ray), Some(t), "ray {i}");
        }
        assert!(
            a.nodes >= 1 && a.nodes <= r.nodes && a.tris <= r.tris,
            "{a:?} {r:?}"
        );
        fewer += usize::from(a.nodes < c.nodes);
    }
    assert!(fewer > 0, "some closest hit walks on past its first hit");
    // A ray that misses everything enters nothing.
    let away = Ray::new(Vec3::splat(500.0), Vec3::ONE);
    assert_eq!(bvh.reduced_traversal(&away), Default::default());
    assert_eq!(bvh.closest_hit_counted(&away).1, Default::default());
}

#[test]
fn bad_rays_trace_nothing() {
    let scene = testkit::icosphere(1, Vec3::ZERO, 1.0);
    let bvh = build(&scene);
    for r in [
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray::new(Vec3::NAN, Vec3::X),
        Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0)),
        Ray::with_range(Vec3::ZERO, Vec3::X, 2.0, 1.0),
        Ray::with_range(Vec3::ZERO, Vec3::X, f32::NAN, 1.0),
        Ray::with_range(Vec3::ZERO, Vec3::X, 0.0, 0.5),
    ] {
        assert!(bvh.closest_hit(&r).is_none(), "{r:?}");
        assert!(bvh.any_hit(&r).is_none(), "{r:?}");
    }
}

#[test]
fn spawned_rays_never_hit_their_own_surface() {
    let seed = testkit::seed(6);
    let mut rng = Rng::new(seed);
    let (unit_v, _) = unit_icosphere(0);
    let _ = unit_v;
    for (center, radius) in [
        (Vec3::ZERO, 1.0),
        (Vec3::splat(1e5), 10.0),
        (Vec3::ZERO, 1e-4),
        (Vec3::splat(-2e4), 1e4),
    ] {
        let scene = testkit::icosphere(4, center, radius);
        let bvh = build(&scene);
        let mut escaped = 0;
        for _ in 0..3000 {
            // From outside, hit the sphere.
            let o = center + Vec3::from(rng.unit_vector()) * radius * 3.0;
            let target = center + Vec3::from(rng.unit_vector()) * radius * 0.5;
            let Some(hit) = bvh.closest_hit(&Ray::new(o, target - o)) else {
                continue;
            };
            let sp = scene.surface_point(&hit);
            // Outward (AO/reflection side): the sphere is convex, so nothing to hit.
            let mut out = Vec3::from(rng.unit_vector());
            if out.dot(sp.normal) < 0.0 {
                out = -out;
            }
            if let Some(h) = bvh.closest_hit(&sp.spawn_ray(out, f32::INFINITY)) {
                panic!(
                    "outward ray from prim {} re-hit prim {} at t {} (COBALT_SEED={seed})",
                    hit.prim, h.prim, h.t
                );
            }
            // Inward (refraction side): must hit another triangle, not itself.
            let inward = -out;
            match bvh.closest_hit(&sp.spawn_ray(inward, f32::INFINITY)) {
                Some(h) => assert_ne!(h.prim, hit.prim, "(COBALT_SEED={seed})"),
                None => escaped += 1,
            }
            // Shadow ray to a point outside: unoccluded.
            let light = center + sp.normal * radius * 4.0;
            assert!(
                !bvh.occluded(&sp.spawn_ray_to(light)),
                "(COBALT_SEED={seed})"
            );
        }
        assert_eq!(escaped, 0, "(COBALT_SEED={seed})");
    }
}

#[test]
fn ao_rays_leave_their_surface() {
    use crate::{Camera, SceneNeeds, SceneSource, ao};
    let scene = SceneSource::parse("builtin:cornell:0.3")
        .unwrap()
        .load(SceneNeeds::AO)
        .unwrap();
    let bvh = build(&scene);
    let primary = Camera::orbit(&scene.bounds(), 1).primary_rays(48, 48);
    let hits = closest_hits(&bvh, &primary.rays);
    let n_hits = (0..hits.len()).filter(|&i| hits.get(i).is_some()).count();
    assert!(n_hits > 48 * 24, "{n_hits}");
    let ao = ao::ao_rays(&scene, &primary.rays, &hits, 32, 0.5, 7);
    assert_eq!(ao.rays.len(), n_hits * 32);
    assert!(ao.rays.tmax.iter().all(|&t| t == 0.5));
    let ao_hits = closest_hits(&bvh, &ao.rays);
    for i in 0..ao.rays.len() {
        if let Some((t, p)) = ao_hits.get(i) {
            let src = hits.prim[ao.source[i] as usize];
            // Coplanar neighbours of a flat wall cannot be hit either.
            assert!(
                p != src && t > 0.0,
                "AO ray {i} hit its own triangle {p} at {t}"
            );
            let n = scene.geometric_normal(src as usize);
            let m = scene.geometric_normal(p as usize);
            assert!(
                n.cross(m).length() > 0.0 || t > 1e-3,
                "AO ray {i} hit a coplanar neighbour"
            );
        }
    }
}

/// A triangle and a ray at its barycentric point `(u, v)`, both multiplied by `2^k`.
fn scaled_case(c: [f32; 12], (u, v): (f32, f32), k: i32) -> (RayShear, [[f32; 3]; 3]) {
    let s = 2f32.powi(k);
    let p = |i: usize| Vec3::new(c[3 * i], c[3 * i + 1], c[3 * i + 2]);
    let [a, b, t, o] = [p(0), p(1), p(2), p(3)];
    let target = a + u * (b - a) + v * (t - a);
    let dir = (target - o) * s;
    let shear = RayShear::new(o * s, dir).unwrap_or_else(|| RayShear::new(o * s, Vec3::X).unwrap());
    (shear, [a * s, b * s, t * s].map(|p| p.to_array()))
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]

    /// The watertight test is exact under power-of-two scaling: a triangle and a ray (origin
    /// and direction) multiplied by `2^k` give the same hit, `t`, `u` and `v` bit for bit,
    /// wherever the products stay inside `f32` (|k| ≤ 30 for coordinates up to 4).
    #[test]
    fn the_triangle_test_does_not_depend_on_the_units(
        c in proptest::array::uniform12(-4.0f32..4.0),
        u in 0.0f32..1.0,
        v in 0.0f32..1.0,
        k in -30i32..=30,
    ) {
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        let hit = |k| {
            let (s, [a, b, t]) = scaled_case(c, (u, v), k);
            intersect_watertight(&s, &a, &b, &t, 0.0, f32::INFINITY)
                .map(|(t, u, v)| [t, u, v].map(f32::to_bits))
        };
        proptest::prop_assert_eq!(hit(0), hit(k));
    }

    /// A ray spawned from any point of a triangle, in any direction off its plane, never hits
    /// that triangle again, at every scale from 2⁻⁶⁰ to 2⁶⁰: the offset covers the point's own
    /// rounding error and the triangle test's error in `t`, which grows as a sliver thins
    /// (`proptest-regressions/tests/robustness.txt` keeps such a case: a triangle 6.5 units
    /// long, re-hit at `t` = 6.6e-7 when the offset covered the point's error alone).
    #[test]
    fn a_spawned_ray_never_hits_its_own_triangle(
        c in proptest::array::uniform12(-4.0f32..4.0),
        u in 0.0f32..1.0,
        v in 0.0f32..1.0,
        d in proptest::array::uniform3(-1.0f32..1.0),
        k in -60i32..=60,
    ) {
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        let s = 2f32.powi(k);
        let p = |i: usize| Vec3::new(c[3 * i], c[3 * i + 1], c[3 * i + 2]) * s;
        let scene = Scene::from_parts(
            "triangle".into(),
            vec![p(0), p(1), p(2)],
            vec![[0, 1, 2]],
            Default::default(),
        )
        .unwrap();
        proptest::prop_assume!(!scene.is_degenerate(0));
        let sp = scene.surface_point(&crate::Hit { t: 1.0, prim: 0, u, v });
        let dir = Vec3::from(d);
        proptest::prop_assume!(sp.normal != Vec3::ZERO && dir.dot(sp.normal).abs() > 1e-3);
        let ray = sp.spawn_ray(dir * s, f32::INFINITY);
        let shear = RayShear::new(ray.origin, ray.dir).unwrap();
        let [a, b, t] = scene.vertices(0).map(|p| p.to_array());
        let again = intersect_watertight(&shear, &a, &b, &t, ray.tmin, ray.tmax);
        proptest::prop_assert!(again.is_none(), "re-hit at {again:?} from {sp:?}");
    }
}

/// Boxes of every extent a float can hold build, validate and trace without a panic: huge
/// triangles (10³⁰ units, whose box areas overflow `f32`), tiny ones (10⁻³⁰), flat ones (a
/// zero side) and degenerate ones, side by side in a scene that was not normalised.
#[test]
fn a_tree_of_huge_tiny_and_flat_boxes_builds_and_traces() {
    let mut m = MeshBuilder::default();
    // Enough huge quads that whole subtrees have infinite areas.
    let sizes = [1e30f32; 40].into_iter().chain([1e-30, 1.0, 1e20, 1e-20]);
    for (i, size) in sizes.enumerate() {
        let o = Vec3::new((i % 7) as f32 * 3.0, (i / 7) as f32 * 3.0, i as f32) * size;
        m.quad(
            [
                o,
                o + Vec3::X * size,
                o + Vec3::new(1.0, 1.0, 0.0) * size,
                o + Vec3::Y * size,
            ],
            0,
        );
    }
    let (positions, mut triangles) = (m.positions, m.triangles);
    triangles.push([0, 0, 1]);
    let scene =
        Scene::from_parts("extremes".into(), positions, triangles, Default::default()).unwrap();
    for preset in [
        BuildPreset::Fastest,
        BuildPreset::Medium,
        BuildPreset::VerySlow,
    ] {
        let bvh = Bvh::build(&scene, preset).unwrap();
        validate(&bvh, &scene).unwrap();
        let mut rays = RayBatch::with_capacity(0);
        for &o in &scene.positions {
            rays.push(&Ray::new(o + Vec3::Z, -Vec3::Z));
        }
        let hits = closest_hits(&bvh, &rays);
        assert_eq!(hits.len(), scene.positions.len());
        let _ = any_hits(&bvh, &rays);
    }
}

/// Cameras far outside the scene: rays from 10² to 10⁶ scene diagonals away, aimed at the
/// scene's centre, still find the scene at the distance they were sent from, and rays aimed
/// beside it find nothing.
#[test]
fn far_cameras_still_hit_the_scene() {
    use crate::{SceneNeeds, SceneSource};
    let scene = SceneSource::parse("builtin:cornell:0.3")
        .unwrap()
        .load(SceneNeeds::AO)
        .unwrap();
    let bvh = build(&scene);
    let (b, mut rng) = (scene.bounds(), Rng::new(testkit::seed(8)));
    let (center, diag) = (b.center(), b.extent().length());
    for far in [1e2f32, 1e4, 1e6] {
        for _ in 0..64 {
            let dir = Vec3::from(rng.unit_vector());
            let o = center + dir * far * diag;
            let hit = bvh.closest_hit(&Ray::new(o, center - o));
            let hit = hit.unwrap_or_else(|| panic!("a ray from {far} diagonals away escaped"));
            // `t` is along `center - o`: the scene is met within a diagonal of the centre.
            assert!((hit.t - 1.0).abs() <= 1.0 / far, "{far}: t {}", hit.t);
            let beside = center + dir.any_orthonormal_vector() * 2.0 * diag;
            assert!(bvh.closest_hit(&Ray::new(o, beside - o)).is_none(), "{far}");
        }
    }
}
