//! Ray throughput on all cores, in MRays/s (criterion's "elem/s"), side by side with obvhs's own
//! CwBvh traversal on the same rays: closest-hit primary rays of the thesis's four cameras, and
//! 32-sample AO rays (any-hit, and closest-hit) from one camera's hits. Scenes: `builtin:forest`
//! and, when present, `../shared/scenes/conference.obj`.
//!
//! `load/SCENE` times bringing a scene into range (`Scene::normalise`) beside loading it whole,
//! and loading its triangles written as OBJ, PLY (ASCII and binary), glTF and GLB, so the
//! formats' loading times per triangle are read side by side.
//!
//! Run: `cargo bench --bench raytrace` (filter with e.g. `-- conference`); each group prints
//! both traversals' throughput, so the ratio to obvhs is read from one run.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3A;
use obvhs::cwbvh::{CwBvh, builder::build_cwbvh_from_tris};
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use rayon::prelude::*;
use raytrace::traverse::{any_hits, closest_hits};
use raytrace::{
    BuildPreset, Bvh, HitBatch, RayBatch, Scene, SceneNeeds, SceneSource, testkit, workload,
};
use std::hint::black_box;
use std::path::{Path, PathBuf};

/// Rays per rayon work item, as in `raytrace::traverse`.
const CHUNK: usize = 256;

/// The yardstick: obvhs's own 8-wide compressed BVH (`CwBvh`) and its traversal over a scene's
/// triangles (degenerate ones included: they never hit), with obvhs's (Möller–Trumbore, not
/// watertight) triangle test.
struct CwBvhBaseline {
    cw: CwBvh,
    tris: Vec<Triangle>,
}

impl CwBvhBaseline {
    /// Builds with the obvhs parameters of `preset`, the same ones `Bvh::build` uses.
    fn build(scene: &Scene, preset: BuildPreset) -> Self {
        let tris: Vec<Triangle> = (0..scene.len())
            .map(|i| {
                let [a, b, c] = scene.vertices(i).map(Vec3A::from);
                Triangle {
                    v0: a,
                    v1: b,
                    v2: c,
                }
            })
            .collect();
        let mut core = std::time::Duration::ZERO;
        let cw = build_cwbvh_from_tris(&tris, preset.params(), &mut core);
        Self { cw, tris }
    }

    fn ray(rays: &RayBatch, i: usize) -> obvhs::ray::Ray {
        let r = rays.get(i);
        obvhs::ray::Ray::new(r.origin.into(), r.dir.into(), r.tmin, r.tmax)
    }

    /// Closest hits of all rays, in parallel; `prim` is the scene's primitive id.
    fn closest_hits(&self, rays: &RayBatch) -> HitBatch {
        let mut out = HitBatch::misses(rays.len());
        out.t
            .par_chunks_mut(CHUNK)
            .zip(out.prim.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(c, (ts, ps))| {
                for (k, (t, p)) in ts.iter_mut().zip(ps.iter_mut()).enumerate() {
                    let mut hit = RayHit::none();
                    let cw = &self.cw;
                    if cw.ray_traverse(Self::ray(rays, c * CHUNK + k), &mut hit, |ray, id| {
                        self.tris[cw.primitive_indices[id] as usize].intersect(ray)
                    }) {
                        *t = hit.t;
                        *p = cw.primitive_indices[hit.primitive_id as usize];
                    }
                }
            });
        out
    }

    /// Whether each ray hits anything (early exit), in parallel.
    fn occluded(&self, rays: &RayBatch) -> Vec<bool> {
        (0..rays.len())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|i| {
                let cw = &self.cw;
                !cw.ray_traverse_miss(Self::ray(rays, i), |ray, id| {
                    self.tris[cw.primitive_indices[id] as usize].intersect(ray)
                })
            })
            .collect()
    }
}

fn scenes() -> Vec<(String, String)> {
    let mut s = vec![("forest".to_string(), "builtin:forest".to_string())];
    if let Some(p) = testkit::shared_scene("conference.obj") {
        s.push(("conference".into(), p.display().to_string()));
    }
    s
}

