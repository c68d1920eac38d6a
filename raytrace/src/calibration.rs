//! What a run learnt about the machine, kept for the next run: per host, device class and
//! workload, the device's speed (relative, and in paths per second) and its cost model's `kR`,
//! `kB`, `kT`, so that the first plan of a run is made with what the last one measured rather
//! than with equal speeds; and per set of device classes, workload and mode, whether frames
//! ran faster on every device or on the fastest class alone.
//!
//! The file is JSON: `{"version": 1, "entries": [{"host", "device", "workload", "speed",
//! "paths_per_second", "kr", "kb", "kt", "samples", "spikes"}, …], "choices": [{"host",
//! "devices", "workload", "mode", "shader", "all_seconds_per_path", "alone_seconds_per_path",
//! "fastest"}, …]}` (`paths_per_second`, `choices` and a choice's figures may be absent; `kr`
//! too, read as 0). By default it lives in the user's cache directory ([`default_path`]).
//!
//! A missing file is an empty calibration. A file that cannot be parsed, or holds a value no
//! plan can use, is a [`CalibrationError`] naming the file and the line or entry: the caller
//! decides whether that is fatal (a file the user named) or a warning and a fresh start (the
//! default cache, which a crash or another program may have damaged). Writing goes through a
//! temporary in the same directory renamed over the file, so a reader never sees half a file.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::fs;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::atomic;
use crate::cost::CostModel;

/// The version of the file format this module reads and writes.
pub const FORMAT_VERSION: u32 = 1;

/// Larger files are refused unread: a calibration holds a few entries per device and scene,
/// so anything this big is not one.
const MAX_BYTES: u64 = 16 << 20;

/// What an entry is about: which machine, which of its devices (the renderer's device class,
/// e.g. `cpu/4`), and which workload (scene and shader).
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct Key {
    /// The host name ([`host_name`]).
    pub host: String,
    /// The device class, as the renderer names it.
    pub device: String,
    /// The scene and shader, as the caller names them.
    pub workload: String,
}

impl Key {
    /// The key of `device` on `host` for `workload`.
    pub fn new(host: &str, device: &str, workload: &str) -> Self {
        Self {
            host: host.to_owned(),
            device: device.to_owned(),
            workload: workload.to_owned(),
        }
    }
}

/// What was learnt about one device on one workload, as the file keeps it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Speed relative to the fastest device of the run that measured it (finite, > 0).
    pub speed: f64,
    /// Paths one device of the class rendered per second over the run's launches (finite and
    /// positive): unlike `speed`, comparable across runs, so the first plan takes its speeds
    /// from these. Absent in older files.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub paths_per_second: Option<f64>,
    /// `kR` of the model fitted to the device's measured launch times ([`Entry::model`]);
    /// absent in files written before the per-ray term, and read as 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kr: Option<f64>,
    /// `kB` of the fitted model, if a fit was made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kb: Option<f64>,
    /// `kT` of the fitted model, if a fit was made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kt: Option<f64>,
    /// Launches learnt from, over every run that updated the entry.
    #[serde(default)]
    pub samples: u64,
    /// Launches left out as timing spikes, over every run that updated the entry.
    #[serde(default)]
    pub spikes: u64,
}

impl Entry {
    /// The model fitted to the device's launch times, if a fit was made.
    pub fn model(&self) -> Option<CostModel> {
        let (kb, kt) = (self.kb?, self.kt?);
        let kr = self.kr.unwrap_or(0.0);
        Some(CostModel { kr, kb, kt })
    }

    /// Sets the fitted model's constants (none for `None`).
    pub fn set_model(&mut self, model: Option<CostModel>) {
        self.kr = model.map(|m| m.kr);
        self.kb = model.map(|m| m.kb);
        self.kt = model.map(|m| m.kt);
    }

