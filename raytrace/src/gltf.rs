//! glTF 2.0 scenes, as JSON (`.gltf`, its buffers in files beside it or in `data:` URIs) or
//! binary (`.glb`, its buffer in the BIN chunk). The gltf crate reads and checks the document;
//! the buffers are read here, so that no URI reaches outside the file's folder. Every node of
//! the scene that holds a mesh gives its triangles (strips and fans turned into triangles)
//! placed by the node's world transform, in the order the nodes are met depth first.

use std::borrow::Cow;
use std::path::{Component, Path, PathBuf};

use ::gltf::accessor::{DataType, Dimensions};
use ::gltf::mesh::Mode;
use ::gltf::{Accessor, Gltf, Node, Semantic};
use base64::Engine;
use glam::{Mat3, Mat4, Vec3};

use crate::file::{self, MAX_ELEMENTS, MAX_SCENE_BYTES};
use crate::scene::{FileMesh, LoadReport, Material, SceneNeeds};
use crate::{Error, Result};

type Step<T> = std::result::Result<T, String>;

/// A node that holds a mesh: the node's index, the mesh, and the node's world transform.
type Instance<'a> = (usize, ::gltf::Mesh<'a>, Mat4);

/// Reads the glTF or GLB file `bytes` of `path`, keeping what `needs` asks for.
pub(crate) fn parse(bytes: &[u8], path: &Path, needs: SceneNeeds) -> Result<FileMesh> {
    let bad = |element: String, what: String| Error::Element {
        path: path.to_path_buf(),
        element,
        what,
    };
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if bytes.starts_with(b"glTF") {
        // The GLB header's length, checked here so that a cut file is named as one.
        let promised = bytes
            .get(8..12)
            .map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]));
        if promised.is_none_or(|l| l as usize > bytes.len()) {
            let promised = promised.map_or("a 12-byte header".into(), |l| format!("{l} bytes"));
            return Err(bad(
                "the GLB header".into(),
                format!(
                    "it promises {promised}, but the file holds {} (truncated file?)",
                    bytes.len()
                ),
            ));
        }
    }
    let gltf = Gltf::from_slice(bytes).map_err(|source| Error::Gltf {
        path: path.to_path_buf(),
        source,
    })?;
    let buffers = buffers(&gltf, path)?;
    let instances = instances(&gltf).map_err(|(node, what)| bad(format!("node {node}"), what))?;

    // Sizes are checked before anything is allocated: a mesh placed by many nodes is copied
    // once for each, so the sum is checked as well as each accessor.
    let (mut vertices, mut triangles) = (0u64, 0u64);
    for (node, mesh, _) in &instances {
        for p in mesh.primitives() {
            let at = || format!("node {node} mesh {} primitive {}", mesh.index(), p.index());
            // Counts are believed only once the buffers are seen to hold them.
            let counted =
                |a: Accessor, what| elements(&a, &buffers, what).map(|_| a.count() as u64);
            let n = positions(&p)
                .and_then(|a| counted(a, "POSITION"))
                .map_err(|what| bad(at(), what))?;
            let corners = match p.indices() {
                Some(i) => counted(i, "indices").map_err(|what| bad(at(), what))?,
                None => n,
            };
            triangles += match p.mode() {
                Mode::Triangles if corners % 3 == 0 => corners / 3,
                Mode::Triangles => {
                    return Err(bad(
                        at(),
                        format!("{corners} corners are not whole triangles"),
                    ));
                }
                Mode::TriangleStrip | Mode::TriangleFan => corners.saturating_sub(2),
                mode => {
                    return Err(bad(
                        at(),
                        format!(
                            "mode {mode:?} is not triangles; only triangles, triangle strips \
                             and triangle fans are rendered"
                        ),
                    ));
                }
            };
            vertices += n;
        }
    }
    if vertices > MAX_ELEMENTS || triangles > MAX_ELEMENTS {
        return Err(bad(
            "the scene".into(),
            format!(
                "its nodes place {vertices} vertices and {triangles} triangles, more than the \
                 {MAX_ELEMENTS} of each a scene may have"
            ),
        ));
    }

    let mut mesh = FileMesh {
        positions: Vec::with_capacity(vertices as usize),
        triangles: Vec::with_capacity(triangles as usize),
        normals: needs.normals.then(|| Vec::with_capacity(vertices as usize)),
        materials: gltf.materials().map(|m| material(&m)).collect(),
        report: LoadReport {
            faces: triangles as usize,
            ..LoadReport::default()
        },
        ..FileMesh::default()
    };
    for (node, m, world) in &instances {
        for p in m.primitives() {
            let at = || format!("node {node} mesh {} primitive {}", m.index(), p.index());
            primitive(&mut mesh, &p, world, &buffers, needs).map_err(|what| bad(at(), what))?;
        }
    }
    Ok(mesh)
}

