//! `--calibration FILE` and `--no-calibration` of the commands that render (`cobalt render`,
//! `cobalt bench`): which calibration file a run opens ([`raytrace::run::Store`]).

use std::path::{Path, PathBuf};

use raytrace::calibration::default_path;
use raytrace::run::Store;

use crate::error::CliError;

/// The calibration flags, shared by the commands that render.
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

impl CalibrationArgs {
    /// The calibration these flags ask for, read; `None` with `--no-calibration` or when
    /// there is no cache directory to default to.
    ///
    /// # Errors
    /// [`CliError::Calibration`] when a file named by `--calibration` cannot be read or
    /// parsed (the default one is started afresh instead, with a warning).
    pub fn open(&self) -> Result<Option<Store>, CliError> {
        if self.no_calibration {
            return Ok(None);
        }
        let (path, named) = match &self.calibration {
            Some(path) => (path.clone(), true),
            None => match default_path() {
                Ok(path) => (path, false),
                Err(why) => {
                    eprintln!(
                        "cobalt: no cache directory for the calibration: {why}; this run does \
                         not learn (--calibration FILE names one)"
                    );
                    return Ok(None);
                }
            },
        };
        Ok(Some(Store::open(path, named)?))
    }

    /// The file these flags read and update, if any: an input of the command that none of its
    /// outputs may replace, and an output that may replace none of its other `inputs`.
    ///
    /// # Errors
    /// [`CliError::Output`] naming both flags when the calibration is one of `inputs`.
    pub fn check(&self, inputs: &[(&'static str, &Path)]) -> Result<Option<PathBuf>, CliError> {
        if self.no_calibration {
            return Ok(None);
        }
        let path = self.calibration.clone().or_else(|| default_path().ok());
        if let Some(path) = &path {
            crate::output::not_input("calibration", path, inputs)?;
        }
        Ok(path)
    }
}