    /// The first value no plan can use, as its field, the value and what is wrong with it.
    fn fault(&self) -> Option<(&'static str, f64, &'static str)> {
        const POSITIVE: &str = "is not a finite number > 0";
        if !positive(self.speed) {
            return Some(("speed", self.speed, POSITIVE));
        }
        if let Some(v) = self.paths_per_second.filter(|&v| !positive(v)) {
            return Some(("paths_per_second", v, POSITIVE));
        }
        let m = match (self.kb, self.kt) {
            (None, None) => return self.kr.map(|v| ("kr", v, "comes without kb and kt")),
            (Some(v), None) => return Some(("kb", v, "comes without kt")),
            (None, Some(v)) => return Some(("kt", v, "comes without kb")),
            (Some(_), Some(_)) => self.model()?,
        };
        let constants = [("kr", m.kr), ("kb", m.kb), ("kt", m.kt)];
        if let Some((field, v)) =
            (constants.into_iter()).find(|(_, v)| !(v.is_finite() && *v >= 0.0))
        {
            return Some((field, v, "is not a finite number >= 0"));
        }
        (m.kb + m.kt <= 0.0).then_some(("kb + kt", m.kb + m.kt, "is not > 0"))
    }
}

/// Why a calibration file could not be read or written. Every message names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CalibrationError {
    /// The file exists but could not be read.
    #[error("{path}: cannot read the calibration file: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// The file is larger than any calibration.
    #[error("{path}: larger than {limit} bytes; not a calibration file")]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The limit, in bytes.
        limit: u64,
    },
    /// The file is not JSON of the calibration's shape.
    #[error("{path}:{line}:{column}: not a calibration file: {why}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line of the fault.
        line: usize,
        /// 1-based column of the fault.
        column: usize,
        /// What the parser expected.
        why: String,
    },
    /// The file is a calibration of another format version.
    #[error(
        "{path}: calibration format version {found}, this build reads version {FORMAT_VERSION}"
    )]
    Version {
        /// The file.
        path: PathBuf,
        /// The version the file says it is.
        found: u32,
    },
    /// An entry holds a value no plan can use (a speed of 0, a negative coefficient, …).
    #[error("{path}: entry {entry} ({key}): {field} = {value} {why}")]
    BadValue {
        /// The file.
        path: PathBuf,
        /// 0-based index of the entry (or of the choice) in the file.
        entry: usize,
        /// Its key: `DEVICE on HOST, WORKLOAD` (`choice of DEVICES on HOST, WORKLOAD`).
        key: String,
        /// The field.
        field: &'static str,
        /// The value found.
        value: f64,
        /// What it should have been.
        why: &'static str,
    },
    /// Another run held the file's lock for longer than [`LOCK_WAIT`].
    #[error("{path}: another run has held the calibration's lock ({lock}) for {waited} s")]
    Locked {
        /// The calibration file.
        path: PathBuf,
        /// The lock file beside it.
        lock: PathBuf,
        /// Seconds waited.
        waited: u64,
    },
    /// The file (or its directory, or the temporary beside it) could not be written.
    #[error("{path}: cannot write the calibration file: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
}

/// Where a [`Choice`] applies: the host, a set of device classes, the workload, the mode's
/// name (`regular`, `cost`) and the shader's (`ao`, `whitted`), as the file spells them.
#[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
pub struct ChoiceKey {
    /// The host name ([`host_name`]).
    pub host: String,
    /// The device classes, sorted and joined by ` + ` ([`device_set`]).
    pub devices: String,
    /// The scene and shader, as the caller names them.
    pub workload: String,
    /// The mode's name.
    pub mode: String,
    /// The shader's name: the renderer keeps its choices per shader.
    pub shader: String,
}

/// What frames on one set of device classes measured of running on every device or on the
/// fastest class alone (see [`crate::paths::PathRenderer::render`]), for one workload, mode
/// and shader: the seconds per path of the latest frame rendered each way, where one was, and
/// the class that renders alone.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Choice {
    /// On every device (finite and positive).
    #[serde(
        rename = "all_seconds_per_path",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub all: Option<f64>,
    /// On the devices of the fastest class alone (finite and positive).
    #[serde(
        rename = "alone_seconds_per_path",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub alone: Option<f64>,
    /// The fastest class, as the speeds known after the first frame measured said: kept, so
    /// that a renderer that starts without speeds (a bench's next cell) leaves the same
    /// devices idle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fastest: Option<String>,
}

impl Choice {
    /// The first time that is not finite and positive, as its field, the time and what is
    /// wrong with it.
    fn fault(&self) -> Option<(&'static str, f64, &'static str)> {
        let times = [
            ("all_seconds_per_path", self.all),
            ("alone_seconds_per_path", self.alone),
        ];
        let (field, v) = times
            .into_iter()
            .find(|(_, v)| v.is_some_and(|v| !positive(v)))?;
        Some((field, v?, "is not a finite number > 0"))
    }
}

