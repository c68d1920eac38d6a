// Differential tests of the 8-wide tree against the binary one, and of the batch queries
// against the per-ray ones: the same closest hits, bit for bit, on the built-in scenes with
// random, grazing and vertex- and edge-aimed rays; any-hit queries that agree on whether
// something is hit and return real hits.

use glam::Vec3;

use crate::testkit;
use crate::traverse::Layout;
use crate::{BuildPreset, Bvh, Ray, Rng, Scene, SceneNeeds, SceneSource};

fn load(name: &str, preset: BuildPreset) -> (Scene, Bvh) {
    let scene = SceneSource::parse(name)
        .and_then(|s| s.load(SceneNeeds::AO))
        .unwrap();
    let bvh = Bvh::build(&scene, preset).unwrap();
    (scene, bvh)
}

/// Random rays through the scene, rays aimed exactly at vertices and edge midpoints, and
/// grazing rays that start on a triangle and run nearly along it; some with a short range.
pub(super) fn rays(scene: &Scene, rng: &mut Rng, n: usize) -> Vec<Ray> {
    let b = scene.bounds();
    let (lo, hi) = (b.min, b.max);
    let ext = (hi - lo).max_element();
    let inside = |rng: &mut Rng| {
        Vec3::new(
            rng.range(lo.x, hi.x),
            rng.range(lo.y, hi.y),
            rng.range(lo.z, hi.z),
        )
    };
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let prim = rng.below(scene.len() as u32) as usize;
        let [a, p, q] = scene.vertices(prim);
        let r = match rng.below(4) {
            0 => Ray::new(inside(rng), Vec3::from(rng.unit_vector())),
            1 => {
                // At a vertex or an edge midpoint, from anywhere.
                let target = [a, (a + p) * 0.5, (p + q) * 0.5][rng.below(3) as usize];
                let o = inside(rng) + Vec3::from(rng.unit_vector()) * ext * 0.5;
                Ray::new(o, target - o)
            }
            2 => {
                // Grazing: from a point of the triangle, along its plane, tilted a hair.
                let nrm = (p - a).cross(q - a).normalize_or_zero();
                let along = (p - a).normalize_or_zero();
                let o = a + (p - a) * rng.f32() * 0.5 + (q - a) * rng.f32() * 0.5;
                Ray::new(o, along + nrm * rng.range(-1e-4, 1e-4))
            }
            _ => Ray::with_range(
                inside(rng),
                Vec3::from(rng.unit_vector()),
                rng.range(0.0, 0.01) * ext,
                rng.range(0.01, 0.3) * ext,
            ),
        };
        out.push(r);
    }
    out
}

fn differential(name: &str, preset: BuildPreset, seed: u64) {
    let (scene, bvh) = load(name, preset);
    let mut rng = Rng::new(seed);
    let mut hits = 0;
    let rays = rays(&scene, &mut rng, 4000);
    // The batch queries (with AVX2 where the CPU has it) equal the per-ray ones (SSE).
    let mut batch = crate::RayBatch::with_capacity(rays.len());
    for r in &rays {
        batch.push(r);
    }
    let closest = crate::traverse::closest_hits(&bvh, &batch);
    let any = crate::traverse::any_hits(&bvh, &batch);
    // Traced into a batch that held other answers, longer and shorter: the fresh batch's.
    let mut kept = crate::HitBatch {
        t: vec![1.0; rays.len() + 9],
        prim: vec![7; rays.len() + 9],
    };
    for _ in 0..2 {
        for (query, fresh) in [(true, &any), (false, &closest)] {
            crate::traverse::hits_into(&bvh, &batch, query, Layout::Wide, &mut kept);
            assert!(&kept == fresh, "{name}: kept batch, any hit {query}");
        }
        kept.t.truncate(9);
        kept.prim.truncate(9);
    }
    for (i, r) in rays.iter().enumerate() {
        let one = bvh.closest_hit(r).map(|h| (h.t.to_bits(), h.prim));
        let got = closest.get(i).map(|(t, p)| (t.to_bits(), p));
        assert_eq!(got, one, "{name} batch ray {i} {r:?} (COBALT_SEED={seed})");
        assert_eq!(any.get(i).is_some(), one.is_some(), "{name} batch any {i}");
    }
    for (i, r) in rays.iter().enumerate() {
        let at = || {
            format!(
                "{name} {} ray {i} {r:?} (COBALT_SEED={seed})",
                preset.name()
            )
        };
        let bits = |h: Option<crate::Hit>| {
            h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
        };
        let binary = bvh.closest_hit_in(r, Layout::Binary);
        let wide = bvh.closest_hit_in(r, Layout::Wide);
        assert_eq!(bits(wide), bits(binary), "closest hit: {}", at());
        assert_eq!(bits(bvh.closest_hit(r)), bits(wide), "default: {}", at());
        let (counted, _) = bvh.counted_in(r, false, Layout::Wide);
        assert_eq!(bits(counted), bits(wide), "counted: {}", at());
        hits += usize::from(wide.is_some());

        let any = bvh.any_hit_in(r, Layout::Wide);
        assert_eq!(
            any.is_some(),
            bvh.any_hit_in(r, Layout::Binary).is_some(),
            "any hit: {}",
            at()
        );
        assert_eq!(any.is_some(), wide.is_some(), "any vs closest: {}", at());
        if let Some(h) = any {
            // A real hit of that triangle, at that distance.
            let again = testkit::retest(&scene, h.prim, r);
            assert_eq!(again.map(f32::to_bits), Some(h.t.to_bits()), "{}", at());
        }
        let (counted_any, _) = bvh.counted_in(r, true, Layout::Wide);
        assert_eq!(bits(counted_any), bits(any), "counted any: {}", at());
    }
    assert!(hits > 500, "{name}: only {hits} rays hit");
}

