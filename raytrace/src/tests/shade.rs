// Shading as generations: determinism, which generations a scene needs, mirrors, and AO.

use glam::Vec3;

use crate::builtin::MeshBuilder;
use crate::shade::{
    AoSettings, CpuTracer, RenderOptions, Rendering, Shader, WhittedSettings, render,
};
use crate::testkit::scene_of;
use crate::{BuildPreset, Bvh, Camera, RayKind, Scene, SceneNeeds, SceneSource};

const N: u32 = 64;

fn cornell(needs: SceneNeeds) -> Scene {
    SceneSource::parse("builtin:cornell")
        .unwrap()
        .load(needs)
        .unwrap()
}

/// Looking into the open side of the Cornell box, both spheres and the back wall in view.
fn front_camera() -> Camera {
    Camera::look_at(Vec3::new(0.0, 0.0, 3.4), Vec3::new(0.0, -0.2, 0.0))
}

fn run(scene: &Scene, camera: Camera, shader: Shader) -> Rendering {
    let bvh = Bvh::build(scene, BuildPreset::Medium).unwrap();
    render(
        scene,
        &mut CpuTracer::new(&bvh),
        &RenderOptions::new(N, N, camera, shader),
    )
}

fn kinds(r: &Rendering) -> Vec<RayKind> {
    r.generations.iter().map(|g| g.kind).collect()
}

/// The material of the surface pixel `(x, y)` sees first, if any.
fn material_at(scene: &Scene, bvh: &Bvh, camera: &Camera, x: u32, y: u32) -> Option<u32> {
    let hit = bvh.closest_hit(&camera.ray(x, y, N, N))?;
    Some(scene.material_ids[hit.prim as usize])
}

#[test]
fn renders_are_deterministic_whatever_the_thread_count() {
    let scene = cornell(SceneNeeds::WHITTED);
    let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    for shader in [
        Shader::Whitted(WhittedSettings::default()),
        Shader::Ao(AoSettings::default()),
    ] {
        let options = RenderOptions::new(N, N, Camera::orbit(&scene.bounds(), 1), shader);
        let a = render(&scene, &mut CpuTracer::new(&bvh), &options);
        let pool = crate::pool::thread_pool(String::from("cobalt-test"), 3).unwrap();
        let b = pool.install(|| render(&scene, &mut CpuTracer::new(&bvh), &options));
        assert_eq!(a.film, b.film, "{}", shader.name());
        assert!(a.film.pixels().iter().all(|p| p.is_finite()));
        let rays = |r: &Rendering| r.generations.iter().map(|g| g.rays).collect::<Vec<_>>();
        assert_eq!(rays(&a), rays(&b));
    }
}

#[test]
fn cornell_whitted_has_shadow_and_reflection_generations_and_mirrors_reflect() {
    let scene = cornell(SceneNeeds::WHITTED);
    let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    let camera = front_camera();
    let full = run(&scene, camera, Shader::Whitted(WhittedSettings::default()));
    let k = kinds(&full);
    assert_eq!(k[0], RayKind::Primary);
    assert_eq!(k[1], RayKind::Shadow);
    assert_eq!(k[2], RayKind::Reflection);
    assert!(full.generations.iter().all(|g| g.bounce <= 2 && g.rays > 0));
    assert_eq!(full.generations[0].rays, (N * N) as usize);
    // The first reflection generation has one ray per primary hit on a reflective material.
    let reflective = (0..N * N)
        .filter_map(|p| material_at(&scene, &bvh, &camera, p % N, p / N))
        .filter(|&m| scene.materials[m as usize].reflectance > 0.0)
        .count();
    assert!(reflective > 0);
    assert_eq!(full.generations[2].rays, reflective);
    assert!(full.trace_seconds() <= full.seconds);

    // Without bounces, mirror pixels lose their reflection; pixels of pure diffuse surfaces
    // (reflectance 0) are the same.
    let flat = run(
        &scene,
        camera,
        Shader::Whitted(WhittedSettings { bounces: 0 }),
    );
    assert!(!kinds(&flat).contains(&RayKind::Reflection));
    let (mut mirror, mut diffuse) = (0, 0);
    for p in 0..N * N {
        let (x, y) = (p % N, p / N);
        let Some(m) = material_at(&scene, &bvh, &camera, x, y) else {
            continue;
        };
        let r = scene.materials[m as usize].reflectance;
        let (a, b) = (full.film.get(x, y), flat.film.get(x, y));
        if r > 0.9 {
            mirror += 1;
            assert!(
                (a - b).length() > 1e-3,
                "mirror pixel ({x}, {y}) shows no reflection"
            );
        } else if r == 0.0 {
            diffuse += 1;
            assert_eq!(a, b, "diffuse pixel ({x}, {y})");
        }
    }
    assert!(
        mirror > 20 && diffuse > 200,
        "{mirror} mirror, {diffuse} diffuse pixels"
    );
}

