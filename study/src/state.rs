//! A study's state on disk (`study.json`): every trial's configuration,
//! status, reports and result, written atomically after each change so an
//! interrupted study resumes where it stopped.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::config::StudyConfig;
use crate::lineage::PbtState;
use crate::objective::{Measurement, Score};
use crate::overrides::Overrides;
use crate::sampler::Observed;

/// Where a trial stands.
///
/// ```
/// use buridan_study::state::TrialStatus;
/// assert!(TrialStatus::Completed.is_finished());
/// assert!(!TrialStatus::Interrupted.is_finished());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrialStatus {
    /// Sampled for a batch (Kubernetes) and not yet collected.
    Planned,
    /// Started and not finished (if found on opening: the study was killed).
    Running,
    /// Ran its full budget.
    Completed,
    /// Stopped early by the scheduler.
    Stopped,
    /// The runner reported an error.
    Failed,
    /// Cut by the wall-time budget; runs again when the study resumes with time left.
    Interrupted,
}

impl TrialStatus {
    /// Finished trials are never run again.
    ///
    /// ```
    /// assert!(buridan_study::state::TrialStatus::Failed.is_finished());
    /// ```
    pub fn is_finished(&self) -> bool {
        matches!(
            self,
            TrialStatus::Completed | TrialStatus::Stopped | TrialStatus::Failed
        )
    }

    /// The status as files spell it.
    ///
    /// ```
    /// assert_eq!(buridan_study::state::TrialStatus::Stopped.name(), "stopped");
    /// ```
    pub fn name(&self) -> &'static str {
        match self {
            TrialStatus::Planned => "planned",
            TrialStatus::Running => "running",
            TrialStatus::Completed => "completed",
            TrialStatus::Stopped => "stopped",
            TrialStatus::Failed => "failed",
            TrialStatus::Interrupted => "interrupted",
        }
    }
}

/// One intermediate report as the scheduler saw it.
///
/// ```
/// let r = buridan_study::state::Report { step: 1000, value: 0.5 };
/// assert_eq!(r.step, 1000);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Env steps.
    pub step: u64,
    /// Objective key ([`Score::key`]) at that step.
    pub value: f64,
}

/// Everything known about one trial.
///
/// ```
/// let t = buridan_study::state::TrialRecord::new(0, Default::default());
/// assert_eq!(t.run_dir, std::path::PathBuf::from("trials/0000"));
/// assert!(t.objective().is_none());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// Trial id (its index in the study).
    pub id: u64,
    /// Its configuration.
    pub overrides: Overrides,
    /// Where it stands.
    pub status: TrialStatus,
    /// Intermediate reports, in step order.
    pub reports: Vec<Report>,
    /// The final measurement (or the last intermediate one).
    pub last: Option<Measurement>,
    /// Its score under the study's objective.
    pub score: Option<Score>,
    /// The runner's error, if it failed.
    pub error: Option<String>,
    /// Run directory, relative to the study directory.
    pub run_dir: PathBuf,
    /// Wall seconds spent on it (all sessions).
    pub seconds: f64,
    /// Times it was started (more than 1 after resumes).
    pub starts: u32,
}

impl TrialRecord {
    /// A new record in state `Running` with run directory `trials/NNNN`.
    ///
    /// ```
    /// let t = buridan_study::state::TrialRecord::new(12, Default::default());
    /// assert_eq!(t.run_dir.to_str(), Some("trials/0012"));
    /// ```
    pub fn new(id: u64, overrides: Overrides) -> TrialRecord {
        TrialRecord {
            id,
            overrides,
            status: TrialStatus::Running,
            reports: Vec::new(),
            last: None,
            score: None,
            error: None,
            run_dir: trial_dir(id),
            seconds: 0.0,
            starts: 0,
        }
    }

    /// The value samplers learn from: the score's key, else the last
    /// reported value, `None` before any report.
    ///
    /// ```
    /// let mut t = buridan_study::state::TrialRecord::new(0, Default::default());
    /// t.reports.push(buridan_study::state::Report { step: 10, value: 0.25 });
    /// assert_eq!(t.objective(), Some(0.25));
    /// ```
    pub fn objective(&self) -> Option<f64> {
        self.score
            .map(|s| s.key())
            .or_else(|| self.reports.last().map(|r| r.value))
    }
}

/// A trial's run directory relative to the study directory.
///
/// ```
/// assert_eq!(buridan_study::state::trial_dir(7).to_str(), Some("trials/0007"));
/// ```
pub fn trial_dir(id: u64) -> PathBuf {
    PathBuf::from("trials").join(format!("{id:04}"))
}