/// The name of a set of device classes in a [`ChoiceKey`].
pub fn device_set<'c>(classes: impl IntoIterator<Item = &'c str>) -> String {
    let mut names: Vec<&str> = classes.into_iter().collect();
    names.sort_unstable();
    names.dedup();
    names.join(" + ")
}

/// The entries of a calibration file, in memory.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Calibration {
    entries: BTreeMap<Key, Entry>,
    choices: BTreeMap<ChoiceKey, Choice>,
}

/// The file as written: a version, and the entries and choices with their keys spelled out.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    version: u32,
    entries: Vec<Keyed<Key, Entry>>,
    /// Absent in files written before the renderer chose its devices.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    choices: Vec<Keyed<ChoiceKey, Choice>>,
}

/// An entry or a choice of the file: its key's fields, then its own.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Keyed<K, V> {
    #[serde(flatten)]
    key: K,
    #[serde(flatten)]
    value: V,
}

impl<K: Clone, V: Clone> Keyed<K, V> {
    fn of((key, value): (&K, &V)) -> Self {
        Self {
            key: key.clone(),
            value: value.clone(),
        }
    }
}

/// Whether `v` is a finite number > 0, as speeds and times must be.
fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

impl Calibration {
    /// An empty calibration.
    pub fn new() -> Self {
        Self::default()
    }

