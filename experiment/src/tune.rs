//! `learner tune`'s files: the study file with its base configuration, the
//! study directory's copies of both (so pods, child processes and later
//! sessions need nothing else), and the outputs with `best-config.toml`
//! (the base with the best trial's overrides merged: a complete `learner
//! train --config` file).

use std::path::{Path, PathBuf};

use buridan_learner::train::{ConfigError, TrainConfig};
use buridan_study::state::StudyState;
use buridan_study::{Study, StudyConfig, StudyError};

use crate::trial::{apply_overrides, TrialRunError};

/// The copy of the study file inside a study directory.
pub const STUDY_FILE: &str = "study.toml";
/// The full base configuration inside a study directory.
pub const BASE_FILE: &str = "base.toml";
/// The best configuration merged into the base.
pub const BEST_CONFIG_FILE: &str = "best-config.toml";

/// Why a study file, a study directory or its outputs cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum TuneError {
    /// The study file cannot be read.
    #[error("{}", file.display())]
    StudyFile {
        /// The study file.
        file: PathBuf,
        /// Why.
        source: buridan_study::config::ConfigError,
    },
    /// The study file's base configuration cannot be read.
    #[error("{}: base_config", file.display())]
    BaseConfig {
        /// The study file.
        file: PathBuf,
        /// Why.
        source: Box<ConfigError>,
    },
    /// A key of the search space is no configuration key.
    #[error("{}: [space] does not fit the base configuration", file.display())]
    Space {
        /// The study file.
        file: PathBuf,
        /// Why.
        source: Box<TrialRunError>,
    },
    /// A directory without a readable study file.
    #[error("{} is not a study directory (no readable {STUDY_FILE})", dir.display())]
    NotAStudy {
        /// The directory.
        dir: PathBuf,
        /// Why.
        source: buridan_study::config::ConfigError,
    },
    /// The base configuration of a study directory.
    #[error(transparent)]
    Base(Box<ConfigError>),
    /// The best overrides do not fit the base.
    #[error(transparent)]
    Best(Box<TrialRunError>),
    /// The study's own files.
    #[error(transparent)]
    Study(#[from] StudyError),
    /// Writing a file.
    #[error("creating {}", path.display())]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// A path named in a file: absolute, else relative to the working
/// directory if it exists there, else relative to the file's directory.
///
/// ```
/// use std::path::Path;
/// let p = buridan_experiment::tune::resolve_relative(Path::new("/a/b/study.toml"), "../c.toml");
/// assert_eq!(p, Path::new("/a/b/../c.toml"));
/// ```
pub fn resolve_relative(file: &Path, named: &str) -> PathBuf {
    let p = PathBuf::from(named);
    if p.is_absolute() || p.exists() {
        return p;
    }
    file.parent().unwrap_or(Path::new(".")).join(p)
}

/// Reads a study file and its base configuration (defaults if none).
pub fn load_study_file(path: &Path) -> Result<(StudyConfig, TrainConfig), TuneError> {
    let config = StudyConfig::from_file(path).map_err(|source| TuneError::StudyFile {
        file: path.to_path_buf(),
        source,
    })?;
    let base = match &config.base_config {
        Some(b) => {
            let p = resolve_relative(path, b);
            TrainConfig::from_toml_file(&p).map_err(|source| TuneError::BaseConfig {
                file: path.to_path_buf(),
                source: Box::new(source),
            })?
        }
        None => TrainConfig::default(),
    };
    // Every key of the space must be a configuration key: check with a sample now.
    let sample: buridan_study::Overrides = config
        .space
        .params()
        .iter()
        .map(|p| {
            let (low, _) = p.domain.internal_bounds();
            (p.key.clone(), p.domain.value_at(low))
        })
        .collect();
    apply_overrides(&base, &sample).map_err(|source| TuneError::Space {
        file: path.to_path_buf(),
        source: Box::new(source),
    })?;
    Ok((config, base))
}

/// Reads a study directory's copies of the study file and base configuration.
pub fn load_study_dir(dir: &Path) -> Result<(StudyConfig, TrainConfig), TuneError> {
    let study = dir.join(STUDY_FILE);
    let config = StudyConfig::from_file(&study).map_err(|source| TuneError::NotAStudy {
        dir: dir.to_path_buf(),
        source,
    })?;
    let base = TrainConfig::from_toml_file(&dir.join(BASE_FILE))?;
    Ok((config, base))
}

/// Copies the study file and the full base configuration into study directory `dir`.
pub fn save_copies(dir: &Path, study_file: &Path, base: &TrainConfig) -> Result<(), TuneError> {
    let failed = |path: &Path| {
        let path = path.to_path_buf();
        move |source| TuneError::Write { path, source }
    };
    std::fs::create_dir_all(dir).map_err(failed(dir))?;
    let text = std::fs::read_to_string(study_file).map_err(failed(study_file))?;
    let copy = dir.join(STUDY_FILE);
    std::fs::write(&copy, text).map_err(failed(&copy))?;
    let base_file = dir.join(BASE_FILE);
    std::fs::write(&base_file, base.to_toml()).map_err(failed(&base_file))?;
    Ok(())
}

/// Writes the study's outputs and `best-config.toml`; returns the files.
pub fn write_outputs(study: &Study, base: &TrainConfig) -> Result<Vec<PathBuf>, TuneError> {
    let mut files = study.write_outputs()?;
    if let Some(best) = study.state().best() {
        let cfg = apply_overrides(base, &best.overrides)?;
        let path = study.dir().join(BEST_CONFIG_FILE);
        let header = format!(
            "# Best trial {} of study `{}` ({}) merged into its base configuration.\n",
            best.id,
            study.config().name,
            best.run_dir.display()
        );
        std::fs::write(&path, header + &cfg.to_toml()).map_err(|source| TuneError::Write {
            path: path.clone(),
            source,
        })?;
        files.push(path);
    }
    Ok(files)
}

/// One line per trial: id, status, objective, overrides.
pub fn trial_lines(state: &StudyState) -> Vec<String> {
    state
        .trials
        .iter()
        .map(|t| {
            format!(
                "trial {:>3} {:<11} objective {:>7} len {:>6} after {:>9} steps  {}{}",
                t.id,
                t.status.name(),
                t.score
                    .map(|s| format!("{:.3}", s.value))
                    .unwrap_or_else(|| "-".into()),
                t.score
                    .and_then(|s| s.episode_len)
                    .map(|l| format!("{l:.1}"))
                    .unwrap_or_else(|| "-".into()),
                t.last.as_ref().map(|m| m.step).unwrap_or(0),
                buridan_study::overrides::describe(&t.overrides),
                t.error
                    .as_ref()
                    .map(|e| format!("  error: {e}"))
                    .unwrap_or_default()
            )
        })
        .collect()
}

impl From<ConfigError> for TuneError {
    fn from(e: ConfigError) -> TuneError {
        TuneError::Base(Box::new(e))
    }
}

impl From<TrialRunError> for TuneError {
    fn from(e: TrialRunError) -> TuneError {
        TuneError::Best(Box::new(e))
    }
}
