// BVH build over every preset, validation (and that it catches breakage), built-in scenes.

use glam::Vec3;

use crate::builtin::{Builtin, MeshBuilder};
use crate::bvh::validate;
use crate::testkit;
use crate::{BuildPreset, Bvh, Ray, SceneNeeds, SceneSource};

#[test]
fn every_preset_builds_a_valid_tree() {
    let scene = SceneSource::parse("builtin:forest:0.05")
        .unwrap()
        .load(SceneNeeds::AO)
        .unwrap();
    let mut sah = Vec::new();
    for p in BuildPreset::ALL {
        let bvh = Bvh::build(&scene, p).unwrap();
        let v = validate(&bvh, &scene).unwrap_or_else(|e| panic!("{p:?}: {e}"));
        assert_eq!(v.triangles, scene.len() - scene.report.degenerate, "{p:?}");
        let r = bvh.report();
        assert!(r.sah_cost > 1.0 && r.sah_cost.is_finite(), "{p:?} {r:?}");
        assert_eq!(r.nodes + 1, bvh.nodes().len(), "all but the pad");
        sah.push(r.sah_cost);
        assert_eq!(p.name().parse::<BuildPreset>().unwrap(), p);
    }
    // Better presets should not make clearly worse trees than the fastest one.
    assert!(sah[5] < sah[0], "{sah:?}");
    assert!(sah[6] < sah[0], "{sah:?}");
}

#[test]
fn validation_catches_broken_trees() {
    let scene = testkit::icosphere(2, Vec3::ZERO, 1.0);
    let good = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    validate(&good, &scene).unwrap();

    let mut b = good.clone();
    let l = b.nodes[0].index as usize;
    b.nodes[l].max[0] += 10.0; // child sticks out of the root
    assert!(validate(&b, &scene).is_err());

    let mut b = good.clone();
    let leaf = b.nodes.iter().position(|n| n.is_leaf()).unwrap();
    b.nodes[leaf].min[1] = b.nodes[leaf].max[1]; // leaf box no longer holds its triangles
    assert!(validate(&b, &scene).is_err());

    let mut b = good.clone();
    b.tris[0].prim = b.tris[1].prim; // one triangle twice, another missing
    assert!(validate(&b, &scene).is_err());

    let mut b = good.clone();
    b.nodes[0].index = 0; // a cycle
    assert!(validate(&b, &scene).is_err());
}

#[test]
fn tiny_and_empty_trees() {
    let mut m = MeshBuilder::default();
    m.tri_points(Vec3::ZERO, Vec3::X, Vec3::Y, 0);
    let one = testkit::scene_of("one", m).unwrap();
    let bvh = Bvh::build(&one, BuildPreset::Fastest).unwrap();
    validate(&bvh, &one).unwrap();
    let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    assert_eq!(bvh.closest_hit(&r).map(|h| h.prim), Some(0));
    assert_eq!(bvh.reduced_traversal(&r).nodes, 1);

    // Degenerate triangles are left out of the tree; a scene of nothing else has nothing a
    // ray could hit, and is refused.
    let mut m = MeshBuilder::default();
    m.tri_points(Vec3::ZERO, Vec3::X, Vec3::X * 2.0, 0);
    m.tri_points(Vec3::Y, Vec3::Y, Vec3::Y, 0);
    let flat = testkit::scene_of("flat", m.clone()).unwrap();
    let e = Bvh::build(&flat, BuildPreset::Medium).unwrap_err();
    assert!(
        matches!(e, crate::Error::NothingToTrace { triangles: 2, .. }),
        "{e}"
    );
    m.tri_points(
        Vec3::Z * 5.0,
        Vec3::Z * 5.0 + Vec3::X,
        Vec3::Z * 5.0 + Vec3::Y,
        0,
    );
    let mixed = testkit::scene_of("mixed", m).unwrap();
    let bvh = Bvh::build(&mixed, BuildPreset::Medium).unwrap();
    validate(&bvh, &mixed).unwrap();
    assert_eq!(bvh.report().degenerate_skipped, 2);
    let r = Ray::new(Vec3::new(1.0, 0.0, 1.0), -Vec3::Z);
    assert!(bvh.closest_hit(&r).is_none());
}

