//! The one error type of the crate: every variant names the input that was wrong.

use std::path::PathBuf;

/// Why a scene could not be loaded or a BVH built. Messages name the file and, where one exists,
/// the 1-based line, so a user can open the file at the fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The file could not be opened or read.
    #[error("{path}: cannot read: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The file is not UTF-8 text (UTF-16 or another encoding, or binary data).
    #[error("{path}: {why}; save it as UTF-8 text")]
    Encoding {
        /// The file.
        path: PathBuf,
        /// What was found instead, and where.
        why: String,
    },
    /// The file is larger than the loader reads.
    #[error("{path}: larger than the limit of {limit} bytes")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The limit, in bytes.
        limit: u64,
    },
    /// A line could not be parsed (garbled or truncated file).
    #[error("{path}:{line}: {what}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line.
        what: String,
    },
    /// A vertex coordinate is NaN or infinite (or overflows `f32`).
    #[error("{path}:{line}: vertex coordinate `{text}` is not a finite number")]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The offending token as written.
        text: String,
    },
    /// A face refers to a vertex that does not exist (yet).
    #[error(
        "{path}:{line}: vertex index {index} is out of range ({count} vertices defined so far)"
    )]
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// The index as written (1-based, or negative for relative).
        index: i64,
        /// Vertices defined before this line.
        count: usize,
    },
    /// An element of a binary or structured scene file (a PLY record, a glTF buffer, accessor
    /// or primitive) is wrong, or is missing from a file shorter than its header promises.
    #[error("{path}: {element}: {what}")]
    Element {
        /// The file.
        path: PathBuf,
        /// Which element, as the format numbers them (`face 17`, `mesh 0 primitive 1`), with
        /// its line or byte offset where the format has them.
        element: String,
        /// What is wrong with it.
        what: String,
    },
    /// The gltf crate rejected the document (bad JSON, GLB framing or a broken reference).
    #[error("{path}: not a valid glTF 2.0 document: {source}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// The gltf crate's reason.
        source: ::gltf::Error,
    },
    /// The scene has no triangle at all (degenerate ones would count).
    #[error("{name}: the scene has no triangles")]
    EmptyScene {
        /// File path or built-in name.
        name: String,
    },
    /// Every triangle of the scene has zero area, so no ray can hit anything: its image would
    /// be the background alone.
    #[error("{name}: every one of its {triangles} triangles has zero area: no ray can hit it")]
    NothingToTrace {
        /// File path or built-in name.
        name: String,
        /// Its triangles, all degenerate.
        triangles: usize,
    },
    /// tobj rejected the file in a way our line scan did not foresee.
    #[error("{path}: OBJ error: {source}")]
    Obj {
        /// The file.
        path: PathBuf,
        /// tobj's reason.
        source: tobj::LoadError,
    },
    /// The scene argument names no known built-in or has a bad detail value.
    #[error("bad scene `{arg}`: {why}")]
    SceneArg {
        /// The argument as given.
        arg: String,
        /// What is wrong with it.
        why: String,
    },
    /// A `--devices` entry is malformed.
    #[error("bad device `{arg}`: {why}")]
    DeviceArg {
        /// The entry as given.
        arg: String,
        /// What is wrong with it.
        why: String,
    },
    /// The BVH is deeper than the traversal stack allows.
    #[error("BVH depth {depth} exceeds the traversal stack ({max})")]
    BvhTooDeep {
        /// Depth of the built tree.
        depth: usize,
        /// The largest depth traversal supports.
        max: usize,
    },
    /// `bvh::validate` found a broken invariant.
    #[error("invalid BVH: {0}")]
    InvalidBvh(String),
    /// An image could not be encoded (PNG).
    #[error("encoding a {width}x{height} PNG: {why}")]
    Encode {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// The encoder's reason.
        why: String,
    },
    /// A CPU tracer's thread pool could not be started.
    #[error("starting a pool of {threads} tracing threads: {why}")]
    ThreadPool {
        /// Threads asked for.
        threads: usize,
        /// rayon's reason.
        why: String,
    },
}
