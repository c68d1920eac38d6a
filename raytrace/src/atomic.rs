//! Files replaced whole: each is written to a temporary created exclusively (`O_EXCL`, a
//! random name) in the target's own directory, and renamed over the target once complete, so
//! that a reader never sees half a file and a planted link or file at a predictable name
//! cannot redirect the write. The calibration ([`crate::calibration`]) and every output of
//! the command line are written this way.

use std::fs::Permissions;
use std::path::{Path, PathBuf};

use tempfile::NamedTempFile;

/// The directory `path` names a file in: its parent, or `.` for a bare name.
pub fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_owned(),
        _ => PathBuf::from("."),
    }
}

/// An exclusively created temporary in `dir`, named after `target` so that one left by a
/// killed process says what it was for. It is removed when dropped, unless persisted over
/// the target.
///
/// # Errors
/// What the system said when the file could not be created.
pub fn temporary(dir: &Path, target: &Path) -> std::io::Result<NamedTempFile> {
    let name = target
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // A new file gets what the umask leaves of rw-rw-rw-, as one created by `open` would,
    // instead of the temporary's private default.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir)
}
