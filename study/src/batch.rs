//! Batches for a cluster: each planned trial's spec as `trial.json` in its
//! run directory on a shared volume; a pod runs trial `JOB_COMPLETION_INDEX`
//! ([`run_trial`]) and leaves `result.json` beside it; [`crate::Study::collect`]
//! reads the results back.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::objective::Measurement;
use crate::runner::{Reporter, TrialRunner, TrialSpec};
use crate::scheduler::Decision;
use crate::state::{trial_dir, Report, StateError};

/// A trial's spec in its run directory.
pub const SPEC_FILE: &str = "trial.json";
/// A trial's result in its run directory.
pub const RESULT_FILE: &str = "result.json";
const STARTED_FILE: &str = "started";

/// What a pod leaves for the study: the reports, and the final measurement
/// or the error.
///
/// ```
/// let r = buridan_study::batch::TrialResult { reports: vec![], outcome: Err("boom".into()), seconds: 1.0 };
/// assert!(r.outcome.is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialResult {
    /// Intermediate reports (objective key per step).
    pub reports: Vec<Report>,
    /// Final measurement, or the runner's error message.
    pub outcome: Result<Measurement, String>,
    /// Wall seconds of the run.
    pub seconds: f64,
}

fn io(path: &Path, e: impl std::fmt::Display) -> StateError {
    StateError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn corrupt(path: &Path, e: impl std::fmt::Display) -> StateError {
    StateError::Corrupt {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Writes `spec` as `trial.json` into its run directory, storing the run
/// directory relative to `study_dir` so pods can mount the volume anywhere.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let spec = buridan_study::TrialSpec {
///     id: 1, overrides: Default::default(), steps: 10, seed: 1,
///     run_dir: dir.path().join("trials/0001"), resume: false, start_from: None,
///     objective: buridan_study::Objective::TrainSuccess,
/// };
/// buridan_study::batch::write_spec(dir.path(), &spec).unwrap();
/// let back = buridan_study::batch::read_spec(dir.path(), 1).unwrap();
/// assert_eq!(back, spec);
/// ```
pub fn write_spec(study_dir: &Path, spec: &TrialSpec) -> Result<(), StateError> {
    std::fs::create_dir_all(&spec.run_dir).map_err(|e| io(&spec.run_dir, e))?;
    let relative = TrialSpec {
        run_dir: spec
            .run_dir
            .strip_prefix(study_dir)
            .map(Path::to_path_buf)
            .unwrap_or_else(|_| spec.run_dir.clone()),
        ..spec.clone()
    };
    let path = spec.run_dir.join(SPEC_FILE);
    let text = serde_json::to_string_pretty(&relative).map_err(|e| corrupt(&path, e))?;
    std::fs::write(&path, text).map_err(|e| io(&path, e))
}

/// Reads trial `index`'s spec from `study_dir` (as mounted in this pod).
///
/// ```
/// assert!(buridan_study::batch::read_spec(std::path::Path::new("/nonexistent"), 0).is_err());
/// ```
pub fn read_spec(study_dir: &Path, index: u64) -> Result<TrialSpec, StateError> {
    let path = study_dir.join(trial_dir(index)).join(SPEC_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| io(&path, e))?;
    let mut spec: TrialSpec = serde_json::from_str(&text).map_err(|e| corrupt(&path, e))?;
    if spec.run_dir.is_relative() {
        spec.run_dir = study_dir.join(&spec.run_dir);
    }
    Ok(spec)
}

/// Reads `result.json` from a run directory, `Ok(None)` if the trial has not finished.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// assert!(buridan_study::batch::read_result(dir.path()).unwrap().is_none());
/// ```
pub fn read_result(run_dir: &Path) -> Result<Option<TrialResult>, StateError> {
    let path = run_dir.join(RESULT_FILE);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| corrupt(&path, e)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io(&path, e)),
    }
}

/// Runs planned trial `index` of the study at `study_dir` (what one pod of
/// the Indexed Job does) and writes its `result.json`. Runs every trial to
/// its budget (no scheduler across pods); a retried pod gets `resume = true`.
///
/// ```
/// use buridan_study::*;
/// struct Half;
/// impl TrialRunner for Half {
///     fn run(&self, s: &TrialSpec, _: &mut dyn Reporter) -> Result<Measurement, TrialError> {
///         Ok(Measurement { step: s.steps, train_success: Some(0.5), ..Default::default() })
///     }
/// }
/// let cfg = StudyConfig::from_toml_str("[study]\nname = \"x\"\ntrials = 2\nsteps_per_trial = 5\n[space]\nx = { int = [1, 9] }").unwrap();
/// let dir = tempfile::tempdir().unwrap();
/// let mut study = Study::open(dir.path(), cfg).unwrap();
/// study.plan(2).unwrap();
/// for i in 0..2 { batch::run_trial(dir.path(), i, &Half).unwrap(); }
/// assert_eq!(study.collect().unwrap(), 2);
/// assert_eq!(study.progress().completed, 2);
/// ```
pub fn run_trial(
    study_dir: &Path,
    index: u64,
    runner: &dyn TrialRunner,
) -> Result<TrialResult, StateError> {
    let mut spec = read_spec(study_dir, index)?;
    let marker: PathBuf = spec.run_dir.join(STARTED_FILE);
    spec.resume = marker.exists();
    std::fs::write(&marker, b"").map_err(|e| io(&marker, e))?;
    let start = Instant::now();
    let mut recorder = Recorder {
        objective: spec.objective,
        reports: Vec::new(),
    };
    let outcome = runner.run(&spec, &mut recorder).map_err(|e| e.message);
    let result = TrialResult {
        reports: recorder.reports,
        outcome,
        seconds: start.elapsed().as_secs_f64(),
    };
    let path = spec.run_dir.join(RESULT_FILE);
    let tmp = spec.run_dir.join(format!("{RESULT_FILE}.tmp"));
    let text = serde_json::to_string_pretty(&result).map_err(|e| corrupt(&path, e))?;
    std::fs::write(&tmp, text).map_err(|e| io(&tmp, e))?;
    std::fs::rename(&tmp, &path).map_err(|e| io(&path, e))?;
    Ok(result)
}

struct Recorder {
    objective: crate::objective::Objective,
    reports: Vec<Report>,
}

impl Reporter for Recorder {
    fn report(&mut self, m: &Measurement) -> Decision {
        if let Some(score) = self.objective.intermediate(m) {
            if self.reports.last().is_none_or(|r| m.step > r.step) {
                self.reports.push(Report {
                    step: m.step,
                    value: score.key(),
                });
            }
        }
        Decision::Continue
    }
}
