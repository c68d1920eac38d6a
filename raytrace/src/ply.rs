//! Stanford PLY scenes, ASCII or binary of either byte order: the `vertex` element's `x`, `y`
//! and `z` (of any numeric type) and the `face` element's `vertex_indices` (or `vertex_index`)
//! lists, polygons fanned into triangles as OBJ's are. Every other element and property is
//! skipped by its type. The header's counts are checked against the limits and the bytes the
//! file holds before anything is allocated.

use std::path::Path;

use glam::Vec3;

use crate::file::{MAX_ELEMENTS, MAX_FACE_VERTICES};
use crate::scene::{FileMesh, LoadReport};
use crate::{Error, Result};

/// A property's numeric type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn named(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// The value `b` (at least [`Scalar::size`] bytes) holds in this type; `f64` holds every
    /// value of every type exactly.
    fn value(self, b: &[u8], big_endian: bool) -> f64 {
        let n = self.size();
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(&b[..n]);
        if big_endian {
            a[..n].reverse();
        }
        let [a0, a1, a2, a3, ..] = a;
        match self {
            Self::I8 => f64::from(a0 as i8),
            Self::U8 => f64::from(a0),
            Self::I16 => f64::from(i16::from_le_bytes([a0, a1])),
            Self::U16 => f64::from(u16::from_le_bytes([a0, a1])),
            Self::I32 => f64::from(i32::from_le_bytes([a0, a1, a2, a3])),
            Self::U32 => f64::from(u32::from_le_bytes([a0, a1, a2, a3])),
            Self::F32 => f64::from(f32::from_le_bytes([a0, a1, a2, a3])),
            Self::F64 => f64::from_le_bytes(a),
        }
    }
}

/// A property: one value, or a list of values after their count.
#[derive(Clone, Copy, Debug)]
enum Kind {
    One(Scalar),
    List { count: Scalar, item: Scalar },
}

/// What the loader does with a property.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// A vertex coordinate: 0, 1, 2 for `x`, `y`, `z`.
    Coordinate(usize),
    /// A face's vertex indices.
    Indices,
    Skip,
}

/// An element of the header: its records' properties, in order.
#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<(Kind, Role)>,
}

impl Element {
    /// The fewest bytes a record can take: a binary record's fixed values and list counts; an
    /// ASCII record's values of one digit, each followed by a space or the end of the line.
    fn min_record_bytes(&self, ascii: bool) -> u64 {
        let bytes = |k: &Kind| match k {
            _ if ascii => 2,
            Kind::One(s) | Kind::List { count: s, .. } => s.size() as u64,
        };
        self.properties.iter().map(|(k, _)| bytes(k)).sum()
    }
}

/// Reads the PLY file `bytes` of `path`.
pub(crate) fn parse(bytes: &[u8], path: &Path) -> Result<FileMesh> {
    let bad = |element: String, what: String| Error::Element {
        path: path.to_path_buf(),
        element,
        what,
    };
    let (elements, encoding, body, header_lines) = header(bytes, path)?;
    let ascii = encoding == Encoding::Ascii;

    // Every count is checked before anything is sized by it.
    let mut least = 0u64;
    for e in &elements {
        if e.count > MAX_ELEMENTS {
            return Err(bad(
                format!("element `{}`", e.name),
                format!(
                    "the header promises {} records, more than the {MAX_ELEMENTS} a scene may have",
                    e.count
                ),
            ));
        }
        least = least.saturating_add(e.count.saturating_mul(e.min_record_bytes(ascii)));
    }
    if least > body.len() as u64 + 1 {
        return Err(bad(
            "the header".into(),
            format!(
                "its elements need at least {least} bytes, but the file holds {} after the \
                 header (truncated file?)",
                body.len()
            ),
        ));
    }
    let vertex_count = elements
        .iter()
        .find(|e| e.name == "vertex")
        .map_or(0, |e| e.count);
    let face_count = elements
        .iter()
        .find(|e| e.name == "face")
        .map_or(0, |e| e.count);
    let mut positions = Vec::with_capacity(vertex_count as usize);
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(face_count as usize);

    let mut body = match encoding {
        Encoding::Ascii => Body::Ascii {
            lines: std::str::from_utf8(body)
                .map_err(|e| {
                    bad(
                        "the body".into(),
                        format!("byte {} of the ASCII body is not text", e.valid_up_to()),
                    )
                })?
                .lines(),
            words: "".split_ascii_whitespace(),
            line: header_lines,
        },
        Encoding::Binary { big_endian } => Body::Binary {
            bytes: body,
            at: 0,
            record: 0,
            big_endian,
            offset: bytes.len() - body.len(),
        },
    };
    // A record without properties takes no bytes: nothing to read, however many.
    for e in elements.iter().filter(|e| !e.properties.is_empty()) {
        for i in 0..e.count {
            let at = |body: &Body| format!("{} {i} ({})", e.name, body.place());
            let mut record = || -> std::result::Result<(), String> {
                body.start()?;
                let mut xyz = [0.0f32; 3];
                for &(kind, role) in &e.properties {
                    match (kind, role) {
                        (Kind::One(s), Role::Coordinate(axis)) => xyz[axis] = body.coordinate(s)?,
                        (Kind::List { count, item }, Role::Indices) => {
                            face(&mut body, count, item, vertex_count, &mut triangles)?;
                        }
                        (Kind::One(s), _) => body.skip(s)?,
                        (Kind::List { count, item }, _) => {
                            let n = body.integer(count)?;
                            if n < 0 {
                                return Err(format!("a list's count is {n}"));
                            }
                            for _ in 0..n {
                                body.skip(item)?;
                            }
                        }
                    }
                }
                if e.name == "vertex" {
                    if let Some(c) = xyz.iter().find(|c| !c.is_finite()) {
                        return Err(format!("coordinate {c} is not a finite number"));
                    }
                    positions.push(Vec3::from(xyz));
                }
                body.finish()
            };
            record().map_err(|what| bad(at(&body), what))?;
        }
    }
    Ok(FileMesh {
        positions,
        triangles,
        report: LoadReport {
            vertices: vertex_count as usize,
            faces: face_count as usize,
            ..LoadReport::default()
        },
        ..FileMesh::default()
    })
}