/// Adds one primitive, placed by `world`, to `mesh`.
fn primitive(
    mesh: &mut FileMesh,
    p: &::gltf::Primitive,
    world: &Mat4,
    buffers: &[Cow<[u8]>],
    needs: SceneNeeds,
) -> Step<()> {
    let base = mesh.positions.len();
    let (bytes, stride) = elements(&positions(p)?, buffers, "POSITION")?;
    let identity = *world == Mat4::IDENTITY;
    mesh.positions.extend(bytes.chunks(stride).map(|c| {
        let v = vec3(c);
        if identity {
            v
        } else {
            world.transform_point3(v)
        }
    }));
    if let Some(i) = mesh.positions[base..].iter().position(|v| !v.is_finite()) {
        return Err(format!("vertex {i} is not finite once placed"));
    }
    let n = mesh.positions.len() - base;

    // Normals are kept only where every primitive has them.
    let normal = p.get(&Semantic::Normals).filter(|a| {
        (a.data_type(), a.dimensions(), a.count()) == (DataType::F32, Dimensions::Vec3, n)
    });
    match (mesh.normals.as_mut(), normal) {
        (Some(normals), Some(a)) => {
            let (bytes, stride) = elements(&a, buffers, "NORMAL")?;
            let turn = Mat3::from_mat4(*world).inverse().transpose();
            normals.extend(
                bytes
                    .chunks(stride)
                    .map(|c| (turn * vec3(c)).normalize_or(Vec3::Y)),
            );
        }
        (Some(_), None) => mesh.normals = None,
        (None, _) => {}
    }

    let corners: Vec<u32> = match p.indices() {
        None => (0..n as u32).collect(),
        Some(a) => {
            let size = match (a.data_type(), a.dimensions()) {
                (DataType::U8, Dimensions::Scalar) => 1,
                (DataType::U16, Dimensions::Scalar) => 2,
                (DataType::U32, Dimensions::Scalar) => 4,
                (t, d) => return Err(format!("indices of type {t:?} {d:?}, not unsigned scalars")),
            };
            let (bytes, stride) = elements(&a, buffers, "indices")?;
            let mut all = Vec::with_capacity(a.count());
            for c in bytes.chunks(stride) {
                let k = match size {
                    1 => u32::from(c[0]),
                    2 => u32::from(u16::from_le_bytes([c[0], c[1]])),
                    _ => u32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                };
                if k as usize >= n {
                    return Err(format!("vertex index {k} is out of range ({n} vertices)"));
                }
                all.push(k);
            }
            all
        }
    };
    let at = |k: usize| base as u32 + corners[k];
    let start = mesh.triangles.len();
    match p.mode() {
        Mode::TriangleStrip => mesh.triangles.extend((2..corners.len()).map(|k| {
            // Every other triangle of a strip turns the other way; swapping its first two
            // corners keeps every triangle's winding the strip's first.
            if k % 2 == 0 {
                [at(k - 2), at(k - 1), at(k)]
            } else {
                [at(k - 1), at(k - 2), at(k)]
            }
        })),
        Mode::TriangleFan => mesh
            .triangles
            .extend((2..corners.len()).map(|k| [at(0), at(k - 1), at(k)])),
        _ => mesh
            .triangles
            .extend((0..corners.len() / 3).map(|t| [at(3 * t), at(3 * t + 1), at(3 * t + 2)])),
    }
    // A mirroring transform turns every triangle's winding.
    if world.determinant() < 0.0 {
        for t in &mut mesh.triangles[start..] {
            t.swap(1, 2);
        }
    }
    let id = p.material().index().map_or(0, |i| i as u32 + 1);
    if needs.materials {
        let added = mesh.triangles.len() - start;
        mesh.material_ids.extend(std::iter::repeat_n(id, added));
    }
    Ok(())
}

