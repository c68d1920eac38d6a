//! Wavefront OBJ (+ optional MTL) loading through tobj, with a line scan of our own in front so
//! that every error names its line (tobj reports only a kind).

use std::io::Cursor;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::file::MAX_FACE_VERTICES;
use crate::scene::{FileMesh, LoadReport, Material, SceneNeeds};
use crate::{Error, Result};

/// What the scan learnt about the file, checked against tobj's result.
struct Scan {
    vertices: usize,
    faces: usize,
    triangles: usize,
}

/// Reads the OBJ text `bytes` of `path` keeping what `needs` asks for. Primitive ids are
/// triangle indices in file order after fan triangulation (`f a b c d` gives `a b c` then
/// `a c d`).
pub(crate) fn parse(bytes: &[u8], path: &Path, needs: SceneNeeds) -> Result<FileMesh> {
    let text = decode(bytes, path)?;
    let scan = scan(&text, path)?;

    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut warnings = Vec::new();
    let (models, materials) =
        tobj::load_obj_buf(&mut Cursor::new(text.as_bytes()), &options, |p| {
            if needs.materials {
                load_mtl(&dir.join(p))
            } else {
                Ok(Default::default())
            }
        })
        .map_err(|source| Error::Obj {
            path: path.to_path_buf(),
            source,
        })?;
    let mtl: Vec<tobj::Material> = match materials {
        Ok(m) => m,
        Err(e) => {
            warnings.push(format!(
                "material library not loaded ({e}); using the default material"
            ));
            Vec::new()
        }
    };

    let mut positions: Vec<Vec3> = Vec::with_capacity(scan.vertices);
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(scan.triangles);
    let mut normals: Vec<Vec3> = Vec::new();
    let mut have_all_normals = true;
    let mut material_ids: Vec<u32> = Vec::new();
    for model in &models {
        let m = &model.mesh;
        let base = positions.len() as u32;
        positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        triangles.extend(
            m.indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
        if needs.normals {
            if m.normals.len() == m.positions.len() {
                normals.extend(
                    m.normals
                        .chunks_exact(3)
                        .map(|n| Vec3::new(n[0], n[1], n[2])),
                );
            } else {
                have_all_normals = false;
            }
        }
        if needs.materials {
            // Material 0 is the default; file materials follow.
            let id = m
                .material_id
                .filter(|&i| i < mtl.len())
                .map_or(0, |i| i as u32 + 1);
            material_ids.extend(std::iter::repeat_n(id, m.indices.len() / 3));
        }
    }
    if triangles.len() != scan.triangles {
        warnings.push(format!(
            "line scan counted {} triangles, tobj gave {}",
            scan.triangles,
            triangles.len()
        ));
    }
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        // The scan rejects non-finite input; this catches `w` scaling overflow.
        return Err(Error::Parse {
            path: path.to_path_buf(),
            line: 0,
            what: format!("vertex {} is not finite after w scaling", i + 1),
        });
    }

    Ok(FileMesh {
        positions,
        triangles,
        normals: (have_all_normals && needs.normals).then_some(normals),
        materials: mtl.iter().map(Material::from_mtl).collect(),
        material_ids,
        report: LoadReport {
            vertices: scan.vertices,
            faces: scan.faces,
            warnings,
            ..LoadReport::default()
        },
    })
}

/// Longest line read, in bytes: a polygon at [`MAX_FACE_VERTICES`] with full `v/vt/vn`
/// references fits; anything longer is not geometry a renderer should take in one line.
pub const MAX_LINE_BYTES: usize = 32 << 20;

/// Why a file that should be OBJ text is not: binary or UTF-16 data in its first bytes.
pub(crate) fn not_text(path: &Path, start: &[u8]) -> Error {
    let why = if start.starts_with(&[0xFF, 0xFE]) || start.starts_with(&[0xFE, 0xFF]) {
        "the file is UTF-16 or UTF-32 (it starts with that byte-order mark)"
    } else {
        "the file holds NUL bytes: it is binary, UTF-16 or UTF-32, not an OBJ text file"
    };
    Error::Encoding {
        path: path.to_path_buf(),
        why: why.into(),
    }
}

/// The text of the file. A UTF-8 byte-order mark is dropped (it would otherwise hide the first
/// line's keyword). Comments may be in another encoding (old files often have Latin-1 ones),
/// but every other line must be UTF-8: names and numbers read in the wrong encoding would
/// silently be wrong.
fn decode<'a>(bytes: &'a [u8], path: &Path) -> Result<std::borrow::Cow<'a, str>> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(not_text(path, bytes));
    }
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let comment = line.trim_ascii_start().starts_with(b"#");
        if !comment && std::str::from_utf8(line).is_err() {
            return Err(Error::Encoding {
                path: path.to_path_buf(),
                why: format!("line {} is not UTF-8", i + 1),
            });
        }
    }
    Ok(String::from_utf8_lossy(bytes))
}

