//! The one way commands write files: every output path is checked before any work starts, and
//! all of a command's outputs replace their targets together once every one of them is ready.
//!
//! Each file is written as [`raytrace::atomic`] writes one, flushed to disk, and renamed over
//! the target: a failure at any step leaves the old outputs as they were and removes the
//! temporaries, and a replaced file keeps its permissions. `-` means standard output.

use std::fs::{self, Metadata, Permissions};
use std::io::Write;
use std::path::{Path, PathBuf};

use raytrace::atomic::{parent_dir, temporary};
use tempfile::NamedTempFile;

use crate::error::CliError;

/// A checked output: standard output, or a regular file (existing or not) in a writable
/// directory.
#[derive(Debug)]
struct Target {
    flag: &'static str,
    path: PathBuf,
    /// `None` for standard output.
    file: Option<FileTarget>,
}

#[derive(Debug)]
struct FileTarget {
    /// The directory the temporary goes to, so that the rename stays on one file system.
    dir: PathBuf,
    /// The directory, resolved, joined with the file name: what two outputs are compared by.
    canonical: PathBuf,
    /// The permissions of the file being replaced, kept on the new one.
    permissions: Option<Permissions>,
}

/// The outputs of one command, checked up front and written together by [`Outputs::commit`].
#[derive(Debug)]
pub struct Outputs {
    targets: Vec<Target>,
}

