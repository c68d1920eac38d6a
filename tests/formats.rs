//! Scene formats: the same triangles in the same order render the same image, byte for byte,
//! from OBJ, PLY (ASCII, binary little- and big-endian), glTF (buffer file or data URI) and
//! GLB; a glTF node's transforms are baked as an OBJ of the placed triangles renders; a glTF
//! metallic, smooth material mirrors as an OBJ's `illum 3` one. Malformed files of each
//! format end in status 2, a message naming the file and the element, nothing written, at
//! once.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::hostile::refused;
use crate::testkit::{Rng, cobalt, temp_dir};

/// Triangles over vertices, in order, split into parts that share no vertex: a glTF writes
/// each part as a primitive of its own (`mode` 4 triangles, 5 a strip, 6 a fan), whose
/// `corners` are indices into the part's own vertices.
struct Part {
    vertices: Vec<[f32; 3]>,
    mode: u32,
    corners: Vec<u32>,
    /// A glTF material: base colour, metallic and roughness factors.
    material: Option<([f32; 3], f32, f32)>,
}

impl Part {
    /// The part's triangles as the loaders make them (strips alternate, fans turn about the
    /// first corner), in the part's own indices.
    fn triangles(&self) -> Vec<[u32; 3]> {
        let c = &self.corners;
        match self.mode {
            5 => (2..c.len())
                .map(|k| {
                    if k % 2 == 0 {
                        [c[k - 2], c[k - 1], c[k]]
                    } else {
                        [c[k - 1], c[k - 2], c[k]]
                    }
                })
                .collect(),
            6 => (2..c.len()).map(|k| [c[0], c[k - 1], c[k]]).collect(),
            _ => c.chunks(3).map(|t| [t[0], t[1], t[2]]).collect(),
        }
    }
}

/// A coordinate on a grid of 1/256: every format writes it and reads it back exactly, and the
/// transforms below (axis swaps, scale 2, half-unit moves) place it exactly in `f32`.
fn q(x: f64) -> f32 {
    ((x * 256.0).round() / 256.0) as f32
}

