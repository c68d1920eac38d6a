//! `--calibration FILE` and `--no-calibration` of the path renders (`cobalt render`, `cobalt
//! bench`): the device speeds and cost models that earlier runs on this host learnt plan the
//! first frame, and what this run learnt is written back ([`raytrace::calibration`]).
//!
//! The default file is a cache: one that cannot be read is reported once on standard error
//! and replaced by what this run learns. A file the user named is not a cache to discard:
//! reading it must succeed, or the command fails naming the file and the fault before any
//! work. A calibration that cannot be written is a warning either way: the render it would
//! have remembered is done and its outputs are good.

use std::path::PathBuf;

use serde::Serialize;

use raytrace::calibration::{Calibration, default_path, host_name};
use raytrace::paths::PathRenderer;
use raytrace::shade::Shader;

use crate::error::CliError;

/// The calibration flags, shared by the commands that render by paths.
#[derive(Debug, Clone, clap::Args)]
pub struct CalibrationArgs {
    /// The calibration file: device speeds and cost models learnt by earlier runs on this
    /// host, per device and workload, which plan the first frame; the run writes back what it
    /// learnt (default: `$XDG_CACHE_HOME/cobalt/calibration.json`, else
    /// `~/.cache/cobalt/calibration.json`).
    #[arg(long, value_name = "FILE", conflicts_with = "no_calibration")]
    pub(crate) calibration: Option<PathBuf>,
    /// Neither read nor write a calibration: the first frame plans with equal speeds.
    #[arg(long)]
    no_calibration: bool,
}

/// What a report says of the calibration.
#[derive(Debug, Clone, Default, Serialize)]
pub struct CalibrationReport {
    /// The file read and written; null with `--no-calibration` or without a cache directory.
    pub file: Option<String>,
    /// Entries of the file that planned a first frame.
    pub loaded_entries: usize,
    /// Entries written back after the run (0 if it could not be written).
    pub written_entries: usize,
}

/// An open calibration: the file's entries, and what this run recalled and learnt. Every
/// renderer of a run recalls the file as it was read, so that the renderers of one run (the
/// cells of a bench) start alike whatever their order; what they learn is merged into a copy
/// that [`Store::save`] writes.
pub struct Store {
    path: PathBuf,
    host: String,
    read: Calibration,
    calibration: Calibration,
    loaded: usize,
    learnt: usize,
}

impl Store {
    /// The calibration `args` ask for, read; `None` with `--no-calibration` or when there is
    /// no cache directory to default to.
    ///
    /// # Errors
    /// [`CliError::Calibration`] when a file named by `--calibration` cannot be read or
    /// parsed (the default one is started afresh instead, with a warning).
    pub fn open(args: &CalibrationArgs) -> Result<Option<Self>, CliError> {
        if args.no_calibration {
            return Ok(None);
        }
        let (path, named) = match &args.calibration {
            Some(path) => (path.clone(), true),
            None => match default_path() {
                Some(path) => (path, false),
                None => return Ok(None),
            },
        };
        let calibration = match Calibration::load(&path) {
            Ok(c) => c,
            Err(e) if named => return Err(e.into()),
            Err(e) => {
                eprintln!("cobalt: {e}; starting a fresh calibration there");
                Calibration::new()
            }
        };
        Ok(Some(Self {
            path,
            host: host_name(),
            read: calibration.clone(),
            calibration,
            loaded: 0,
            learnt: 0,
        }))
    }

    /// Plans `renderer`'s first frame with the file's entries for its devices on `workload`;
    /// returns how many were used.
    pub fn recall(&mut self, renderer: &mut PathRenderer<'_>, workload: &str) -> usize {
        let used = renderer.recall(&self.read, &self.host, workload);
        self.loaded += used;
        used
    }

    /// Keeps what `renderer` learnt on `workload`, for [`Store::save`].
    pub fn remember(&mut self, renderer: &PathRenderer<'_>, workload: &str) {
        self.learnt += renderer.remember(&mut self.calibration, &self.host, workload);
    }

    /// The file, for reports.
    pub fn file(&self) -> String {
        self.path.display().to_string()
    }

    /// Writes the calibration back if the run learnt anything (a warning on standard error if
    /// it cannot be written), and says what happened.
    pub fn save(&self) -> CalibrationReport {
        let written = if self.learnt == 0 {
            0
        } else {
            match self.calibration.save(&self.path) {
                Ok(()) => self.learnt,
                Err(e) => {
                    eprintln!("cobalt: {e}; the calibration was not saved");
                    0
                }
            }
        };
        CalibrationReport {
            file: Some(self.file()),
            loaded_entries: self.loaded,
            written_entries: written,
        }
    }
}

/// What a calibration entry's workload is: the scene (a file by its resolved path, so that
/// one file named two ways is one workload) and the shader.
pub fn workload(scene: &str, shader: &Shader) -> String {
    let scene = std::fs::canonicalize(scene)
        .map(|p| p.display().to_string())
        .unwrap_or_else(|_| scene.to_owned());
    format!("{scene} {}", shader.name())
}