    /// Reads `path`; a file that does not exist is an empty calibration.
    ///
    /// # Errors
    /// [`CalibrationError`] naming `path`: unreadable, too large, not JSON of this shape (with
    /// the line and column), of another version, or holding a value no plan can use.
    pub fn load(path: &Path) -> Result<Self, CalibrationError> {
        let read = |source| CalibrationError::Read {
            path: path.to_owned(),
            source,
        };
        let file = match fs::File::open(path) {
            Ok(file) => file,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Self::new()),
            Err(e) => return Err(read(e)),
        };
        let mut text = String::new();
        file.take(MAX_BYTES + 1)
            .read_to_string(&mut text)
            .map_err(read)?;
        if text.len() as u64 > MAX_BYTES {
            return Err(CalibrationError::TooLarge {
                path: path.to_owned(),
                limit: MAX_BYTES,
            });
        }
        Self::parse(path, &text)
    }

    /// Parses the text of a calibration file; `path` only names it in errors.
    ///
    /// # Errors
    /// As [`Calibration::load`], reading aside.
    pub fn parse(path: &Path, text: &str) -> Result<Self, CalibrationError> {
        let file: File = serde_json::from_str(text).map_err(|e| CalibrationError::Parse {
            path: path.to_owned(),
            line: e.line(),
            column: e.column(),
            why: e.to_string(),
        })?;
        if file.version != FORMAT_VERSION {
            return Err(CalibrationError::Version {
                path: path.to_owned(),
                found: file.version,
            });
        }
        let mut entries = BTreeMap::new();
        let bad = |entry, key, (field, value, why)| CalibrationError::BadValue {
            path: path.to_owned(),
            entry,
            key,
            field,
            value,
            why,
        };
        for (i, Keyed { key, mut value }) in file.entries.into_iter().enumerate() {
            // A file written before the per-ray term has no `kr`: it reads as 0.
            if value.kb.is_some() && value.kt.is_some() {
                value.kr.get_or_insert(0.0);
            }
            if let Some(fault) = value.fault() {
                let name = format!("{} on {}, {}", key.device, key.host, key.workload);
                return Err(bad(i, name, fault));
            }
            entries.insert(key, value);
        }
        let mut choices = BTreeMap::new();
        for (i, Keyed { key, value }) in file.choices.into_iter().enumerate() {
            if let Some(fault) = value.fault() {
                let name = format!(
                    "choice of {} on {}, {}",
                    key.devices, key.host, key.workload
                );
                return Err(bad(i, name, fault));
            }
            choices.insert(key, value);
        }
        Ok(Self { entries, choices })
    }

    /// The file's text: entries in key order, so that equal calibrations write equal files.
    pub fn to_json(&self) -> String {
        let file = File {
            version: FORMAT_VERSION,
            entries: self.entries.iter().map(Keyed::of).collect(),
            choices: self.choices.iter().map(Keyed::of).collect(),
        };
        // Only strings, integers and finite numbers (checked on insert and load): cannot fail.
        let text = serde_json::to_string_pretty(&file).unwrap_or_default();
        format!("{text}\n")
    }

    /// Writes the calibration to `path`, creating its directory if needed: to a new temporary
    /// in that directory first, then renamed over `path`, so that a reader (or a run that
    /// crashes midway) never sees half a file.
    ///
    /// # Errors
    /// [`CalibrationError::Write`] naming the path that could not be written; the temporary
    /// is removed and `path` is left as it was.
    pub fn save(&self, path: &Path) -> Result<(), CalibrationError> {
        let failed = |at: &Path, source| CalibrationError::Write {
            path: at.to_owned(),
            source,
        };
        let dir = atomic::parent_dir(path);
        fs::create_dir_all(&dir).map_err(|e| failed(&dir, e))?;
        // A temporary not persisted is removed as it drops, leaving `path` as it was.
        let mut temp = atomic::temporary(&dir, path).map_err(|e| failed(path, e))?;
        temp.write_all(self.to_json().as_bytes())
            .and_then(|()| temp.as_file().sync_all())
            .map_err(|e| failed(path, e))?;
        temp.persist(path).map_err(|e| failed(path, e.error))?;
        Ok(())
    }

    /// Writes to `path` what this calibration changed from `read` (the file as this run read
    /// it), merged into the file as it is now: other runs may have written theirs since. The
    /// read, merge and write happen under an advisory lock (a `.NAME.lock` file beside it), so that runs sharing a
    /// file keep every one's entries; where a run's entry and another's share a key, the last
    /// to write wins.
    ///
    /// # Errors
    /// [`CalibrationError::Locked`] when another run holds the lock for longer than
    /// [`LOCK_WAIT`], and [`Calibration::save`]'s errors; the file is then left as it was. A
    /// file that can no longer be read is replaced, as a damaged cache is.
    pub fn update(&self, path: &Path, read: &Calibration) -> Result<(), CalibrationError> {
        let _lock = lock(path)?;
        let mut current = Self::load(path).unwrap_or_default();
        for (key, entry) in &self.entries {
            if read.entries.get(key) != Some(entry) {
                current.entries.insert(key.clone(), *entry);
            }
        }
        for (key, choice) in &self.choices {
            if read.choices.get(key) != Some(choice) {
                current.choices.insert(key.clone(), choice.clone());
            }
        }
        current.save(path)
    }

    /// The entry of `key`, if there is one.
    pub fn get(&self, key: &Key) -> Option<&Entry> {
        self.entries.get(key)
    }

    /// Records (or replaces) the entry of `key`. An entry no plan could use (a speed that is
    /// not finite and positive, or a model with a negative or non-finite coefficient) is not
    /// recorded: returns whether it was.
    pub fn insert(&mut self, key: Key, entry: Entry) -> bool {
        let ok = entry.fault().is_none();
        if ok {
            self.entries.insert(key, entry);
        }
        ok
    }

    /// The choice kept for `key`, if there is one.
    pub fn choice(&self, key: &ChoiceKey) -> Option<&Choice> {
        self.choices.get(key)
    }

    /// Records (or replaces) the choice of `key`; one with a time that is not finite and
    /// positive is not recorded: returns whether it was.
    pub fn insert_choice(&mut self, key: ChoiceKey, choice: Choice) -> bool {
        let ok = choice.fault().is_none();
        if ok {
            self.choices.insert(key, choice);
        }
        ok
    }

    /// Every entry, in key order.
    pub fn iter(&self) -> impl Iterator<Item = (&Key, &Entry)> {
        self.entries.iter()
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when there is no entry.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// How long a run waits for another run's update of the same calibration file before it goes
/// on without saving: an update takes milliseconds, so a lock held this long is stuck.
pub const LOCK_WAIT: Duration = Duration::from_secs(5);

/// Takes the advisory lock of the calibration at `path` (creating its directory and the lock
/// file `.NAME.lock` beside it if needed), waiting up to [`LOCK_WAIT`]. The lock is on a file
/// of its own, not on the calibration, because each update renames a new file over the
/// calibration: a lock held on the old file would not exclude a run that opened the new one.
/// The lock file is left in place, since removing it would race with a run about to lock it.
/// The lock goes with the returned file, also when the process dies.
fn lock(path: &Path) -> Result<fs::File, CalibrationError> {
    let failed = |at: &Path, source| CalibrationError::Write {
        path: at.to_owned(),
        source,
    };
    let dir = atomic::parent_dir(path);
    fs::create_dir_all(&dir).map_err(|e| failed(&dir, e))?;
    let name = path
        .file_name()
        .map_or("calibration".into(), |n| n.to_string_lossy());
    let lock_path = dir.join(format!(".{name}.lock"));
    let file = fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| failed(&lock_path, e))?;
    let start = Instant::now();
    loop {
        match file.try_lock() {
            Ok(()) => return Ok(file),
            Err(fs::TryLockError::WouldBlock) if start.elapsed() < LOCK_WAIT => {
                std::thread::sleep(Duration::from_millis(10));
            }
            Err(fs::TryLockError::WouldBlock) => {
                return Err(CalibrationError::Locked {
                    path: path.to_owned(),
                    lock: lock_path,
                    waited: LOCK_WAIT.as_secs(),
                });
            }
            Err(fs::TryLockError::Error(e)) => return Err(failed(&lock_path, e)),
        }
    }
}

