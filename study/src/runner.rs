//! The trait the learner implements to run one trial, in process or as a
//! `learner train` child process; the study never imports the learner.

use std::panic::AssertUnwindSafe;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::objective::{Measurement, Objective};
use crate::overrides::Overrides;
use crate::scheduler::Decision;

/// Everything a runner needs to run one trial.
///
/// ```
/// let spec = buridan_study::TrialSpec {
///     id: 3,
///     overrides: Default::default(),
///     steps: 200_000,
///     seed: 3,
///     run_dir: "study/trials/0003".into(),
///     resume: false,
///     start_from: None,
///     objective: buridan_study::Objective::TrainSuccess,
/// };
/// assert_eq!(spec.set_args().len(), 0);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialSpec {
    /// Trial number within the study (0-based, stable across resumes).
    pub id: u64,
    /// Configuration keys to override in the study's base configuration.
    pub overrides: Overrides,
    /// Env-step budget of the trial.
    pub steps: u64,
    /// Seed of the trial's run.
    pub seed: u64,
    /// The trial's run directory (a normal `learner train --out` directory).
    pub run_dir: PathBuf,
    /// The trial was interrupted before: continue from its latest checkpoint
    /// in `run_dir` if there is one.
    pub resume: bool,
    /// A checkpoint, or a run directory's newest one, to continue from when
    /// `run_dir` has none to resume (`learner train --resume DIR`): weights,
    /// optimiser state and counters. PBT rounds start this way, from the
    /// member's own last round or from the one it exploits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_from: Option<PathBuf>,
    /// What to measure at the end (the evaluation, if an eval objective).
    pub objective: Objective,
}

impl TrialSpec {
    /// The overrides as `learner train --set KEY=VALUE` arguments.
    ///
    /// ```
    /// let mut spec: buridan_study::TrialSpec = serde_json::from_str(
    ///     r#"{"id":0,"overrides":{"ppo.lr":0.001},"steps":1,"seed":0,"run_dir":"r","resume":false,"objective":"train_success"}"#,
    /// ).unwrap();
    /// assert_eq!(spec.set_args(), ["ppo.lr=0.001"]);
    /// ```
    pub fn set_args(&self) -> Vec<String> {
        crate::overrides::to_set_args(&self.overrides)
    }
}

/// Where a running trial sends intermediate measurements; the answer says
/// whether to go on.
///
/// ```
/// use buridan_study::{Decision, Measurement, Reporter};
/// struct Always;
/// impl Reporter for Always {
///     fn report(&mut self, _: &Measurement) -> Decision { Decision::Continue }
/// }
/// assert_eq!(Always.report(&Measurement::default()), Decision::Continue);
/// ```
pub trait Reporter {
    /// Records one intermediate measurement; on [`Decision::Stop`] the runner
    /// should end the trial soon and return its last measurement.
    fn report(&mut self, measurement: &Measurement) -> Decision;
}

/// A trial failed (the run crashed, the configuration was rejected…), in words.
///
/// ```
/// let e = buridan_study::TrialError::new("invalid --set override");
/// assert_eq!(e.to_string(), "trial failed: invalid --set override");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("trial failed: {message}")]
pub struct TrialError {
    /// What went wrong.
    pub message: String,
}

impl TrialError {
    /// A trial error with this message.
    ///
    /// ```
    /// assert_eq!(buridan_study::TrialError::new("x").message, "x");
    /// ```
    pub fn new(message: impl Into<String>) -> TrialError {
        TrialError {
            message: message.into(),
        }
    }
}

/// Runs trials. The learner implements it; tests implement it with
/// synthetic objectives. Called from several threads at once.
///
/// ```
/// use buridan_study::{Measurement, Reporter, TrialError, TrialRunner, TrialSpec};
/// struct Constant;
/// impl TrialRunner for Constant {
///     fn run(&self, spec: &TrialSpec, reporter: &mut dyn Reporter) -> Result<Measurement, TrialError> {
///         let m = Measurement { step: spec.steps, train_success: Some(0.5), ..Default::default() };
///         reporter.report(&m);
///         Ok(m)
///     }
/// }
/// ```
pub trait TrialRunner: Sync {
    /// Trains `spec.overrides` for up to `spec.steps` in `spec.run_dir`,
    /// reporting intermediate measurements to `reporter`, and returns the
    /// final measurement (with the evaluation the objective asks for).
    fn run(&self, spec: &TrialSpec, reporter: &mut dyn Reporter)
        -> Result<Measurement, TrialError>;
}

/// Runs trial `spec` on `runner`; a runner that panics fails the trial
/// instead of the study's worker thread.
pub(crate) fn run_caught(
    runner: &dyn TrialRunner,
    spec: &TrialSpec,
    reporter: &mut dyn Reporter,
) -> Result<Measurement, TrialError> {
    std::panic::catch_unwind(AssertUnwindSafe(|| runner.run(spec, reporter)))
        .unwrap_or_else(|_| Err(TrialError::new("the runner panicked")))
}