/// A seeded scene: a bumpy ground of triangles, a polygon above it as a fan, and a strip.
fn scene(rng: &mut Rng) -> Vec<Part> {
    let n = 8;
    let mut ground = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let (x, z) = (i as f64 / 4.0 - 1.0, j as f64 / 4.0 - 1.0);
            ground.push([q(x), q(rng.range(0.0, 0.3)), q(z)]);
        }
    }
    let at = |i: u32, j: u32| i * (n + 1) + j;
    let mut corners = Vec::new();
    for i in 0..n {
        for j in 0..n {
            corners.extend([at(i, j), at(i, j + 1), at(i + 1, j)]);
            corners.extend([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
        }
    }
    let sides = 7;
    let polygon = (0..sides)
        .map(|k| {
            let a = k as f64 / sides as f64 * std::f64::consts::TAU;
            [
                q(0.5 * a.cos()),
                q(0.8 + rng.range(0.0, 0.1)),
                q(0.5 * a.sin()),
            ]
        })
        .collect();
    let strip = (0..10)
        .map(|k| {
            let x = k as f64 / 8.0 - 0.6;
            [
                q(x),
                q(0.4 + 0.3 * (k % 2) as f64),
                q(rng.range(-0.9, -0.7)),
            ]
        })
        .collect();
    vec![
        Part {
            vertices: ground,
            mode: 4,
            corners,
            material: None,
        },
        Part {
            vertices: polygon,
            mode: 6,
            corners: (0..sides).collect(),
            material: Some(([0.75, 0.25, 0.125], 1.0, 0.5)),
        },
        Part {
            vertices: strip,
            mode: 5,
            corners: (0..10).collect(),
            material: None,
        },
    ]
}

/// Every part's vertices and triangles, the triangles indexing the whole list.
fn flat(parts: &[Part]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for p in parts {
        let base = vertices.len() as u32;
        vertices.extend(&p.vertices);
        triangles.extend(p.triangles().iter().map(|t| t.map(|k| k + base)));
    }
    (vertices, triangles)
}

/// OBJ, with `materials` an MTL beside it giving each part's material as `illum 3`.
fn write_obj(parts: &[Part], path: &Path, materials: bool) {
    let mut obj = String::new();
    let mut mtl = String::new();
    if materials {
        let name = path.with_extension("mtl");
        let name = name.file_name().expect("a name").to_string_lossy();
        obj += &format!("mtllib {name}\n");
    }
    let mut base = 1;
    for (i, p) in parts.iter().enumerate() {
        obj += &format!("o part{i}\n");
        if let (true, Some(([r, g, b], metal, rough))) = (materials, p.material) {
            let k = metal * (1.0 - rough);
            mtl += &format!("newmtl m{i}\nKd {r} {g} {b}\nKs {k} {k} {k}\nillum 3\n");
            obj += &format!("usemtl m{i}\n");
        }
        for [x, y, z] in &p.vertices {
            obj += &format!("v {x} {y} {z}\n");
        }
        if p.mode == 6 {
            // A polygon, which the OBJ loader fans.
            obj += "f";
            for c in &p.corners {
                obj += &format!(" {}", c + base);
            }
            obj += "\n";
        } else {
            for [a, b, c] in p.triangles() {
                obj += &format!("f {} {} {}\n", a + base, b + base, c + base);
            }
        }
        base += p.vertices.len() as u32;
    }
    std::fs::write(path, obj).expect("write OBJ");
    if materials {
        std::fs::write(path.with_extension("mtl"), mtl).expect("write MTL");
    }
}

/// PLY in `format` (`ascii`, `binary_little_endian`, `binary_big_endian`), with a property
/// the loader skips on each element (a list on the faces); the polygon is one face.
fn write_ply(parts: &[Part], path: &Path, format: &str) {
    let (vertices, _) = flat(parts);
    let mut faces: Vec<Vec<u32>> = Vec::new();
    let mut base = 0;
    for p in parts {
        if p.mode == 6 {
            faces.push(p.corners.iter().map(|c| c + base).collect());
        } else {
            faces.extend(p.triangles().iter().map(|t| t.map(|k| k + base).to_vec()));
        }
        base += p.vertices.len() as u32;
    }
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment written by the tests\nelement vertex {}\n\
         property double x\nproperty float y\nproperty ushort confidence\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\n\
         property list ushort float texcoord\nelement material 1\nproperty uchar red\n\
         end_header\n",
        vertices.len(),
        faces.len()
    )
    .into_bytes();
    let big = format == "binary_big_endian";
    let mut put = |bytes: &[u8]| {
        let mut b = bytes.to_vec();
        if big {
            b.reverse();
        }
        out.extend(b);
    };
    for [x, y, z] in &vertices {
        if format == "ascii" {
            put(format!("{x} {y} 7 {z}\n").as_bytes());
        } else {
            put(&f64::from(*x).to_le_bytes());
            put(&y.to_le_bytes());
            put(&7u16.to_le_bytes());
            put(&z.to_le_bytes());
        }
    }
    for f in &faces {
        if format == "ascii" {
            let list: Vec<String> = f.iter().map(u32::to_string).collect();
            put(format!("{} {} 2 0.5 0.25\n", f.len(), list.join(" ")).as_bytes());
        } else {
            put(&[f.len() as u8]);
            for k in f {
                put(&k.to_le_bytes());
            }
            put(&2u16.to_le_bytes());
            put(&0.5f32.to_le_bytes());
            put(&0.25f32.to_le_bytes());
        }
    }
    put(if format == "ascii" { b"9\n" } else { b"\x09" });
    std::fs::write(path, out).expect("write PLY");
}

/// How a glTF holds its buffer.
#[derive(Clone, Copy, PartialEq)]
enum Buffer {
    /// A `.bin` file beside the `.gltf`.
    File,
    /// A base64 `data:` URI.
    DataUri,
    /// A `.glb`'s BIN chunk.
    Glb,
}