fn vec3(c: &[u8]) -> Vec3 {
    let f = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
    Vec3::new(f(0), f(4), f(8))
}

/// A primitive's `POSITION` accessor, checked to hold three floats a vertex.
fn positions<'a>(p: &::gltf::Primitive<'a>) -> Step<Accessor<'a>> {
    let a = p
        .get(&Semantic::Positions)
        .ok_or("the primitive has no POSITION attribute")?;
    match (a.data_type(), a.dimensions()) {
        (DataType::F32, Dimensions::Vec3) => Ok(a),
        (t, d) => Err(format!("POSITION is {t:?} {d:?}, not three floats")),
    }
}

/// The bytes of an accessor's elements, from its first element to the end of its last, and
/// the stride between elements: checked to lie within its view and the view within its
/// buffer's bytes, so a file shorter than it claims is an error here.
fn elements<'b>(a: &Accessor, buffers: &'b [Cow<[u8]>], what: &str) -> Step<(&'b [u8], usize)> {
    if a.sparse().is_some() {
        return Err(format!("{what} is a sparse accessor, which is not read"));
    }
    let view = a
        .view()
        .ok_or_else(|| format!("{what} has no buffer view"))?;
    let size = a.size();
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{what}'s stride {stride} is less than its element's {size} bytes"
        ));
    }
    let buffer = &buffers[view.buffer().index()];
    let beyond = || {
        format!(
            "{what} lies beyond the {} bytes of buffer {} (truncated file?)",
            buffer.len(),
            view.buffer().index()
        )
    };
    let view_bytes = view
        .offset()
        .checked_add(view.length())
        .and_then(|end| buffer.get(view.offset()..end))
        .ok_or_else(beyond)?;
    if a.count() == 0 {
        return Ok((&[], stride));
    }
    let len = (a.count() - 1)
        .checked_mul(stride)
        .and_then(|l| l.checked_add(size))
        .ok_or_else(beyond)?;
    let bytes = a
        .offset()
        .checked_add(len)
        .and_then(|end| view_bytes.get(a.offset()..end))
        .ok_or_else(beyond)?;
    Ok((bytes, stride))
}

/// Each node of the scene that holds a mesh, with the mesh and its world transform, depth
/// first in the order the scene and each node list them. The scene is the document's default,
/// else its first; a document without scenes gives every node that is no node's child.
fn instances(gltf: &Gltf) -> std::result::Result<Vec<Instance<'_>>, (usize, String)> {
    let roots: Vec<Node> = match gltf.default_scene().or_else(|| gltf.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut child = vec![false; gltf.nodes().len()];
            for c in gltf.nodes().flat_map(|n| n.children()) {
                child[c.index()] = true;
            }
            gltf.nodes().filter(|n| !child[n.index()]).collect()
        }
    };
    let mut seen = vec![false; gltf.nodes().len()];
    let mut stack: Vec<(Node, Mat4)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY))
        .collect();
    let mut out = Vec::new();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err((
                node.index(),
                "is reached twice: the node hierarchy has a cycle or a shared child".into(),
            ));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            out.push((node.index(), mesh, world));
        }
        let children: Vec<Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
    }
    Ok(out)
}