#[test]
fn wide_equals_binary_on_forest() {
    differential(
        "builtin:forest:0.05",
        BuildPreset::Medium,
        testkit::seed(21),
    );
    differential("builtin:forest:0.05", BuildPreset::Sah, testkit::seed(21));
}

#[test]
fn wide_equals_binary_on_hairball() {
    differential(
        "builtin:hairball:0.1",
        BuildPreset::Medium,
        testkit::seed(22),
    );
}

#[test]
fn wide_equals_binary_on_cornell() {
    let seed = testkit::seed(23);
    differential("builtin:cornell:0.2", BuildPreset::Medium, seed);
    // Spatial splits put a triangle in several leaves; the smallest build, one triangle each.
    differential("builtin:cornell:0.2", BuildPreset::Slow, seed);
    differential("builtin:cornell:0.2", BuildPreset::Fastest, seed);
    differential("builtin:cornell:0.2", BuildPreset::Sah, seed);
}

/// The wide tree holds every leaf triangle of the binary tree once, plus repeats that only fill
/// groups, and does less work per ray.
/// Four AO rays from each hit of a camera's rays, with a short range, in runs by hit point.
fn ao_rays(scene: &Scene, bvh: &Bvh, rng: &mut Rng) -> Vec<Ray> {
    let ext = scene.bounds().extent().max_element();
    let camera = crate::Camera::orbit(&scene.bounds(), 1).primary_rays(48, 40);
    let mut out = Vec::new();
    for i in 0..camera.rays.len() {
        let r = camera.rays.get(i);
        let Some(h) = bvh.closest_hit(&r) else {
            continue;
        };
        let p = r.origin + r.dir * h.t;
        for _ in 0..4 {
            let d = Vec3::from(rng.unit_vector());
            out.push(Ray::with_range(
                p,
                d,
                1e-4 * ext,
                rng.range(0.02, 0.3) * ext,
            ));
        }
    }
    out
}

#[test]
fn shuffled_ao_rays_answer_as_their_single_walks() {
    // Shuffled, the batch is walked in its origins' order and scattered back; in runs, as it
    // comes. Either way each ray's answer is its single walk's, and a hit a real one.
    let seed = testkit::seed(24);
    for (name, preset) in [
        ("builtin:forest:0.05", BuildPreset::Sah),
        ("builtin:cornell:0.2", BuildPreset::Medium),
        ("builtin:hairball:0.1", BuildPreset::Sah),
    ] {
        let (scene, bvh) = load(name, preset);
        let mut rng = Rng::new(seed);
        let mut rays = ao_rays(&scene, &bvh, &mut rng);
        assert!(rays.len() > 1000, "{name}: {} AO rays", rays.len());
        for shuffled in [false, true] {
            if shuffled {
                for i in (1..rays.len()).rev() {
                    rays.swap(i, rng.below(i as u32 + 1) as usize);
                }
            }
            let batch: crate::RayBatch = rays.iter().copied().collect();
            let got = crate::traverse::any_hits(&bvh, &batch);
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let at =
                    || format!("{name} shuffled {shuffled} ray {i} {r:?} (COBALT_SEED={seed})");
                let one = bvh.any_hit(r);
                assert_eq!(got.get(i).is_some(), one.is_some(), "{}", at());
                let Some((t, prim)) = got.get(i) else {
                    continue;
                };
                hits += 1;
                let again = testkit::retest(&scene, prim, r);
                assert_eq!(again.map(f32::to_bits), Some(t.to_bits()), "{}", at());
            }
            assert!(hits > 100 && hits < rays.len(), "{name}: {hits} hits");
        }
    }
}