fn load_mtl(path: &Path) -> tobj::MTLLoadResult {
    let bytes = std::fs::read(path).map_err(|_| tobj::LoadError::OpenFileFailed)?;
    let text = String::from_utf8_lossy(&bytes);
    tobj::load_mtl_buf(&mut Cursor::new(text.as_bytes()))
}

fn parse_err(path: &Path, line: usize, what: String) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line,
        what,
    }
}

/// One pass over the lines, checking what tobj would reject (or silently accept, like `nan`)
/// and remembering where.
fn scan(text: &str, path: &Path) -> Result<Scan> {
    let p: PathBuf = path.to_path_buf();
    let (mut v, mut vt, mut vn) = (0usize, 0usize, 0usize);
    let mut faces = 0usize;
    let mut triangles = 0usize;
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if line.len() > MAX_LINE_BYTES {
            return Err(parse_err(
                &p,
                line_no,
                format!(
                    "the line is {} bytes long, more than the {MAX_LINE_BYTES} a line may be",
                    line.len()
                ),
            ));
        }
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let rest: Vec<&str> = words.collect();
                if rest.len() < 3 {
                    return Err(parse_err(
                        &p,
                        line_no,
                        format!("vertex has {} coordinates, needs 3", rest.len()),
                    ));
                }
                if !matches!(rest.len(), 3 | 4 | 6) {
                    return Err(parse_err(
                        &p,
                        line_no,
                        format!("vertex has {} numbers, expected 3, 4 or 6", rest.len()),
                    ));
                }
                for (k, word) in rest.iter().enumerate() {
                    let x: f32 = word
                        .parse()
                        .map_err(|_| parse_err(&p, line_no, format!("`{word}` is not a number")))?;
                    if k < 4 && !x.is_finite() {
                        return Err(Error::NonFinite {
                            path: p.clone(),
                            line: line_no,
                            text: (*word).to_string(),
                        });
                    }
                    if k == 3 && rest.len() == 4 && x == 0.0 {
                        return Err(parse_err(&p, line_no, "vertex weight w is zero".into()));
                    }
                }
                v += 1;
            }
            Some("vt") => {
                vt += 1;
            }
            Some("vn") => {
                let ok = words.take(3).filter(|w| w.parse::<f32>().is_ok()).count() == 3;
                if !ok {
                    return Err(parse_err(&p, line_no, "normal needs 3 numbers".into()));
                }
                vn += 1;
            }
            Some("f") => {
                let mut n = 0usize;
                for word in words {
                    n += 1;
                    if n > MAX_FACE_VERTICES {
                        return Err(parse_err(
                            &p,
                            line_no,
                            format!("the face has more than {MAX_FACE_VERTICES} vertices"),
                        ));
                    }
                    for (slot, part) in word.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        let (count, what) = match slot {
                            0 => (v, "vertex"),
                            1 => (vt, "texcoord"),
                            2 => (vn, "normal"),
                            _ => {
                                return Err(parse_err(
                                    &p,
                                    line_no,
                                    format!("face vertex `{word}` has too many `/` parts"),
                                ));
                            }
                        };
                        if slot > 0 && count == 0 {
                            continue; // tobj ignores texcoord/normal refs when none are defined
                        }
                        let index: i64 = part.parse().map_err(|_| {
                            parse_err(&p, line_no, format!("face vertex `{word}` is not an index"))
                        })?;
                        let ok = (index > 0 && index as usize <= count)
                            || (index < 0 && index.unsigned_abs() as usize <= count);
                        if !ok {
                            if slot == 0 {
                                return Err(Error::IndexOutOfRange {
                                    path: p.clone(),
                                    line: line_no,
                                    index,
                                    count,
                                });
                            }
                            return Err(parse_err(
                                &p,
                                line_no,
                                format!(
                                    "{what} index {index} is out of range ({count} defined so far)"
                                ),
                            ));
                        }
                    }
                }
                if n < 3 {
                    return Err(parse_err(
                        &p,
                        line_no,
                        format!("face has {n} vertices, needs at least 3 (truncated file?)"),
                    ));
                }
                faces += 1;
                triangles += n - 2;
            }
            _ => {}
        }
    }
    Ok(Scan {
        vertices: v,
        faces,
        triangles,
    })
}