/// Reads one face's index list, fanning it into `triangles` (`a b c d` gives `a b c` and
/// `a c d`).
fn face(
    body: &mut Body,
    count: Scalar,
    item: Scalar,
    vertices: u64,
    triangles: &mut Vec<[u32; 3]>,
) -> std::result::Result<(), String> {
    let n = body.integer(count)?;
    if n < 3 {
        return Err(format!("the face has {n} vertices, needs at least 3"));
    }
    if n as u64 > MAX_FACE_VERTICES as u64 {
        return Err(format!(
            "the face has {n} vertices, more than the {MAX_FACE_VERTICES} a face may have"
        ));
    }
    if triangles.len() as u64 + n as u64 - 2 > MAX_ELEMENTS {
        return Err(format!(
            "the faces make more than the {MAX_ELEMENTS} triangles a scene may have"
        ));
    }
    let mut index = || -> std::result::Result<u32, String> {
        let k = body.integer(item)?;
        if k < 0 || k as u64 >= vertices {
            return Err(format!(
                "vertex index {k} is out of range ({vertices} vertices)"
            ));
        }
        Ok(k as u32)
    };
    let a = index()?;
    let mut b = index()?;
    for _ in 2..n {
        let c = index()?;
        triangles.push([a, b, c]);
        b = c;
    }
    Ok(())
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encoding {
    Ascii,
    Binary { big_endian: bool },
}

/// The header's elements, the body's encoding, the body and the header's line count.
fn header<'a>(bytes: &'a [u8], path: &Path) -> Result<(Vec<Element>, Encoding, &'a [u8], usize)> {
    let bad = |line: usize, what: String| Error::Element {
        path: path.to_path_buf(),
        element: format!("header line {line}"),
        what,
    };
    let mut elements: Vec<Element> = Vec::new();
    let mut encoding = None;
    let mut rest = bytes;
    let mut line_no = 0;
    loop {
        line_no += 1;
        let Some(end) = rest.iter().position(|&b| b == b'\n') else {
            return Err(bad(
                line_no,
                "the file ends before the header's `end_header` line (truncated file?)".into(),
            ));
        };
        let line = std::str::from_utf8(&rest[..end])
            .map_err(|_| bad(line_no, "the header line is not text".into()))?;
        rest = &rest[end + 1..];
        let words: Vec<&str> = line.split_ascii_whitespace().collect();
        match words[..] {
            ["ply"] if line_no == 1 => {}
            _ if line_no == 1 => return Err(bad(1, "a PLY file starts with a `ply` line".into())),
            ["format", format, "1.0"] => {
                encoding = Some(match format {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Binary { big_endian: false },
                    "binary_big_endian" => Encoding::Binary { big_endian: true },
                    _ => return Err(bad(line_no, format!("unknown format `{format}`"))),
                });
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                if elements.iter().any(|e| e.name == name) {
                    return Err(bad(line_no, format!("a second `{name}` element")));
                }
                let count = count
                    .parse()
                    .map_err(|_| bad(line_no, format!("element count `{count}` is not a count")))?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", ..] => {
                let Some(element) = elements.last_mut() else {
                    return Err(bad(line_no, "a property before any element".into()));
                };
                let scalar = |name: &str| {
                    Scalar::named(name)
                        .ok_or_else(|| bad(line_no, format!("unknown property type `{name}`")))
                };
                let (kind, name) = match words[1..] {
                    ["list", count, item, name] => {
                        let (count, item) = (scalar(count)?, scalar(item)?);
                        if !count.is_integer() {
                            return Err(bad(line_no, "a list's count must be an integer".into()));
                        }
                        (Kind::List { count, item }, name)
                    }
                    [ty, name] => (Kind::One(scalar(ty)?), name),
                    _ => return Err(bad(line_no, format!("malformed property `{line}`"))),
                };
                let role = match (element.name.as_str(), name, kind) {
                    ("vertex", "x" | "y" | "z", Kind::One(_)) => {
                        Role::Coordinate(usize::from(name.as_bytes()[0] - b'x'))
                    }
                    ("vertex", "x" | "y" | "z", _) => {
                        return Err(bad(line_no, format!("vertex `{name}` is a list")));
                    }
                    ("face", "vertex_indices" | "vertex_index", Kind::List { item, .. }) => {
                        if !item.is_integer() {
                            return Err(bad(line_no, format!("`{name}` must hold integers")));
                        }
                        Role::Indices
                    }
                    _ => Role::Skip,
                };
                if role != Role::Skip && element.properties.iter().any(|p| p.1 == role) {
                    return Err(bad(line_no, format!("a second `{name}` property")));
                }
                element.properties.push((kind, role));
            }
            ["end_header"] => break,
            _ => return Err(bad(line_no, format!("unknown header line `{line}`"))),
        }
    }
    let Some(encoding) = encoding else {
        return Err(bad(line_no, "the header has no `format` line".into()));
    };
    let Some(vertex) = elements.iter().find(|e| e.name == "vertex") else {
        return Err(bad(line_no, "the header has no `vertex` element".into()));
    };
    for axis in 0..3 {
        if !vertex
            .properties
            .iter()
            .any(|p| p.1 == Role::Coordinate(axis))
        {
            let name = ["x", "y", "z"][axis];
            return Err(bad(line_no, format!("the vertex element has no `{name}`")));
        }
    }
    if let Some(face) = elements.iter().find(|e| e.name == "face")
        && !face.properties.iter().any(|p| p.1 == Role::Indices)
    {
        return Err(bad(
            line_no,
            "the face element has no `vertex_indices` list".into(),
        ));
    }
    Ok((elements, encoding, rest, line_no))
}

