//! An open calibration file for one run: the device speeds and cost models that earlier runs
//! on this host learnt plan the first frame, and what this run learnt is written back
//! ([`crate::calibration`]).
//!
//! The default file is a cache: one that cannot be read is reported once on standard error
//! and replaced by what this run learns. A file the user named is not a cache to discard:
//! reading it must succeed, or the run fails naming the file and the fault before any work. A
//! calibration that cannot be written is a warning either way: the render it would have
//! remembered is done and its outputs are good.

use std::path::PathBuf;

use serde::Serialize;

use crate::calibration::{Calibration, CalibrationError, host_name};
use crate::paths::PathRenderer;
use crate::shade::Shader;

/// What a report says of the calibration.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// The file read and written; null without a calibration.
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
    /// The calibration at `path`, read. `named`: the user named the file, so a file that
    /// cannot be read is an error; otherwise it is a cache, started afresh with a warning.
    ///
    /// # Errors
    /// [`CalibrationError`] naming the file when a `named` file cannot be read or parsed.
    pub fn open(path: PathBuf, named: bool) -> Result<Self, CalibrationError> {
        let calibration = match Calibration::load(&path) {
            Ok(c) => c,
            Err(e) if named => return Err(e),
            Err(e) => {
                eprintln!("cobalt: {e}; starting a fresh calibration there");
                Calibration::new()
            }
        };
        Ok(Self {
            path,
            host: host_name(),
            read: calibration.clone(),
            calibration,
            loaded: 0,
            learnt: 0,
        })
    }

    /// Plans `renderer`'s first frame with the file's entries for its devices on `workload`;
    /// says how many were used (and none written yet).
    pub fn recall(&mut self, renderer: &mut PathRenderer<'_>, workload: &str) -> CalibrationReport {
        let used = renderer.recall(&self.read, &self.host, workload);
        self.loaded += used;
        CalibrationReport {
            file: Some(self.path.display().to_string()),
            loaded_entries: used,
            written_entries: 0,
        }
    }

    /// Keeps what `renderer` learnt on `workload`, for [`Store::save`].
    pub fn remember(&mut self, renderer: &PathRenderer<'_>, workload: &str) {
        self.learnt += renderer.remember(&mut self.calibration, &self.host, workload);
    }

    /// Merges what the run learnt into the file as it is now, under the file's lock, if the run
    /// learnt anything (a warning on standard error if it cannot be written or locked), and says
    /// what happened.
    pub fn save(&self) -> CalibrationReport {
        let written = if self.learnt == 0 {
            0
        } else {
            match self.calibration.update(&self.path, &self.read) {
                Ok(()) => self.learnt,
                Err(e) => {
                    eprintln!("cobalt: {e}; the calibration was not saved");
                    0
                }
            }
        };
        CalibrationReport {
            file: Some(self.path.display().to_string()),
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