/// glTF 2.0: one primitive a part, positions then indices (16-bit) in one buffer; `nodes` are
/// the node list (the mesh's node must be among them, the scene's root is node 0).
fn write_gltf(parts: &[Part], path: &Path, buffer: Buffer, nodes: serde_json::Value) {
    let mut bin = Vec::new();
    let (mut views, mut accessors, mut primitives, mut materials) =
        (vec![], vec![], vec![], vec![]);
    for p in parts {
        let start = bin.len();
        for v in &p.vertices {
            for c in v {
                bin.extend(c.to_le_bytes());
            }
        }
        views.push(
            serde_json::json!({"buffer": 0, "byteOffset": start, "byteLength": bin.len() - start}),
        );
        let lo: Vec<f32> = (0..3)
            .map(|a| p.vertices.iter().map(|v| v[a]).fold(f32::MAX, f32::min))
            .collect();
        let hi: Vec<f32> = (0..3)
            .map(|a| p.vertices.iter().map(|v| v[a]).fold(f32::MIN, f32::max))
            .collect();
        accessors.push(
            serde_json::json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": p.vertices.len(), "type": "VEC3", "min": lo, "max": hi}),
        );
        let start = bin.len();
        for c in &p.corners {
            bin.extend((*c as u16).to_le_bytes());
        }
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(serde_json::json!({"buffer": 0, "byteOffset": start, "byteLength": 2 * p.corners.len()}));
        accessors.push(
            serde_json::json!({"bufferView": views.len() - 1, "componentType": 5123,
            "count": p.corners.len(), "type": "SCALAR"}),
        );
        let mut primitive = serde_json::json!({"attributes": {"POSITION": accessors.len() - 2},
            "indices": accessors.len() - 1, "mode": p.mode});
        if let Some((colour, metallic, roughness)) = p.material {
            primitive["material"] = materials.len().into();
            materials.push(serde_json::json!({"pbrMetallicRoughness": {
                "baseColorFactor": [colour[0], colour[1], colour[2], 1.0],
                "metallicFactor": metallic, "roughnessFactor": roughness}}));
        }
        primitives.push(primitive);
    }
    let mut buffer_json = serde_json::json!({"byteLength": bin.len()});
    match buffer {
        Buffer::File => {
            let name = path.with_extension("bin");
            std::fs::write(&name, &bin).expect("write buffer");
            buffer_json["uri"] = name.file_name().expect("a name").to_string_lossy().into();
        }
        Buffer::DataUri => {
            buffer_json["uri"] =
                format!("data:application/octet-stream;base64,{}", base64(&bin)).into();
        }
        Buffer::Glb => {}
    }
    let doc = serde_json::json!({"asset": {"version": "2.0"}, "scene": 0,
        "scenes": [{"nodes": [0]}], "nodes": nodes, "meshes": [{"primitives": primitives}],
        "materials": materials, "buffers": [buffer_json], "bufferViews": views,
        "accessors": accessors});
    let mut json = serde_json::to_vec(&doc).expect("JSON");
    if buffer != Buffer::Glb {
        std::fs::write(path, json).expect("write glTF");
        return;
    }
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(bin);
    std::fs::write(path, glb).expect("write GLB");
}

