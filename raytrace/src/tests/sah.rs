// Differential tests of the binned SAH tree against obvhs's PLOC tree: on seeded random
// scenes (soups of mixed sizes, stacked copies, a fan, a grid) and random rays, the same
// closest hit (primitive and distance, bit for bit) on both layouts, and the same any-hit
// verdict.

use glam::Vec3;

use crate::builtin::MeshBuilder;
use crate::bvh::validate;
use crate::testkit;
use crate::traverse::Layout;
use crate::{BuildPreset, Bvh, Rng, Scene};

/// A random scene of about `n` triangles: small and large ones mixed, some stacked exactly on
/// others, a fan of slivers sharing a vertex and a flat grid.
fn random_scene(rng: &mut Rng, n: usize) -> Scene {
    let mut m = MeshBuilder::default();
    let point =
        |rng: &mut Rng, e: f32| Vec3::new(rng.range(-e, e), rng.range(-e, e), rng.range(-e, e));
    let mut kept: Vec<[Vec3; 3]> = Vec::new();
    for _ in 0..n {
        let c = point(rng, 10.0);
        let size = [0.05, 0.5, 4.0][rng.below(3) as usize];
        let tri = [0; 3].map(|_| c + Vec3::from(rng.unit_vector()) * size * rng.range(0.2, 1.0));
        let tri = match rng.below(16) {
            // A copy of an earlier triangle: equal distances, decided by primitive id.
            0 if !kept.is_empty() => kept[rng.below(kept.len() as u32) as usize],
            _ => tri,
        };
        kept.push(tri);
        m.tri_points(tri[0], tri[1], tri[2], 0);
    }
    let hub = point(rng, 8.0);
    let spokes = 64 + rng.below(192) as usize;
    for k in 0..spokes {
        let a = |k: usize| k as f32 / spokes as f32 * std::f32::consts::TAU;
        let rim = |k: usize| hub + Vec3::new(a(k).cos(), a(k).sin(), 0.0) * 3.0;
        m.tri_points(hub, rim(k), rim(k + 1), 0);
    }
    m.grid(
        point(rng, 8.0),
        Vec3::X * 6.0,
        Vec3::Z * 6.0,
        8 + rng.below(16),
        0,
    );
    testkit::scene_of("random", m).expect("the scene has triangles")
}

#[test]
fn sah_trees_hit_what_ploc_trees_hit() {
    let seed = testkit::seed(31);
    let mut rng = Rng::new(seed);
    for round in 0..6 {
        let n = [50, 400, 3000, 12000][round % 4];
        let scene = random_scene(&mut rng, n);
        let sah = Bvh::build(&scene, BuildPreset::Sah).unwrap();
        let ploc = Bvh::build(&scene, BuildPreset::Medium).unwrap();
        validate(&sah, &scene).unwrap_or_else(|e| panic!("round {round}: {e}"));
        assert!(!sah.report().spatial_splits);
        let rays = super::wide::rays(&scene, &mut rng, 3000);
        let mut hits = 0;
        for (i, r) in rays.iter().enumerate() {
            let at = || format!("round {round} ray {i} {r:?} (COBALT_SEED={seed})");
            let bits = |h: Option<crate::Hit>| h.map(|h| (h.prim, h.t.to_bits()));
            let want = bits(ploc.closest_hit(r));
            for layout in [Layout::Wide, Layout::Binary] {
                assert_eq!(
                    bits(sah.closest_hit_in(r, layout)),
                    want,
                    "{layout:?}: {}",
                    at()
                );
                assert_eq!(
                    sah.any_hit_in(r, layout).is_some(),
                    want.is_some(),
                    "any hit {layout:?}: {}",
                    at()
                );
            }
            hits += usize::from(want.is_some());
        }
        assert!(hits > 300, "round {round}: only {hits} rays hit");
    }
}

/// The SAH tree's cost is near the PLOC tree's (the reported cost weighs a box step as one
/// triangle test, the SAH build as three, so its leaves are a little fuller) and its leaves
/// stay small.
#[test]
fn sah_trees_are_cheap_and_deterministic() {
    let mut rng = Rng::new(testkit::seed(32));
    let scene = random_scene(&mut rng, 20000);
    let sah = Bvh::build(&scene, BuildPreset::Sah).unwrap();
    let medium = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    assert!(
        sah.report().sah_cost < 1.25 * medium.report().sah_cost,
        "{} against {}",
        sah.report().sah_cost,
        medium.report().sah_cost
    );
    assert!(
        sah.nodes()
            .iter()
            .all(|n| n.count as usize <= crate::bvh::sah::MAX_LEAF)
    );
    // Parallel at the top levels, yet the same tree on every build.
    let again = Bvh::build(&scene, BuildPreset::Sah).unwrap();
    assert_eq!(again.nodes(), sah.nodes());
    assert_eq!(again.triangles(), sah.triangles());
}

/// `auto` builds with PLOC only where a few triangles hold most of the area, and the tree
/// names the build it got.
#[test]
fn auto_picks_by_where_the_area_is() {
    let mut even = vec![1.0f32; 1000];
    assert_eq!(BuildPreset::for_areas(&mut even), BuildPreset::Sah);
    // 10 walls (1 %) of area 200 among 990 small triangles: 2000 of 2990.
    let mut room: Vec<f32> = (0..1000)
        .map(|k| if k % 100 == 7 { 200.0 } else { 1.0 })
        .collect();
    assert_eq!(BuildPreset::for_areas(&mut room), BuildPreset::Medium);
    assert_eq!(BuildPreset::for_areas(&mut []), BuildPreset::Sah);
    assert_eq!("auto".parse::<BuildPreset>(), Ok(BuildPreset::Auto));
    assert_eq!(BuildPreset::default(), BuildPreset::Auto);

    let mut rng = Rng::new(testkit::seed(33));
    let scene = random_scene(&mut rng, 2000);
    let auto = Bvh::build(&scene, BuildPreset::Auto).unwrap();
    let sah = Bvh::build(&scene, BuildPreset::Sah).unwrap();
    assert_eq!(auto.report().preset, BuildPreset::Sah);
    assert_eq!(auto.nodes(), sah.nodes());
    // One floor under everything, then a thousand specks: the floor is the largest 1 %.
    let mut m = MeshBuilder::default();
    m.quad(
        [
            Vec3::new(-1e3, 0.0, -1e3),
            Vec3::new(1e3, 0.0, -1e3),
            Vec3::new(1e3, 0.0, 1e3),
            Vec3::new(-1e3, 0.0, 1e3),
        ],
        0,
    );
    for k in 0..1000 {
        let c = Vec3::new(k as f32, 1.0, 0.0);
        m.tri_points(c, c + Vec3::X * 0.1, c + Vec3::Y * 0.1, 0);
    }
    let room = testkit::scene_of("room", m).unwrap();
    let auto = Bvh::build(&room, BuildPreset::Auto).unwrap();
    assert_eq!(auto.report().preset, BuildPreset::Medium);
}