/// Where the calibration is kept by default: `$XDG_CACHE_HOME/cobalt/calibration.json`, else
/// `$HOME/.cache/cobalt/calibration.json`. `Err` says why there is none: neither is set to an
/// absolute path (as the XDG base directory specification asks), or `HOME` is not an existing
/// directory. A run then keeps nothing: it may create the cache directories below `HOME`, never
/// `HOME` itself.
pub fn default_path() -> Result<PathBuf, String> {
    default_path_from(std::env::var_os("XDG_CACHE_HOME"), std::env::var_os("HOME"))
}

/// [`default_path`] from the two variables' values.
fn default_path_from(
    xdg_cache_home: Option<OsString>,
    home: Option<OsString>,
) -> Result<PathBuf, String> {
    let absolute = |v: Option<OsString>| v.map(PathBuf::from).filter(|p| p.is_absolute());
    let cache = match (absolute(xdg_cache_home), absolute(home)) {
        (Some(cache), _) => cache,
        (None, Some(home)) if home.is_dir() => home.join(".cache"),
        (None, Some(home)) => {
            return Err(format!(
                "HOME ({}) is not an existing directory and XDG_CACHE_HOME is not set",
                home.display()
            ));
        }
        (None, None) => {
            return Err("neither XDG_CACHE_HOME nor HOME is set to an absolute path".into());
        }
    };
    Ok(cache.join("cobalt").join("calibration.json"))
}