fn base64(bytes: &[u8]) -> String {
    const DIGITS: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = c
            .iter()
            .enumerate()
            .fold(0u32, |n, (i, &b)| n | u32::from(b) << (16 - 8 * i));
        for k in 0..4 {
            out.push(if k <= c.len() {
                DIGITS[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

/// The mesh on node 0 with no transform.
fn one_node() -> serde_json::Value {
    serde_json::json!([{"mesh": 0}])
}

/// Renders `scene` with `shader` and returns the PNG's bytes.
fn png(scene: &Path, shader: &str) -> Vec<u8> {
    let out = scene.with_extension(format!("{shader}.png"));
    let o = cobalt(&[
        "render",
        "--scene",
        &scene.display().to_string(),
        "--shader",
        shader,
        "--size",
        "40x40",
        "--ao-samples",
        "4",
        "--devices",
        "cpu:1",
        "--out",
        &out.display().to_string(),
    ]);
    assert!(
        o.status.success(),
        "{}: {}",
        scene.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read(&out).expect("the PNG")
}

fn dir(tag: &str) -> PathBuf {
    let d = temp_dir("formats").join(tag);
    std::fs::create_dir_all(&d).expect("test dir");
    d
}

#[test]
fn every_format_renders_the_objs_image() {
    // PLY has no materials: every format's triangles take the default one here.
    let mut parts = scene(&mut Rng::from_env(44));
    for p in &mut parts {
        p.material = None;
    }
    let d = dir("same");
    let obj = d.join("scene.obj");
    write_obj(&parts, &obj, false);
    let mut files = Vec::new();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        files.push(d.join(format!("{format}.ply")));
        write_ply(&parts, files.last().expect("a file"), format);
    }
    for (name, buffer) in [
        ("file.gltf", Buffer::File),
        ("uri.gltf", Buffer::DataUri),
        ("scene.glb", Buffer::Glb),
    ] {
        files.push(d.join(name));
        write_gltf(&parts, files.last().expect("a file"), buffer, one_node());
    }
    for shader in ["ao", "whitted"] {
        let want = png(&obj, shader);
        for f in &files {
            assert!(
                png(f, shader) == want,
                "{} renders another {shader} image than OBJ",
                f.display()
            );
        }
    }
}

/// A glTF whose mesh sits under two nodes (moved, scaled, axes swapped; mirrored, so every
/// triangle turns round) and has a metallic, smooth material renders as the OBJ of the placed
/// triangles with the same material as MTL.
#[test]
fn gltf_transforms_and_materials_render_as_the_baked_obj() {
    let parts = scene(&mut Rng::from_env(45));
    let d = dir("baked");
    // Column-major: the parent moves by (0.5, -1, 1.5) and scales x by -2 (a mirror); the
    // child turns x to z, z to -x.
    let parent = [
        -2.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, -1.0, 1.5, 1.0,
    ];
    let child = [
        0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    let place = |[x, y, z]: [f32; 3]| {
        let [x, y, z] = [-z, y, x];
        [-2.0 * x + 0.5, y - 1.0, z + 1.5]
    };
    let baked: Vec<Part> = parts
        .iter()
        .map(|p| Part {
            vertices: p.vertices.iter().map(|&v| place(v)).collect(),
            mode: 4,
            corners: p
                .triangles()
                .iter()
                .flat_map(|&[a, b, c]| [a, c, b])
                .collect(),
            material: p.material,
        })
        .collect();
    let obj = d.join("baked.obj");
    write_obj(&baked, &obj, true);
    let gltf = d.join("placed.gltf");
    let nodes =
        serde_json::json!([{"matrix": parent, "children": [1]}, {"matrix": child, "mesh": 0}]);
    write_gltf(&parts, &gltf, Buffer::File, nodes);
    for shader in ["ao", "whitted"] {
        assert!(
            png(&gltf, shader) == png(&obj, shader),
            "{shader}: the placed glTF differs from the baked OBJ"
        );
    }
}

/// Runs `cobalt render` on `file` and checks that it is refused at once, naming the file and
/// every one of `needles`, and writes nothing.
fn refused_at_once(file: &Path, needles: &[&str]) {
    let out = file.with_extension("png");
    let start = Instant::now();
    let o = cobalt(&[
        "render",
        "--scene",
        &file.display().to_string(),
        "--size",
        "8x8",
        "--devices",
        "cpu:1",
        "--out",
        &out.display().to_string(),
    ]);
    let took = start.elapsed();
    let name = file.file_name().expect("a name").to_string_lossy();
    let mut all = vec![&*name];
    all.extend(needles);
    refused(&o, &all);
    assert!(took < Duration::from_secs(1), "{name} took {took:?}");
    assert!(!out.exists(), "{name}: an output was written");
}

#[test]
fn malformed_ply_files_are_refused_naming_the_file_and_element() {
    let parts = scene(&mut Rng::from_env(46));
    let d = dir("bad-ply");
    let good = d.join("good.ply");
    write_ply(&parts, &good, "binary_little_endian");
    let bytes = std::fs::read(&good).expect("the PLY");
    let body = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .expect("a header")
        + 11;
    let header = String::from_utf8_lossy(&bytes[..body]).into_owned();
    let vertices = flat(&parts).0.len();
    let with = |name: &str, content: &[u8], needles: &[&str]| {
        let f = d.join(name);
        std::fs::write(&f, content).expect("write");
        refused_at_once(&f, needles);
    };

    // The first face's first index past the vertices.
    let mut past = bytes.clone();
    let first_face = body + vertices * 18 + 1;
    past[first_face..first_face + 4].copy_from_slice(&(vertices as u32).to_le_bytes());
    with(
        "past.ply",
        &past,
        &["face 0", "vertex index", "out of range"],
    );
    with("cut.ply", &bytes[..bytes.len() - 30], &["truncated"]);
    with(
        "cut-header.ply",
        &bytes[..body - 5],
        &["end_header", "truncated"],
    );
    let huge = header.replacen(
        &format!("element vertex {vertices}"),
        "element vertex 1000000000000",
        1,
    );
    with(
        "huge.ply",
        huge.as_bytes(),
        &["element `vertex`", "1000000000000", "more than"],
    );
    let more = header.replacen(
        &format!("element vertex {vertices}"),
        &format!("element vertex {}", vertices + 1000),
        1,
    );
    let mut more = more.into_bytes();
    more.extend(&bytes[body..]);
    with("more.ply", &more, &["the header", "truncated"]);
    with(
        "points.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
        &["face 0 (line 13)", "needs at least 3"],
    );
    with(
        "nan.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
        &["vertex 1 (line 11)", "not a finite number"],
    );
    with(
        "short-line.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n",
        &["vertex 1 (line 11)", "fewer values"],
    );
    with(
        "no-xyz.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n",
        &["header line", "no `z`"],
    );
    with(
        "type.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\n",
        &["header line 4", "`quad`"],
    );
    with(
        "obj-inside.ply",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        &["the start of the file", "PLY"],
    );
}

#[test]
fn malformed_gltf_files_are_refused_naming_the_file_and_element() {
    let parts = scene(&mut Rng::from_env(47));
    let d = dir("bad-gltf");
    let good = d.join("good.gltf");
    write_gltf(&parts, &good, Buffer::File, one_node());
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&good).expect("glTF")).expect("JSON");
    let bin = std::fs::read(good.with_extension("bin")).expect("the buffer");
    let with = |name: &str, change: &dyn Fn(&mut serde_json::Value), needles: &[&str]| {
        let mut doc = doc.clone();
        change(&mut doc);
        let f = d.join(name);
        std::fs::write(&f, serde_json::to_vec(&doc).expect("JSON")).expect("write");
        refused_at_once(&f, needles);
    };
    let primitive = "mesh 0 primitive 0";

    // Index 999 past the ground's vertices, in place of its first.
    let mut past = bin.clone();
    let first_index = doc["bufferViews"][1]["byteOffset"]
        .as_u64()
        .expect("an offset") as usize;
    past[first_index..first_index + 2].copy_from_slice(&999u16.to_le_bytes());
    std::fs::write(d.join("past.bin"), &past).expect("write");
    with(
        "past.gltf",
        &|d| d["buffers"][0]["uri"] = "past.bin".into(),
        &[primitive, "vertex index 999", "out of range"],
    );
    std::fs::write(d.join("cut.bin"), &bin[..bin.len() / 2]).expect("write");
    with(
        "cut.gltf",
        &|d| d["buffers"][0]["uri"] = "cut.bin".into(),
        &["buffer 0", "fewer than its byteLength", "truncated"],
    );
    with(
        "points.gltf",
        &|d| d["meshes"][0]["primitives"][0]["mode"] = 0.into(),
        &[primitive, "mode Points", "not triangles"],
    );
    with(
        "lines.gltf",
        &|d| d["meshes"][0]["primitives"][1]["mode"] = 1.into(),
        &["mesh 0 primitive 1", "mode Lines"],
    );
    with(
        "count.gltf",
        &|d| d["accessors"][0]["count"] = 500_000_000.into(),
        &[primitive, "POSITION lies beyond"],
    );
    for (name, uri, needle) in [
        ("up.gltf", "../good.bin", "leaves the glTF file's folder"),
        (
            "root.gltf",
            "/etc/hostname",
            "leaves the glTF file's folder",
        ),
        ("escaped.gltf", "%2E%2E/good.bin", "leaves"),
        ("missing.gltf", "nothing.bin", "nothing.bin"),
    ] {
        with(
            name,
            &|d| d["buffers"][0]["uri"] = uri.into(),
            &["buffer 0", needle],
        );
    }
    with(
        "cycle.gltf",
        &|d| d["nodes"][0]["children"] = serde_json::json!([0]),
        &["node 0", "reached twice"],
    );
    with(
        "broken-ref.gltf",
        &|d| d["nodes"][0]["mesh"] = 7.into(),
        &["not a valid glTF"],
    );
    with(
        "vec2.gltf",
        &|d| d["accessors"][0]["type"] = "VEC2".into(),
        &[primitive, "POSITION is"],
    );

    // A GLB cut short, inside its BIN chunk and inside its JSON.
    let glb = d.join("good.glb");
    write_gltf(&parts, &glb, Buffer::Glb, one_node());
    let bytes = std::fs::read(&glb).expect("GLB");
    for (name, len) in [
        ("cut-bin.glb", bytes.len() - 40),
        ("cut-json.glb", 40),
        ("magic.glb", 6),
    ] {
        let f = d.join(name);
        std::fs::write(&f, &bytes[..len]).expect("write");
        refused_at_once(&f, &["the GLB header", "truncated"]);
    }
    // A GLB whose chunks are garbled inside an honest length.
    let mut garbled = bytes.clone();
    garbled[16..20].copy_from_slice(b"JUNK");
    let f = d.join("garbled.glb");
    std::fs::write(&f, &garbled).expect("write");
    refused_at_once(&f, &["not a valid glTF"]);
    let f = d.join("not.glb");
    std::fs::write(&f, b"v 0 0 0\n").expect("write");
    refused_at_once(&f, &["the start of the file", "glTF"]);
}

/// Every prefix of a file of each format, and the file with bytes changed at random, loads or
/// is refused with an error: the loaders never panic on what a file holds.
#[test]
fn cut_and_garbled_files_of_every_format_never_panic() {
    let mut rng = Rng::from_env(48);
    let parts = scene(&mut rng);
    let d = dir("garbled");
    let mut files = vec![d.join("a.obj")];
    write_obj(&parts, &files[0], false);
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        files.push(d.join(format!("{format}.ply")));
        write_ply(&parts, files.last().expect("a file"), format);
    }
    for (name, buffer) in [("uri.gltf", Buffer::DataUri), ("b.glb", Buffer::Glb)] {
        files.push(d.join(name));
        write_gltf(&parts, files.last().expect("a file"), buffer, one_node());
    }
    for file in &files {
        let bytes = std::fs::read(file).expect("the file");
        let probe = d.join(format!(
            "probe.{}",
            file.extension().expect("an extension").to_string_lossy()
        ));
        let load = |content: &[u8]| {
            std::fs::write(&probe, content).expect("write");
            let _ = raytrace::SceneSource::File(probe.clone()).load(raytrace::SceneNeeds::WHITTED);
        };
        let step = (bytes.len() / 400).max(1);
        for len in (0..bytes.len()).step_by(step) {
            load(&bytes[..len]);
        }
        for _ in 0..300 {
            let mut changed = bytes.clone();
            for _ in 0..1 + rng.below(4) {
                let at = rng.below(changed.len());
                changed[at] = rng.next_u64() as u8;
            }
            load(&changed);
        }
    }
}