/// The body, read one value at a time.
enum Body<'a> {
    /// One record a line, values between spaces.
    Ascii {
        lines: std::str::Lines<'a>,
        words: std::str::SplitAsciiWhitespace<'a>,
        /// The line of the current record, from the start of the file.
        line: usize,
    },
    Binary {
        bytes: &'a [u8],
        /// The next value's offset in `bytes`.
        at: usize,
        /// The current record's offset in `bytes`.
        record: usize,
        big_endian: bool,
        /// The body's offset in the file.
        offset: usize,
    },
}

type Step<T> = std::result::Result<T, String>;

const ENDS: &str = "the file ends inside it (truncated file?)";

impl<'a> Body<'a> {
    /// Where the current record is, for errors.
    fn place(&self) -> String {
        match self {
            Self::Ascii { line, .. } => format!("line {line}"),
            Self::Binary { record, offset, .. } => format!("byte {}", offset + record),
        }
    }

    fn start(&mut self) -> Step<()> {
        match self {
            Self::Ascii { lines, words, line } => loop {
                let text = lines.next().ok_or(ENDS)?;
                *line += 1;
                *words = text.split_ascii_whitespace();
                if !text.trim_ascii().is_empty() {
                    return Ok(());
                }
            },
            Self::Binary { at, record, .. } => {
                *record = *at;
                Ok(())
            }
        }
    }

    fn finish(&mut self) -> Step<()> {
        match self {
            Self::Ascii { words, .. } => match words.next() {
                Some(_) => Err("the line holds more values than the header's properties".into()),
                None => Ok(()),
            },
            Self::Binary { .. } => Ok(()),
        }
    }

    /// The next value as ASCII text, or as binary bytes of `s`'s size.
    fn next(&mut self, s: Scalar) -> Step<std::result::Result<&'a str, (&'a [u8], bool)>> {
        match self {
            Self::Ascii { words, .. } => words
                .next()
                .map(Ok)
                .ok_or_else(|| "the line holds fewer values than the header's properties".into()),
            Self::Binary {
                bytes,
                at,
                big_endian,
                ..
            } => {
                let b = bytes.get(*at..*at + s.size()).ok_or(ENDS)?;
                *at += s.size();
                Ok(Err((b, *big_endian)))
            }
        }
    }

    /// The next value: an ASCII word parsed as `T` (a number as written, not through `f64`),
    /// or a binary value of type `s` converted by `from`; `what` names `T` in errors.
    fn number<T: std::str::FromStr>(
        &mut self,
        s: Scalar,
        what: &str,
        from: fn(f64) -> T,
    ) -> Step<T> {
        match self.next(s)? {
            Ok(word) => word.parse().map_err(|_| format!("`{word}` is not {what}")),
            Err((b, big)) => Ok(from(s.value(b, big))),
        }
    }

    fn coordinate(&mut self, s: Scalar) -> Step<f32> {
        self.number(s, "a number", |v| v as f32)
    }

    fn integer(&mut self, s: Scalar) -> Step<i64> {
        self.number(s, "an integer", |v| v as i64)
    }

    fn skip(&mut self, s: Scalar) -> Step<()> {
        self.next(s).map(drop)
    }
}