#[test]
fn a_scene_without_lights_or_mirrors_traces_neither_shadow_nor_reflection_rays() {
    let mut scene = cornell(SceneNeeds::WHITTED);
    scene.set_lights(Vec::new());
    let r = run(&scene, front_camera(), Shader::Whitted(Default::default()));
    assert!(!kinds(&r).contains(&RayKind::Shadow));
    assert!(kinds(&r).contains(&RayKind::Reflection));

    for m in &mut scene.materials {
        m.reflectance = 0.0;
    }
    let r = run(&scene, front_camera(), Shader::Whitted(Default::default()));
    assert_eq!(kinds(&r), vec![RayKind::Primary]);

    // Loaded for AO (no materials, normals or lights): the default material, which reflects.
    let bare = cornell(SceneNeeds::AO);
    let r = run(&bare, front_camera(), Shader::Whitted(Default::default()));
    assert!(!kinds(&r).contains(&RayKind::Shadow));
    assert!(kinds(&r).contains(&RayKind::Reflection));
}

/// A floor `[-1, 1]²` at `y = 0`, and optionally a wall at `x = -1`, seen from above.
fn floor_scene(wall: bool) -> (Scene, Camera) {
    let mut m = MeshBuilder::default();
    let q = |a: [f32; 3], b: [f32; 3], c: [f32; 3], d: [f32; 3]| [a, b, c, d].map(Vec3::from_array);
    m.quad(
        q(
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
        ),
        0,
    );
    if wall {
        m.quad(
            q(
                [-1.0, 0.0, -1.0],
                [-1.0, 2.0, -1.0],
                [-1.0, 2.0, 1.0],
                [-1.0, 0.0, 1.0],
            ),
            0,
        );
    }
    let scene = scene_of("floor", m).unwrap();
    (
        scene,
        Camera::look_at(Vec3::new(0.0, 2.5, 0.01), Vec3::ZERO),
    )
}

/// Where pixel `(x, y)`'s ray meets the floor plane.
fn on_floor(camera: &Camera, x: u32, y: u32) -> Vec3 {
    let r = camera.ray(x, y, N, N);
    r.at(-r.origin.y / r.dir.y)
}

#[test]
fn ao_is_one_on_open_ground_and_darker_in_a_corner() {
    let (open, camera) = floor_scene(false);
    let r = run(&open, camera, Shader::Ao(AoSettings::default()));
    assert_eq!(kinds(&r), vec![RayKind::Primary, RayKind::Ao]);
    let not_one: Vec<_> = (0..N * N)
        .map(|p| (p % N, p / N))
        .filter(|&(x, y)| r.film.get(x, y) != Vec3::ONE)
        .map(|(x, y)| (x, y, r.film.get(x, y).x))
        .collect();
    assert!(not_one.is_empty(), "open ground: {not_one:?}");
    assert_eq!(r.generations[1].rays % 32, 0);

    let (corner, camera) = floor_scene(true);
    let settings = AoSettings {
        max_distance: Some(0.5),
        ..Default::default()
    };
    let r = run(&corner, camera, Shader::Ao(settings));
    // The floor pixel closest to the wall, and one far from it.
    let floor: Vec<(u32, u32, Vec3)> = (0..N * N)
        .map(|p| (p % N, p / N))
        .map(|(x, y)| (x, y, on_floor(&camera, x, y)))
        .filter(|(_, _, p)| p.x > -1.0 && p.x < 1.0 && p.z.abs() < 0.5)
        .collect();
    let near = floor.iter().min_by(|a, b| a.2.x.total_cmp(&b.2.x)).unwrap();
    let far = floor.iter().max_by(|a, b| a.2.x.total_cmp(&b.2.x)).unwrap();
    let (dark, light) = (r.film.get(near.0, near.1).x, r.film.get(far.0, far.1).x);
    assert!(near.2.x < -0.9 && far.2.x > 0.6, "{near:?} {far:?}");
    assert_eq!(light, 1.0);
    assert!(dark < 0.8, "corner AO {dark}");
}

#[test]
fn primary_counts_cover_every_pixel() {
    let scene = cornell(SceneNeeds::AO);
    let bvh = Bvh::build(&scene, BuildPreset::Medium).unwrap();
    let counts = crate::cost_image::primary_counts(&bvh, &front_camera(), N, N / 2);
    assert_eq!(counts.len(), (N * N / 2) as usize);
    // Counts land on their own pixel (row-major, not Morton order): each is its ray's count
    // in the batch trace of the frame's rays (which walks neighbours together, so a count
    // can differ from the ray's single walk).
    let primary = front_camera().primary_rays(N, N / 2);
    let (_, batch) = crate::traverse::closest_hits_counted(&bvh, &primary.rays);
    for (c, &p) in batch.iter().zip(&primary.pixels) {
        assert_eq!(counts[p as usize], *c, "pixel {p}");
    }
    assert!(counts.iter().any(|c| c.nodes > 0 && c.tris > 0));
    let img = crate::cost_image::cost_image(&counts, N, N / 2);
    assert_eq!((img.width(), img.height()), (2 * N, N / 2));
}