#[test]
fn builtins_are_deterministic_and_sized() {
    let forest = Builtin::Forest.generate(1.0, SceneNeeds::AO).unwrap();
    assert!(
        (100_000..=200_000).contains(&forest.len()),
        "forest has {} triangles",
        forest.len()
    );
    // A huge range of sizes: ground triangles vs grass blades and leaves.
    let areas: Vec<f32> = (0..forest.len())
        .map(|i| forest.geometric_normal(i).length())
        .collect();
    let max = areas.iter().copied().fold(0.0, f32::max);
    let min = areas
        .iter()
        .copied()
        .filter(|&a| a > 0.0)
        .fold(f32::MAX, f32::min);
    assert!(max / min > 1e4, "area range {min} .. {max}");
    let again = Builtin::Forest.generate(1.0, SceneNeeds::AO).unwrap();
    assert_eq!(forest.positions, again.positions);

    let hair = Builtin::Hairball.generate(0.1, SceneNeeds::AO).unwrap();
    assert_eq!(hair.len(), 200 * 504);
    let bvh = Bvh::build(&hair, BuildPreset::Medium).unwrap();
    validate(&bvh, &hair).unwrap();

    let cornell = Builtin::Cornell.generate(1.0, SceneNeeds::WHITTED).unwrap();
    assert_eq!(cornell.material_ids.len(), cornell.len());
    assert!(cornell.materials.iter().any(|m| m.reflectance > 0.9));
    assert!(
        cornell
            .materials
            .iter()
            .any(|m| m.emission.max_element() > 0.0)
    );
    assert_eq!(cornell.lights.len(), 1);
    let plain = Builtin::Hairball
        .generate(0.01, SceneNeeds::WHITTED)
        .unwrap();
    assert_eq!(plain.materials, vec![crate::Material::default()]);
    assert_eq!(plain.lights.len(), 1);
}

/// A polygon of `n` vertices on a circle, fan-triangulated as the OBJ loader does: many thin
/// triangles sharing one vertex, which a cost-driven builder nests deeply.
fn fan(n: usize) -> crate::Scene {
    let mut obj = String::new();
    for k in 0..n {
        let a = k as f32 / n as f32 * std::f32::consts::TAU;
        obj += &format!("v {} {} 0\n", a.cos(), a.sin());
    }
    obj += "f";
    for k in 1..=n {
        obj += &format!(" {k}");
    }
    obj += "\n";
    let dir = std::env::temp_dir().join(format!("cobalt-rt-{}-fan-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fan.obj");
    std::fs::write(&path, obj).unwrap();
    SceneSource::File(path).load(SceneNeeds::AO).unwrap()
}

#[test]
fn a_polygon_of_many_vertices_builds_within_the_stack_with_every_preset() {
    let scene = fan(2000);
    let unbounded =
        BuildPreset::ALL.map(|p| Bvh::build_within(&scene, p, usize::MAX).unwrap().depth());
    assert!(
        unbounded.iter().any(|&d| d > crate::bvh::MAX_DEPTH),
        "the fan no longer needs the bound: {unbounded:?}"
    );
    for p in BuildPreset::ALL {
        let bvh = Bvh::build(&scene, p).unwrap_or_else(|e| panic!("{p:?}: {e}"));
        assert!(
            bvh.depth() <= crate::bvh::MAX_DEPTH,
            "{p:?}: {}",
            bvh.depth()
        );
        validate(&bvh, &scene).unwrap_or_else(|e| panic!("{p:?}: {e}"));
    }
}

/// With a tight limit, the subtrees past it are rebuilt by median: the depth holds, the tree
/// validates, and every hit is still the exact one.
#[test]
fn a_bounded_depth_keeps_exact_hits() {
    let mut rng = crate::Rng::new(testkit::seed(7));
    let scene = testkit::random_triangles(&mut rng, 3000, 10.0, 0.5);
    let free = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    // 3000 triangles in leaves of at most 4 need 11 levels; the bound must cut the tree in
    // between.
    assert!(
        free.depth() > 13,
        "the test needs a deeper tree: {}",
        free.depth()
    );
    for max in [free.depth() - 1, 13, 12] {
        let bvh = Bvh::build_within(&scene, BuildPreset::Medium, max).unwrap();
        assert!(bvh.depth() <= max, "{} > {max}", bvh.depth());
        validate(&bvh, &scene).unwrap();
        for _ in 0..2000 {
            let o = Vec3::new(rng.f32() * 24.0 - 12.0, rng.f32() * 24.0 - 12.0, -15.0);
            let to = Vec3::new(rng.f32() * 20.0 - 10.0, rng.f32() * 20.0 - 10.0, 10.0);
            let ray = Ray::new(o, to - o);
            let r = testkit::reference_closest(&scene, &ray, 1e-5, 1e-5);
            if r.ambiguous {
                continue;
            }
            let got = bvh.closest_hit(&ray).map(|h| h.prim);
            assert_eq!(got, r.hit.map(|(_, p)| p), "max depth {max}");
            assert_eq!(got, free.closest_hit(&ray).map(|h| h.prim));
        }
    }
}