#[test]
fn wide_tree_holds_the_binary_leaves() {
    let (scene, bvh) = load("builtin:hairball:0.1", BuildPreset::Medium);
    let w = bvh.wide();
    let mut binary: Vec<u32> = bvh.triangles().iter().map(|t| t.prim).collect();
    let mut wide = Vec::new();
    for n in w.nodes() {
        for k in 0..crate::bvh::wide::WIDTH {
            if n.count[k] > 0 {
                let first = n.child[k] as usize;
                for j in 0..n.count[k] as usize {
                    wide.push(w.groups()[first + j / 4].prim[j % 4]);
                }
            }
        }
    }
    binary.sort_unstable();
    wide.sort_unstable();
    assert_eq!(wide, binary);
    assert!(w.nodes().len() * 2 < bvh.nodes().len());
    let mut rng = Rng::new(testkit::seed(24));
    let (mut nb, mut nw) = (0, 0);
    for r in rays(&scene, &mut rng, 500) {
        nb += bvh.counted_in(&r, false, Layout::Binary).1.nodes;
        nw += bvh.counted_in(&r, false, Layout::Wide).1.nodes;
    }
    assert!(nw < nb, "wide entered {nw} nodes, binary {nb}");
}

/// The trace left after a sample answers every other ray as the full trace does (the closest
/// hit bit for bit, any hit the same occlusion) and leaves the known rays as misses, whatever
/// their pattern: none, all, a chunk's edges, long and single gaps.
#[test]
fn tracing_all_but_known_rays_answers_the_rest_as_the_full_trace() {
    let (scene, bvh) = load("builtin:forest:0.05", BuildPreset::Medium);
    let mut rng = Rng::new(testkit::seed(24));
    // Camera rays (packets of one origin) then random ones, across several batch chunks.
    let mut batch = crate::Camera::orbit(&scene.bounds(), 0)
        .primary_rays(32, 24)
        .rays;
    for r in rays(&scene, &mut rng, 700) {
        batch.push(&r);
    }
    let n = batch.len();
    let mut every_seventh: Vec<usize> = (3..n).step_by(7).collect();
    every_seventh.push(n - 1);
    let patterns: Vec<Vec<usize>> = vec![
        vec![],
        (0..n).collect(),
        vec![0, 255, 256, 257, 511, 512, n - 1],
        (100..164).chain(600..608).chain(1000..1300).collect(),
        every_seventh,
    ];
    for any in [false, true] {
        let full = if any {
            crate::traverse::any_hits(&bvh, &batch)
        } else {
            crate::traverse::closest_hits(&bvh, &batch)
        };
        for known in &patterns {
            let rest = crate::traverse::hits_skipping(&bvh, &batch, any, known);
            // Traced slice by slice, the same packets find the same hits, to the bit.
            for count in [1, 3, 7, 100] {
                let mut sliced = crate::HitBatch::default();
                for r in crate::traverse::slices(n, count) {
                    let part =
                        crate::traverse::hits_skipping_in(&bvh, &batch, any, r.clone(), known);
                    assert_eq!(part.t.len(), r.len());
                    sliced.t.extend_from_slice(&part.t);
                    sliced.prim.extend_from_slice(&part.prim);
                }
                let bits = |h: &crate::HitBatch| -> Vec<(u32, u32)> {
                    h.t.iter()
                        .map(|t| t.to_bits())
                        .zip(h.prim.iter().copied())
                        .collect()
                };
                assert_eq!(bits(&sliced), bits(&rest), "{count} slices, any {any}");
            }
            for i in 0..n {
                let got = rest.get(i).map(|(t, p)| (t.to_bits(), p));
                let want = full.get(i).map(|(t, p)| (t.to_bits(), p));
                if known.binary_search(&i).is_ok() {
                    assert_eq!(got, None, "known ray {i} (any {any}) stays a miss");
                } else if any {
                    assert_eq!(got.is_some(), want.is_some(), "any-hit ray {i}");
                } else {
                    assert_eq!(got, want, "closest-hit ray {i}");
                }
            }
        }
    }
}

#[test]
fn slices_cover_a_batch_in_order_on_chunk_boundaries() {
    use crate::traverse::slices;
    for (len, count) in [
        (0, 4),
        (1, 4),
        (255, 2),
        (256, 2),
        (257, 2),
        (5000, 1),
        (5000, 3),
    ] {
        let got = slices(len, count);
        assert!(got.len() <= count.max(1), "{len} in {count}: {got:?}");
        let mut at = 0;
        for r in &got {
            assert_eq!(r.start, at, "{len} in {count}: {got:?}");
            assert_eq!(r.start % 256, 0, "{len} in {count}: {got:?}");
            assert!(!r.is_empty());
            at = r.end;
        }
        assert_eq!(at, len, "{len} in {count}: {got:?}");
    }
    // As even as whole chunks allow: 20 chunks in 3 slices of 6, 7 and 7.
    let lens: Vec<usize> = slices(20 * 256, 3).iter().map(|r| r.len() / 256).collect();
    assert_eq!(lens, [6, 7, 7]);
}