impl Outputs {
    /// Checks every output (`(flag, path)`, flags without dashes; `None` for an output not
    /// asked for) against the command's inputs (`(flag, path)`; `-` and missing files are
    /// skipped). Nothing is created or changed.
    pub fn check(
        outputs: &[(&'static str, Option<&Path>)],
        inputs: &[(&'static str, &Path)],
    ) -> Result<Self, CliError> {
        let mut targets: Vec<Target> = Vec::new();
        for &(flag, path) in outputs {
            let Some(path) = path else { continue };
            let target = check_one(flag, path, inputs)?;
            if let Some(other) = targets.iter().find(|t| same_target(t, &target)) {
                let message = match target.file {
                    None => format!("--{} already writes to standard output", other.flag),
                    Some(_) => format!("--{} already writes this file", other.flag),
                };
                return Err(bad(flag, path, message));
            }
            targets.push(target);
        }
        Ok(Self { targets })
    }

    /// Whether a file goes to standard output; the command's own report then goes to standard
    /// error, so the two never mix.
    pub fn uses_stdout(&self) -> bool {
        self.targets.iter().any(|t| t.file.is_none())
    }

    /// Prints the command's summary or JSON: on standard output, or on standard error when a
    /// file is written there.
    pub fn print(&self, text: &str) -> Result<(), CliError> {
        if self.uses_stdout() {
            let mut err = std::io::stderr().lock();
            err.write_all(text.as_bytes())
                .and_then(|()| err.flush())
                .map_err(|e| CliError::Write(e.to_string()))
        } else {
            crate::print::print_text(text)
        }
    }

    /// Prints one JSON object where [`Outputs::print`] prints.
    pub fn print_json(&self, value: &impl serde::Serialize) -> Result<(), CliError> {
        let text = serde_json::to_string(value).map_err(|e| CliError::Write(e.to_string()))?;
        self.print(&format!("{text}\n"))
    }

    /// Writes every output: `contents` gives the bytes of each flag passed to
    /// [`Outputs::check`] (an output without contents is left untouched). All files are
    /// written and flushed to temporaries first; only then do they replace their targets.
    pub fn commit(&self, contents: &[(&'static str, &[u8])]) -> Result<(), CliError> {
        let mut staged: Vec<(&Target, NamedTempFile)> = Vec::new();
        let mut to_stdout: Vec<&[u8]> = Vec::new();
        for target in &self.targets {
            let Some(&(_, bytes)) = contents.iter().find(|(f, _)| *f == target.flag) else {
                continue;
            };
            match &target.file {
                None => to_stdout.push(bytes),
                Some(file) => staged.push((target, stage(target, file, bytes)?)),
            }
        }
        // Something may have been put at a path while the command worked: check them all
        // again before the first is replaced.
        for (target, _) in &staged {
            if let Ok(meta) = fs::symlink_metadata(&target.path) {
                check_existing(target.flag, &target.path, &meta)?;
            }
        }
        for bytes in to_stdout {
            let mut out = std::io::stdout().lock();
            out.write_all(bytes)
                .and_then(|()| out.flush())
                .map_err(|e| bad("out", Path::new("-"), format!("cannot write: {e}")))?;
        }
        for (target, tmp) in staged {
            tmp.persist(&target.path).map_err(|e| {
                bad(
                    target.flag,
                    &target.path,
                    format!("cannot replace: {}", e.error),
                )
            })?;
        }
        Ok(())
    }
}

/// Writes `bytes` to a fresh temporary beside the target, with the target's permissions (or
/// those a new file gets), flushed to disk.
fn stage(target: &Target, file: &FileTarget, bytes: &[u8]) -> Result<NamedTempFile, CliError> {
    let fail = |e: std::io::Error| bad(target.flag, &target.path, format!("cannot write: {e}"));
    let mut tmp = temporary(&file.dir, &target.path).map_err(fail)?;
    tmp.write_all(bytes).map_err(fail)?;
    if let Some(permissions) = &file.permissions {
        tmp.as_file()
            .set_permissions(permissions.clone())
            .map_err(fail)?;
    }
    tmp.as_file().sync_all().map_err(fail)?;
    Ok(tmp)
}

fn check_one(
    flag: &'static str,
    path: &Path,
    inputs: &[(&'static str, &Path)],
) -> Result<Target, CliError> {
    if path == Path::new("-") {
        return Ok(Target {
            flag,
            path: path.to_owned(),
            file: None,
        });
    }
    if path.as_os_str().is_empty() {
        return Err(bad(flag, path, "the path is empty".into()));
    }
    let text = path.as_os_str().to_string_lossy();
    let Some(name) = path.file_name().filter(|_| !text.ends_with('/')) else {
        return Err(bad(flag, path, "names a directory, not a file".into()));
    };
    let dir = parent_dir(path);
    match fs::metadata(&dir) {
        Ok(meta) if meta.is_dir() => {}
        Ok(_) => {
            let message = format!("{} is not a directory", dir.display());
            return Err(bad(flag, path, message));
        }
        Err(e) => {
            let message = format!("directory {} does not exist ({e})", dir.display());
            return Err(bad(flag, path, message));
        }
    }
    let existing = match fs::symlink_metadata(path) {
        Ok(meta) => {
            check_existing(flag, path, &meta)?;
            Some(meta)
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(bad(flag, path, format!("cannot inspect: {e}"))),
    };
    if let Some(meta) = &existing {
        not_an_input(flag, path, meta, inputs)?;
        writable(flag, path, meta)?;
    }
    // The only sure test that the directory takes a new file is to make one.
    temporary(&dir, path).map_err(|e| {
        bad(
            flag,
            path,
            format!("cannot create a file in {}: {e}", dir.display()),
        )
    })?;
    let canonical = fs::canonicalize(&dir)
        .map_err(|e| bad(flag, path, format!("cannot resolve {}: {e}", dir.display())))?
        .join(name);
    Ok(Target {
        flag,
        path: path.to_owned(),
        file: Some(FileTarget {
            dir,
            canonical,
            permissions: existing.map(|m| m.permissions()),
        }),
    })
}

/// Refuses `path`, written by `--flag`, where it is (`meta`, links followed) the file an
/// input names, whatever names it: links are followed, `..` resolved, and hard links compared
/// by device and inode. An input that is `-` or does not exist cannot be replaced.
fn not_an_input(
    flag: &'static str,
    path: &Path,
    meta: &Metadata,
    inputs: &[(&'static str, &Path)],
) -> Result<(), CliError> {
    for &(input_flag, input) in inputs {
        if input == Path::new("-") || input_flag == flag {
            continue;
        }
        if fs::metadata(input).is_ok_and(|m| same_file(&m, meta)) {
            let message = format!(
                "is the file --{input_flag} reads ({}); choose another output",
                input.display()
            );
            return Err(bad(flag, path, message));
        }
    }
    Ok(())
}

/// Refuses a file written outside [`Outputs`] (the calibration, which a run reads and then
/// updates) where it is one of the command's other inputs. A file not there yet is no input.
pub fn not_input(
    flag: &'static str,
    path: &Path,
    inputs: &[(&'static str, &Path)],
) -> Result<(), CliError> {
    match fs::metadata(path) {
        Ok(meta) => not_an_input(flag, path, &meta, inputs),
        Err(_) => Ok(()),
    }
}

/// Refuses an existing output its user could not write, as `cp` would, rather than replace
/// it by a rename (which only needs the directory). The kernel decides for an ordinary user
/// (`access(2)`, ACLs included); root may write anything, so for root a file without any
/// write permission bit counts as one the user asked to be kept.
fn writable(flag: &'static str, path: &Path, meta: &Metadata) -> Result<(), CliError> {
    let refuse = |why: String| Err(bad(flag, path, why));
    if meta.permissions().readonly() {
        return refuse("is read-only; make it writable or choose another output".into());
    }
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let Ok(c_path) = std::ffi::CString::new(path.as_os_str().as_bytes()) else {
            return refuse("holds a NUL byte".into());
        };
        // SAFETY: `c_path` is a NUL-terminated string that outlives the call; `access` only
        // reads it.
        if unsafe { libc::access(c_path.as_ptr(), libc::W_OK) } != 0 {
            let e = std::io::Error::last_os_error();
            return refuse(format!(
                "cannot be written by this user ({e}); choose another output"
            ));
        }
    }
    Ok(())
}

/// Only a regular file may be replaced: a link would be replaced by a file instead of writing
/// through, and a device or FIFO is not something an output should ever land on.
fn check_existing(flag: &'static str, path: &Path, meta: &Metadata) -> Result<(), CliError> {
    let kind = meta.file_type();
    let refuse = |what: &str| Err(bad(flag, path, format!("is {what}, not a regular file")));
    if kind.is_symlink() {
        return refuse("a symbolic link; give the path it points to");
    }
    if kind.is_dir() {
        return Err(bad(flag, path, "is a directory, not a file".into()));
    }
    if !kind.is_file() {
        return refuse("a device, FIFO or socket");
    }
    Ok(())
}

fn same_target(a: &Target, b: &Target) -> bool {
    match (&a.file, &b.file) {
        (None, None) => true,
        (Some(x), Some(y)) => x.canonical == y.canonical,
        _ => false,
    }
}

#[cfg(unix)]
fn same_file(a: &Metadata, b: &Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    a.dev() == b.dev() && a.ino() == b.ino()
}

#[cfg(not(unix))]
fn same_file(_: &Metadata, _: &Metadata) -> bool {
    false
}

fn bad(flag: &'static str, path: &Path, message: String) -> CliError {
    CliError::Output {
        flag,
        path: path.to_owned(),
        message,
    }
}

/// Writes one file the way every output is written (see [`Outputs`]), for outputs not
/// yet checked up front with the command's other outputs.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let outputs = Outputs::check(&[("", Some(path))], &[])?;
    outputs.commit(&[("", bytes)])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("cobalt-output-{}-{tag}", std::process::id()));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).expect("test dir");
        d
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn all_outputs_are_written_together() {
        let d = dir("together");
        let (a, b) = (d.join("a"), d.join("b"));
        fs::write(&a, "old").unwrap();
        let outputs = Outputs::check(&[("a", Some(&a)), ("b", Some(&b))], &[]).unwrap();
        assert_eq!(names(&d), ["a"], "checking creates nothing");
        outputs.commit(&[("a", b"new a"), ("b", b"new b")]).unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"new a");
        assert_eq!(fs::read(&b).unwrap(), b"new b");
        assert_eq!(names(&d), ["a", "b"]);
    }

    #[test]
    fn a_failure_while_staging_leaves_every_old_output_and_no_temporary() {
        let d = dir("staging");
        let a = d.join("a");
        fs::write(&a, "old").unwrap();
        let sub = d.join("sub");
        fs::create_dir(&sub).unwrap();
        let b = sub.join("b");
        let outputs = Outputs::check(&[("a", Some(&a)), ("b", Some(&b))], &[]).unwrap();
        // The second output's directory goes away while the command works.
        fs::remove_dir(&sub).unwrap();
        let e = outputs.commit(&[("a", b"new"), ("b", b"new")]).unwrap_err();
        assert!(e.to_string().contains("--b"), "{e}");
        assert_eq!(fs::read(&a).unwrap(), b"old");
        assert_eq!(names(&d), ["a"]);
    }

    #[test]
    fn a_target_replaced_by_a_directory_while_working_stops_every_rename() {
        let d = dir("replaced");
        let (a, b) = (d.join("a"), d.join("b"));
        fs::write(&a, "old").unwrap();
        let outputs = Outputs::check(&[("a", Some(&a)), ("b", Some(&b))], &[]).unwrap();
        fs::create_dir(&b).unwrap();
        let e = outputs.commit(&[("a", b"new"), ("b", b"new")]).unwrap_err();
        assert!(e.to_string().contains("directory"), "{e}");
        assert_eq!(fs::read(&a).unwrap(), b"old");
        assert_eq!(names(&d), ["a", "b"]);
    }

    #[test]
    fn outputs_without_contents_are_left_alone() {
        let d = dir("untouched");
        let a = d.join("a");
        fs::write(&a, "old").unwrap();
        let outputs = Outputs::check(&[("a", Some(&a)), ("b", None)], &[]).unwrap();
        outputs.commit(&[]).unwrap();
        assert_eq!(fs::read(&a).unwrap(), b"old");
    }

    #[cfg(unix)]
    #[test]
    fn new_files_get_the_umask_permissions_not_the_temporary_ones() {
        use std::os::unix::fs::PermissionsExt;
        let d = dir("mode");
        let (a, probe) = (d.join("a"), d.join("probe"));
        fs::write(&probe, "").unwrap();
        let expected = fs::metadata(&probe).unwrap().permissions().mode() & 0o777;
        Outputs::check(&[("a", Some(&a))], &[])
            .unwrap()
            .commit(&[("a", b"x")])
            .unwrap();
        assert_eq!(
            fs::metadata(&a).unwrap().permissions().mode() & 0o777,
            expected
        );
    }
}
