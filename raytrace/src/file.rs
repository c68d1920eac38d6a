//! Reading a scene file (or a file it names, as a glTF buffer) whole, up to a size limit, and
//! the limits every format's loader shares.

use std::path::Path;

use crate::{Error, Result};

/// Largest scene file read, and largest sum of a glTF's buffers: `/dev/zero` or a wrong path
/// to a huge file ends in an error instead of filling memory.
pub const MAX_SCENE_BYTES: u64 = 4 << 30;

/// Most vertices, and most triangles, a scene file may make: as many as the shortest OBJ
/// lines (`v 0 0 0`, `f 1 2 3`, 8 bytes each) of the largest file hold. A binary format's
/// header counts, and a glTF's meshes placed by many nodes, are checked against it before
/// anything is allocated.
pub const MAX_ELEMENTS: u64 = MAX_SCENE_BYTES / 8;

/// Most vertices of one face: a polygon is fanned into one triangle per vertex past the
/// second, and a face this large is damage or an attack rather than a model.
pub const MAX_FACE_VERTICES: usize = 1 << 20;

/// Bytes read at a time.
const BLOCK: usize = 1 << 16;

/// Reads the file, or standard input for `-`, up to [`MAX_SCENE_BYTES`]. `check_start` sees
/// what has been read after each read within the first block, so that a text format ends the
/// read of `/dev/zero` or binary data at once.
pub(crate) fn read(
    path: &Path,
    mut check_start: impl FnMut(&[u8]) -> Result<()>,
) -> Result<Vec<u8>> {
    use std::io::Read;
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut input: Box<dyn Read> = if path == Path::new("-") {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(std::fs::File::open(path).map_err(io)?)
    };
    let mut bytes = Vec::new();
    let mut block = vec![0u8; BLOCK];
    loop {
        let n = match input.read(&mut block) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(io(e)),
        };
        bytes.extend_from_slice(&block[..n]);
        if bytes.len() - n < BLOCK {
            check_start(&bytes)?;
        }
        if bytes.len() as u64 > MAX_SCENE_BYTES {
            return Err(Error::TooLarge {
                path: path.to_path_buf(),
                limit: MAX_SCENE_BYTES,
            });
        }
    }
    Ok(bytes)
}