fn trace(c: &mut Criterion) {
    for (name, source) in scenes() {
        let scene = SceneSource::parse(&source)
            .and_then(|s| s.load(SceneNeeds::AO))
            .expect("bench scene loads");
        let bvh = Bvh::build(&scene, BuildPreset::Medium).expect("bvh builds");
        let cw = CwBvhBaseline::build(&scene, BuildPreset::Medium);
        let primary = workload::orbit_primary(&scene, 256, 256, 0..4);
        let ao = workload::orbit_ao(&scene, &bvh, 128, 128, 0, 32).rays;

        let mut g = c.benchmark_group(format!("trace/{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(primary.len() as u64));
        g.bench_function("primary/cobalt", |b| {
            b.iter(|| closest_hits(&bvh, black_box(&primary)))
        });
        g.bench_function("primary/obvhs-cwbvh", |b| {
            b.iter(|| cw.closest_hits(black_box(&primary)))
        });
        g.throughput(Throughput::Elements(ao.len() as u64));
        g.bench_function("ao-any/cobalt", |b| {
            b.iter(|| any_hits(&bvh, black_box(&ao)))
        });
        g.bench_function("ao-any/obvhs-cwbvh", |b| {
            b.iter(|| cw.occluded(black_box(&ao)))
        });
        g.bench_function("ao-closest/cobalt", |b| {
            b.iter(|| closest_hits(&bvh, black_box(&ao)))
        });
        g.bench_function("ao-closest/obvhs-cwbvh", |b| {
            b.iter(|| cw.closest_hits(black_box(&ao)))
        });
        g.finish();
    }
}

/// What bringing a scene into range costs on loading (`Scene::normalise`, one pass to find the
/// largest coordinate and one to scale), beside loading it whole.
fn normalise(c: &mut Criterion) {
    for (name, source) in scenes() {
        let source = SceneSource::parse(&source).expect("bench scene");
        let scene = source.load(SceneNeeds::AO).expect("bench scene loads");
        let mut g = c.benchmark_group(format!("load/{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(scene.positions.len() as u64));
        g.bench_function("normalise", |b| {
            b.iter(|| black_box(scene.clone()).normalise())
        });
        g.bench_function("load", |b| {
            b.iter(|| source.load(black_box(SceneNeeds::AO)))
        });
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("bench-formats-{name}"));
        g.throughput(Throughput::Elements(scene.len() as u64));
        for (format, path) in write_formats(&scene, &dir) {
            let file = SceneSource::File(path);
            g.bench_function(format, |b| b.iter(|| file.load(black_box(SceneNeeds::AO))));
        }
        g.finish();
    }
}

/// `scene`'s triangles, in order, as OBJ, PLY (ASCII and binary), glTF (with a buffer file)
/// and GLB in `dir`.
fn write_formats(scene: &Scene, dir: &Path) -> Vec<(&'static str, PathBuf)> {
    std::fs::create_dir_all(dir).expect("bench folder");
    let (v, t) = (&scene.positions, &scene.triangles);
    let write = |name: &str, bytes: &[u8]| {
        std::fs::write(dir.join(name), bytes).expect("bench file");
        dir.join(name)
    };
    let ply = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
             property float z\nelement face {}\nproperty list uchar uint vertex_indices\n\
             end_header\n",
            v.len(),
            t.len()
        )
    };
    let (mut obj, mut ascii, mut binary) = (
        String::new(),
        ply("ascii"),
        ply("binary_little_endian").into_bytes(),
    );
    for p in v {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
        ascii += &format!("{} {} {}\n", p.x, p.y, p.z);
        binary.extend(p.to_array().iter().flat_map(|c| c.to_le_bytes()));
    }
    let mut bin: Vec<u8> = binary[binary.len() - 12 * v.len()..].to_vec();
    for [a, b, c] in t {
        obj += &format!("f {} {} {}\n", a + 1, b + 1, c + 1);
        ascii += &format!("3 {a} {b} {c}\n");
        binary.push(3);
        for k in [a, b, c] {
            binary.extend(k.to_le_bytes());
            bin.extend(k.to_le_bytes());
        }
    }
    let bounds = scene.bounds();
    let gltf = |uri: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
            "buffers":[{{"byteLength":{}{uri}}}],"bufferViews":[{{"buffer":0,"byteLength":{}}},
            {{"buffer":0,"byteOffset":{},"byteLength":{}}}],"accessors":[{{"bufferView":0,
            "componentType":5126,"count":{},"type":"VEC3","min":{:?},"max":{:?}}},{{"bufferView":1,
            "componentType":5125,"count":{},"type":"SCALAR"}}]}}"#,
            bin.len(),
            12 * v.len(),
            12 * v.len(),
            12 * t.len(),
            v.len(),
            bounds.min.to_array(),
            bounds.max.to_array(),
            3 * t.len()
        )
    };
    let mut json = gltf("").into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut glb = b"glTF\x02\0\0\0".to_vec();
    glb.extend((28 + json.len() as u32 + bin.len() as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    write("scene.bin", &bin);
    vec![
        ("obj", write("scene.obj", obj.as_bytes())),
        ("ply-ascii", write("ascii.ply", ascii.as_bytes())),
        ("ply", write("binary.ply", &binary)),
        (
            "gltf",
            write("scene.gltf", gltf(r#","uri":"scene.bin""#).as_bytes()),
        ),
        ("glb", write("scene.glb", &glb)),
    ]
}

criterion_group!(benches, trace, normalise);
criterion_main!(benches);