/// The persisted study: the settings that must not change across resumes,
/// the trials, and the wall time used.
///
/// ```
/// let cfg = buridan_study::StudyConfig::from_toml_str(
///     "[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }",
/// ).unwrap();
/// let s = buridan_study::state::StudyState::new(&cfg);
/// assert!(s.trials.is_empty());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyState {
    /// File format version.
    pub version: u32,
    /// The configuration the study was created with (budgets may change later).
    pub config: StudyConfig,
    /// Every trial, index = id.
    pub trials: Vec<TrialRecord>,
    /// Wall seconds used by all sessions.
    pub wall_seconds: f64,
    /// Population-based training's rounds and lineage (PBT studies only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pbt: Option<PbtState>,
}

/// The file name of the state in a study directory.
pub const STATE_FILE: &str = "study.json";

impl StudyState {
    /// A fresh state for `config`.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// assert_eq!(buridan_study::state::StudyState::new(&cfg).version, 1);
    /// ```
    pub fn new(config: &StudyConfig) -> StudyState {
        StudyState {
            version: 1,
            config: config.clone(),
            trials: Vec::new(),
            wall_seconds: 0.0,
            pbt: None,
        }
    }

    /// Finished and stopped trials with an objective, in id order, as samplers see them.
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// assert!(buridan_study::state::StudyState::new(&cfg).observed().is_empty());
    /// ```
    pub fn observed(&self) -> Vec<Observed> {
        self.trials
            .iter()
            .filter(|t| matches!(t.status, TrialStatus::Completed | TrialStatus::Stopped))
            .filter_map(|t| {
                Some(Observed {
                    overrides: t.overrides.clone(),
                    objective: t.objective()?,
                })
            })
            .collect()
    }

    /// The best trial with a final score (ties to the lower id).
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// assert!(buridan_study::state::StudyState::new(&cfg).best().is_none());
    /// ```
    pub fn best(&self) -> Option<&TrialRecord> {
        self.trials
            .iter()
            .filter(|t| t.status.is_finished() && t.score.is_some())
            .fold(None, |best: Option<&TrialRecord>, t| match best {
                Some(b) if b.objective() >= t.objective() => Some(b),
                _ => Some(t),
            })
    }

    /// Reads `dir/study.json`, `Ok(None)` if there is none.
    ///
    /// ```
    /// let dir = tempfile::tempdir().unwrap();
    /// assert!(buridan_study::state::StudyState::load(dir.path()).unwrap().is_none());
    /// ```
    pub fn load(dir: &Path) -> Result<Option<StudyState>, StateError> {
        let path = dir.join(STATE_FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(StateError::io(&path, e)),
        };
        serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| StateError::Corrupt {
                path: path.display().to_string(),
                message: e.to_string(),
            })
    }

    /// Writes `dir/study.json` atomically (a temporary file, then a rename).
    ///
    /// ```
    /// # let cfg = buridan_study::StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 1\nsteps_per_trial = 1\n[space]\nx = { int = [1, 2] }").unwrap();
    /// let dir = tempfile::tempdir().unwrap();
    /// let s = buridan_study::state::StudyState::new(&cfg);
    /// s.save(dir.path()).unwrap();
    /// assert_eq!(buridan_study::state::StudyState::load(dir.path()).unwrap(), Some(s));
    /// ```
    pub fn save(&self, dir: &Path) -> Result<(), StateError> {
        let path = dir.join(STATE_FILE);
        let tmp = dir.join(format!("{STATE_FILE}.tmp"));
        let text = serde_json::to_string_pretty(self).map_err(|e| StateError::Corrupt {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        std::fs::create_dir_all(dir).map_err(|e| StateError::io(dir, e))?;
        std::fs::write(&tmp, text).map_err(|e| StateError::io(&tmp, e))?;
        std::fs::rename(&tmp, &path).map_err(|e| StateError::io(&path, e))
    }
}

/// Reading or writing the state failed.
///
/// ```
/// let e = buridan_study::state::StateError::Io { path: "x".into(), message: "denied".into() };
/// assert_eq!(e.to_string(), "x: denied");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// A file operation failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        message: String,
    },
    /// The state file is not a study state.
    #[error("{path} is not a study state: {message}")]
    Corrupt {
        /// The file.
        path: String,
        /// The parse error.
        message: String,
    },
}

impl StateError {
    fn io(path: &Path, e: std::io::Error) -> StateError {
        StateError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        }
    }
}