/// The host's name, for the entries' keys: the kernel's host name, else `/etc/hostname`,
/// else `$HOSTNAME`, else `unknown` (entries then still separate devices and workloads).
pub fn host_name() -> String {
    let from_file = |p: &str| fs::read_to_string(p).ok();
    from_file("/proc/sys/kernel/hostname")
        .or_else(|| from_file("/etc/hostname"))
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|s| s.trim().to_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Calibration {
        let mut c = Calibration::new();
        let entry = |speed, model, samples| {
            let mut e = Entry {
                speed,
                paths_per_second: Some(1.5e6 * speed),
                samples,
                spikes: 1,
                ..Entry::default()
            };
            e.set_model(model);
            e
        };
        assert!(c.insert(
            Key::new("box", "cpu/1", "builtin:cornell whitted"),
            entry(
                0.25,
                Some(CostModel {
                    kr: 4e-8,
                    kb: 1e-8,
                    kt: 3e-9,
                }),
                12
            ),
        ));
        assert!(c.insert(
            Key::new("box", "gpu0 (lavapipe)", "builtin:cornell whitted"),
            entry(1.0, None, 3),
        ));
        assert!(c.insert(
            Key::new("other", "cpu/1", "scene.obj ao"),
            entry(0.1 + 0.2, None, 0)
        ));
        let set = device_set(["gpu0 (lavapipe)", "cpu/1", "cpu/1"]);
        assert_eq!(set, "cpu/1 + gpu0 (lavapipe)");
        let choice_key = |workload: &str, mode: &str, shader: &str| ChoiceKey {
            host: "box".into(),
            devices: set.clone(),
            workload: workload.into(),
            mode: mode.into(),
            shader: shader.into(),
        };
        assert!(c.insert_choice(
            choice_key("builtin:cornell whitted", "cost", "whitted"),
            Choice {
                all: Some(2.5e-7),
                alone: Some(1.0 / 3.0 * 1e-6),
                fastest: Some("cpu/1".into()),
            },
        ));
        assert!(!c.insert_choice(
            choice_key("w", "regular", "ao"),
            Choice {
                all: Some(f64::INFINITY),
                alone: None,
                fastest: None,
            },
        ));
        c
    }

    fn scratch(tag: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("raytrace-calibration-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn a_calibration_reads_back_equal_and_leaves_no_temporary() {
        let dir = scratch("round-trip");
        // The directory is made on the first save, as the cache directory must be.
        let path = dir.join("nested").join("calibration.json");
        assert_eq!(Calibration::load(&path).unwrap(), Calibration::new());
        let c = sample();
        c.save(&path).unwrap();
        assert_eq!(Calibration::load(&path).unwrap(), c);
        // Saved again over itself: still equal, byte for byte.
        let first = fs::read_to_string(&path).unwrap();
        Calibration::load(&path).unwrap().save(&path).unwrap();
        assert_eq!(fs::read_to_string(&path).unwrap(), first);
        let names: Vec<String> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["calibration.json"], "no temporary is left behind");
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_update_merges_into_the_file_as_it_is_and_waits_for_the_lock() {
        let dir = scratch("merge");
        let path = dir.join("c.json");
        let read = Calibration::new();
        let mut ours = Calibration::new();
        let entry = |speed| Entry {
            speed,
            samples: 1,
            ..Entry::default()
        };
        ours.insert(Key::new("h", "cpu/1", "a"), entry(1.0));
        let mut theirs = Calibration::new();
        theirs.insert(Key::new("h", "cpu/1", "b"), entry(2.0));
        theirs.save(&path).unwrap();
        ours.update(&path, &read).unwrap();
        assert_eq!(Calibration::load(&path).unwrap().len(), 2, "both kept");

        let held = lock(&path).unwrap();
        let e = ours.update(&path, &read).unwrap_err();
        assert!(matches!(e, CalibrationError::Locked { .. }), "{e}");
        drop(held);
        ours.update(&path, &read).unwrap();
    }

    #[test]
    fn a_failed_save_removes_its_temporary() {
        let dir = scratch("failed-save");
        fs::create_dir_all(&dir).unwrap();
        // The target is a directory: the rename fails after the temporary was written.
        let path = dir.join("calibration.json");
        fs::create_dir_all(path.join("occupied")).unwrap();
        let err = sample().save(&path).unwrap_err();
        assert!(matches!(err, CalibrationError::Write { .. }), "{err}");
        assert!(err.to_string().contains("calibration.json"), "{err}");
        assert_eq!(
            fs::read_dir(&dir).unwrap().count(),
            1,
            "the temporary is removed"
        );
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_corrupt_file_is_an_error_naming_the_file_and_the_fault() {
        let path = Path::new("/cache/cobalt/calibration.json");
        let cut = sample().to_json();
        let cut = &cut[..cut.len() / 2];
        let err = Calibration::parse(path, cut).unwrap_err();
        let text = err.to_string();
        assert!(
            text.starts_with("/cache/cobalt/calibration.json:"),
            "{text}"
        );
        assert!(
            matches!(err, CalibrationError::Parse { line, .. } if line > 1),
            "{text}"
        );

        let zero = sample()
            .to_json()
            .replacen("\"speed\": 0.25", "\"speed\": 0.0", 1);
        let err = Calibration::parse(path, &zero).unwrap_err().to_string();
        assert!(err.contains("entry 0 (cpu/1 on box"), "{err}");
        assert!(err.contains("speed = 0"), "{err}");

        let slow = sample().to_json().replacen(
            "\"all_seconds_per_path\": 2.5e-7",
            "\"all_seconds_per_path\": 0.0",
            1,
        );
        let err = Calibration::parse(path, &slow).unwrap_err().to_string();
        assert!(
            err.contains("(choice of cpu/1 + gpu0 (lavapipe) on box"),
            "{err}"
        );
        assert!(err.contains("all_seconds_per_path = 0"), "{err}");

        let rate = sample().to_json().replacen(
            "\"paths_per_second\": 375000.0",
            "\"paths_per_second\": -2.0",
            1,
        );
        let err = Calibration::parse(path, &rate).unwrap_err().to_string();
        assert!(err.contains("entry 0 (cpu/1 on box"), "{err}");
        assert!(err.contains("paths_per_second = -2"), "{err}");

        let negative = sample()
            .to_json()
            .replacen("\"kt\": 3e-9", "\"kt\": -1.0", 1);
        let err = Calibration::parse(path, &negative).unwrap_err().to_string();
        assert!(err.contains("kt = -1"), "{err}");

        let negative = sample()
            .to_json()
            .replacen("\"kr\": 4e-8", "\"kr\": -1.0", 1);
        let err = Calibration::parse(path, &negative).unwrap_err().to_string();
        assert!(err.contains("kr = -1"), "{err}");

        // A file written before the per-ray term reads as kR = 0.
        let older = sample().to_json().replacen("\"kr\": 4e-8,", "", 1);
        assert_ne!(older, sample().to_json());
        let read = Calibration::parse(path, &older).expect("a file without kr");
        let models: Vec<_> = read.entries.values().filter_map(|e| e.model()).collect();
        assert!(!models.is_empty() && models.iter().all(|m| m.kr == 0.0 && m.kb > 0.0));

        // Fields the format does not have are refused, in a choice as in an entry.
        let unknown = sample().to_json().replacen(
            "\"fastest\": \"cpu/1\"",
            "\"fastest\": \"cpu/1\", \"extra\": 1",
            1,
        );
        assert_ne!(unknown, sample().to_json());
        let err = Calibration::parse(path, &unknown).unwrap_err().to_string();
        assert!(err.contains("extra"), "{err}");
        let unknown =
            sample()
                .to_json()
                .replacen("\"samples\": 12", "\"samples\": 12, \"other\": 1", 1);
        assert_ne!(unknown, sample().to_json());
        let err = Calibration::parse(path, &unknown).unwrap_err().to_string();
        assert!(err.contains("other"), "{err}");

        let future = sample()
            .to_json()
            .replacen("\"version\": 1", "\"version\": 7", 1);
        let err = Calibration::parse(path, &future).unwrap_err().to_string();
        assert!(err.contains("version 7"), "{err}");

        let err = Calibration::parse(path, "[1, 2]").unwrap_err().to_string();
        assert!(err.contains("calibration.json:1:"), "{err}");
    }

    #[test]
    fn unusable_entries_are_not_recorded() {
        let mut c = Calibration::new();
        let key = Key::new("h", "d", "w");
        let entry = |speed, kb| {
            let mut e = Entry {
                speed,
                samples: 1,
                ..Entry::default()
            };
            e.set_model(Some(CostModel::counts_only(kb, 0.0)));
            e
        };
        assert!(!c.insert(key.clone(), entry(f64::NAN, 1.0)));
        assert!(!c.insert(key.clone(), entry(1.0, -1.0)));
        assert!(!c.insert(key.clone(), entry(1.0, 0.0)));
        assert!(c.is_empty());
        assert!(c.insert(key, entry(1.0, 1.0)));
        assert_eq!(c.len(), 1);
    }

    #[test]
    fn the_default_path_is_in_the_cache_directory() {
        let p = |x: Option<&str>, h: Option<&str>| {
            default_path_from(x.map(OsString::from), h.map(OsString::from)).ok()
        };
        let home = std::env::temp_dir();
        let home = home.to_str().expect("a UTF-8 temp path");
        let expected = |s: &str| Some(PathBuf::from(s));
        assert_eq!(
            p(Some("/c"), Some(home)),
            expected("/c/cobalt/calibration.json")
        );
        let in_home = format!("{home}/.cache/cobalt/calibration.json");
        assert_eq!(p(None, Some(home)), expected(&in_home));
        // A relative XDG_CACHE_HOME is ignored, as the specification says.
        assert_eq!(p(Some("rel"), Some(home)), expected(&in_home));
        assert_eq!(p(None, None), None);
        assert_eq!(p(Some(""), Some("")), None);
        // A HOME that is not there is not made.
        let e = default_path_from(None, Some("/nonexistent/x".into())).unwrap_err();
        assert!(e.contains("/nonexistent/x"), "{e}");
        assert!(!host_name().is_empty());
    }
}