/// Every buffer's bytes: the GLB's BIN chunk, a `data:` URI's base64, or a file in the glTF
/// file's own folder (or below it). Each must hold the bytes its `byteLength` promises.
fn buffers<'a>(gltf: &'a Gltf, path: &Path) -> Result<Vec<Cow<'a, [u8]>>> {
    let mut total = 0u64;
    gltf.buffers()
        .map(|b| {
            let bad = |what: String| Error::Element {
                path: path.to_path_buf(),
                element: format!("buffer {}", b.index()),
                what,
            };
            let data: Cow<[u8]> = match b.source() {
                ::gltf::buffer::Source::Bin => Cow::Borrowed(
                    gltf.blob
                        .as_deref()
                        .ok_or_else(|| bad("the file has no BIN chunk".into()))?,
                ),
                ::gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                    Some(data) => Cow::Owned(data_uri(data).map_err(bad)?),
                    None => {
                        let file = beside(path, uri).map_err(bad)?;
                        Cow::Owned(file::read(&file, |_| Ok(())).map_err(|e| bad(e.to_string()))?)
                    }
                },
            };
            if data.len() < b.length() {
                return Err(bad(format!(
                    "it holds {} bytes, fewer than its byteLength of {} (truncated file?)",
                    data.len(),
                    b.length()
                )));
            }
            total += data.len() as u64;
            if total > MAX_SCENE_BYTES {
                return Err(Error::TooLarge {
                    path: path.to_path_buf(),
                    limit: MAX_SCENE_BYTES,
                });
            }
            Ok(data)
        })
        .collect()
}

/// The bytes of a `data:` URI (what follows `data:`), which must be base64.
fn data_uri(data: &str) -> Step<Vec<u8>> {
    let (kind, text) = data
        .split_once(',')
        .ok_or("the data URI has no `,` before its data")?;
    if !kind.ends_with(";base64") {
        return Err("the data URI is not base64".into());
    }
    base64::engine::general_purpose::STANDARD
        .decode(text)
        .map_err(|e| format!("the data URI's base64 is broken: {e}"))
}

/// The file a buffer's relative URI names, which must lie in the glTF file's folder or below
/// it: no scheme, no absolute path, no `..`, and no link leading out.
fn beside(gltf: &Path, uri: &str) -> Step<PathBuf> {
    let outside = || format!("the URI `{uri}` leaves the glTF file's folder");
    let name = percent_decoded(uri).ok_or_else(|| format!("the URI `{uri}` is malformed"))?;
    let relative = Path::new(&name);
    if name.contains(':')
        || name.is_empty()
        || !relative
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(outside());
    }
    let folder = match gltf.parent() {
        Some(f) if !f.as_os_str().is_empty() => f,
        _ => Path::new("."),
    };
    let file = folder.join(relative);
    let real = |p: &Path| {
        p.canonicalize()
            .map_err(|e| format!("cannot read `{}`: {e}", p.display()))
    };
    if !real(&file)?.starts_with(real(folder)?) {
        return Err(outside());
    }
    Ok(file)
}

/// A URI's `%XX` escapes decoded.
fn percent_decoded(uri: &str) -> Option<String> {
    let mut out = Vec::with_capacity(uri.len());
    let mut bytes = uri.bytes();
    while let Some(b) = bytes.next() {
        if b == b'%' {
            let hex = [bytes.next()?, bytes.next()?];
            out.push(u8::from_str_radix(std::str::from_utf8(&hex).ok()?, 16).ok()?);
        } else {
            out.push(b);
        }
    }
    String::from_utf8(out).ok()
}

/// A glTF material as the shaders see it: the base colour is the diffuse colour, a metallic
/// and smooth surface a mirror (reflectance `metallic · (1 − roughness)`, so a rough or
/// dielectric one mirrors nothing, as an OBJ material below `illum 3`), the emissive factor
/// the emission.
fn material(m: &::gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    Material {
        diffuse: Vec3::new(r, g, b),
        reflectance: (pbr.metallic_factor() * (1.0 - pbr.roughness_factor())).clamp(0.0, 1.0),
        emission: Vec3::from(m.emissive_factor()),
    }
}
