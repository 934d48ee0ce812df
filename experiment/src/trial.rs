//! The learner's side of a study: [`LearnerRunner`] trains one trial in
//! process (a normal run directory), forwards its progress to the study's
//! scheduler, stops it on the scheduler's word (with a checkpoint), and
//! measures the declared objective — training success, or the seed-42
//! evaluation of the final policy with sampled or greedy actions. The
//! child-process runner ([`crate::process`]) shares the configuration, the
//! checkpoint to start from and the measuring.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use buridan_env::{EnvError, Map, MapError};
use buridan_eval::output::{write_report, OutputError};
use buridan_eval::policy::{PolicyController, PolicyLoadError};
use buridan_eval::{evaluate, Controller, EvalReport, EvalSpec};
use buridan_learner::train::{
    ConfigError, InProcess, MetricsRow, Progress, Run, Summary, Task, TrainConfig, TrainError,
};
use buridan_policy::{checkpoint, ActMode};
use buridan_study::{
    Measurement, Objective, Overrides, Reporter, TrialError, TrialRunner, TrialSpec,
};

/// Why a trial could not be trained or measured.
#[derive(Debug, thiserror::Error)]
pub enum TrialRunError {
    /// The base configuration and the overrides do not form a configuration.
    #[error("the overrides {overrides} do not fit the configuration")]
    Overrides {
        /// The overrides, as `--set` flags.
        overrides: String,
        /// What the configuration parser says.
        source: toml::de::Error,
    },
    /// The configuration is out of range.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Training failed.
    #[error("training in {}", dir.display())]
    Train {
        /// The run directory.
        dir: PathBuf,
        /// Why.
        source: Box<TrainError>,
    },
    /// The trained policy cannot be loaded for the evaluation.
    #[error("evaluating {}", dir.display())]
    Policy {
        /// The run directory.
        dir: PathBuf,
        /// Why.
        source: Box<PolicyLoadError>,
    },
    /// An evaluation objective on a plant run (the trial evaluation plays
    /// grid episodes).
    #[error("{plant}: the evaluation objectives play grid episodes; a plant trial can only use the training objective (evaluate its policy with `learner eval --plant`)")]
    PlantEvaluation {
        /// The run's plant label.
        plant: String,
    },
    /// The evaluation's map cannot be loaded.
    #[error(transparent)]
    Map(#[from] MapError),
    /// The evaluation's envs cannot be built.
    #[error("evaluation envs")]
    Env(#[from] EnvError),
    /// The evaluation's files cannot be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The checkpoint a trial should start from is not there.
    #[error("no checkpoint to start from in {}", dir.display())]
    StartFrom {
        /// The run or checkpoint directory.
        dir: PathBuf,
        /// Why.
        source: buridan_policy::PolicyError,
    },
    /// An evaluation objective on a run over several layouts (which one?).
    #[error("the trial trains on several layouts ({0}); evaluation objectives need one, use train_success")]
    SeveralLayouts(String),
}

/// The message of `e` and all its causes, `a: b: c`.
pub use buridan_env::error::error_chain as chain;

/// `base` with `overrides` (dotted keys) applied, as `learner train --set` would.
///
/// ```
/// use buridan_experiment::trial::apply_overrides;
/// let mut o = buridan_study::Overrides::new();
/// o.insert("ppo.lr".into(), toml::Value::Float(5e-4));
/// o.insert("hidden".into(), toml::Value::Array(vec![32.into(), 32.into()]));
/// let cfg = apply_overrides(&Default::default(), &o).unwrap();
/// assert_eq!((cfg.algorithm.ppo().unwrap().lr, cfg.model.hidden.clone()), (5e-4, vec![32, 32]));
/// o.insert("ppo.no_such_key".into(), 1.into());
/// assert!(apply_overrides(&Default::default(), &o).is_err());
/// ```
pub fn apply_overrides(
    base: &TrainConfig,
    overrides: &Overrides,
) -> Result<TrainConfig, TrialRunError> {
    let mut table: toml::Table =
        toml::from_str(&base.to_toml()).expect("a configuration round-trips through TOML");
    for (key, value) in overrides {
        buridan_study::overrides::merge_key(&mut table, key, value.clone());
        // Naming a task (`map`, `maps` or `plant`) replaces the base's.
        Task::keep_only(&mut table, key);
    }
    let cfg: TrainConfig = table
        .try_into()
        .map_err(|source| TrialRunError::Overrides {
            overrides: buridan_study::overrides::describe(overrides),
            source,
        })?;
    cfg.validate()?;
    Ok(cfg)
}

/// The configuration of trial `spec`: the base, the overrides, the trial's
/// seed and step budget, and the checkpoint it continues from
/// ([`start_checkpoint`]).
pub fn trial_config(base: &TrainConfig, spec: &TrialSpec) -> Result<TrainConfig, TrialRunError> {
    let mut cfg = apply_overrides(base, &spec.overrides)?;
    cfg.run.seed = spec.seed;
    cfg.run.steps = spec.steps;
    cfg.run.resume = start_checkpoint(spec)?;
    Ok(cfg)
}

/// The checkpoint trial `spec` continues from: when resuming, the newest of
/// its run directory if it has one; else that of `start_from` (which must
/// have one); else none, a fresh start.
pub fn start_checkpoint(spec: &TrialSpec) -> Result<Option<PathBuf>, TrialRunError> {
    if spec.resume {
        if let Ok(own) = checkpoint::resolve(&spec.run_dir) {
            return Ok(Some(own));
        }
    }
    spec.start_from
        .as_deref()
        .map(|dir| {
            checkpoint::resolve(dir).map_err(|source| TrialRunError::StartFrom {
                dir: dir.to_path_buf(),
                source,
            })
        })
        .transpose()
}

/// What the evaluation protocol runs on: seed-42 episodes, as in SPEC §6.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalProtocol {
    /// Episodes (100 in the dissertation, 1,000 for generalization).
    pub episodes: usize,
    /// Seed of the episode generator (42).
    pub seed: u64,
}

impl Default for EvalProtocol {
    fn default() -> Self {
        EvalProtocol {
            episodes: 100,
            seed: 42,
        }
    }
}

/// Evaluates the policy of run directory (or checkpoint) `dir` on `map`
/// with `agents` agents, as `learner eval --controller checkpoint:DIR` does.
pub fn evaluate_policy(
    dir: &Path,
    map: &Arc<Map>,
    spec: &EvalSpec,
    act_mode: ActMode,
) -> Result<EvalReport, TrialRunError> {
    let failed = |source| TrialRunError::Policy {
        dir: dir.to_path_buf(),
        source: Box::new(source),
    };
    // Load once here so that a bad checkpoint fails with its reason.
    PolicyController::load(dir, spec.agents, act_mode, spec.seed).map_err(failed)?;
    let make = || -> Box<dyn Controller> {
        Box::new(
            PolicyController::load(dir, spec.agents, act_mode, spec.seed)
                .expect("loaded once already"),
        )
    };
    Ok(evaluate(map, spec, &make, &|_| {})?)
}

/// The scheduler's view of one metrics row.
///
/// ```
/// let row = buridan_learner::train::MetricsRow { env_steps: 4000, success_rate: f64::NAN, ..Default::default() };
/// let m = buridan_experiment::trial::measurement(&row);
/// assert_eq!((m.step, m.train_success), (4000, None));
/// ```
pub fn measurement(row: &MetricsRow) -> Measurement {
    train_measurement(row.env_steps, row.success_rate, row.episode_len_mean)
}

fn summary_measurement(s: &Summary) -> Measurement {
    train_measurement(s.env_steps, s.success_rate, s.episode_len_mean)
}

/// A measurement at env step `step` of the training success rate and
/// episode length (`None` where not finite: no episode finished yet).
fn train_measurement(step: u64, success_rate: f64, episode_len_mean: f64) -> Measurement {
    let finite = |x: f64| x.is_finite().then_some(x);
    Measurement {
        step,
        train_success: finite(success_rate),
        train_len: finite(episode_len_mean),
        ..Measurement::default()
    }
}

/// Where a runner shows its running trials (the command line draws a bar
/// per trial).
pub trait TrialDisplay: Send + Sync {
    /// Trial `spec` starts: its progress goes to the view returned, which
    /// is dropped when its training ends.
    fn trial(&self, spec: &TrialSpec) -> Box<dyn TrialView>;
}

/// One running trial's progress, as a [`TrialDisplay`] shows it.
pub trait TrialView: Send {
    /// Training starts (or resumes) at `env_steps` of `total_steps`.
    fn started(&mut self, _total_steps: u64, _env_steps: u64) {}
    /// A metrics row was written.
    fn row(&mut self, row: &MetricsRow);
}

/// A view of trial `spec` on `display` (none without one).
pub fn trial_view(
    display: Option<&Arc<dyn TrialDisplay>>,
    spec: &TrialSpec,
) -> Option<Box<dyn TrialView>> {
    display.map(|d| d.trial(spec))
}

/// Forwards training progress to the study and to an optional view; stops
/// the run when the study says so.
struct TrialProgress<'a> {
    reporter: &'a mut dyn Reporter,
    interrupt: Arc<AtomicBool>,
    last: Measurement,
    stopped: bool,
    view: Option<Box<dyn TrialView>>,
}

impl Progress for TrialProgress<'_> {
    fn on_start(&mut self, _cfg: &TrainConfig, total_steps: u64, env_steps: u64) {
        if let Some(view) = &mut self.view {
            view.started(total_steps, env_steps);
        }
    }

    fn on_update(&mut self, row: &MetricsRow) {
        self.last = measurement(row);
        if let Some(view) = &mut self.view {
            view.row(row);
        }
        if !self.stopped && !self.reporter.report(&self.last).keeps_going() {
            self.stopped = true;
            self.interrupt.store(true, Ordering::SeqCst);
        }
    }
}

/// Trains `cfg` in this process into run directory `out`, learner and
/// actors on threads (what `learner train` runs); stops with a checkpoint
/// once `interrupt` is set.
pub fn train_interruptible(
    cfg: &TrainConfig,
    out: &Path,
    progress: &mut dyn Progress,
    interrupt: Arc<AtomicBool>,
) -> Result<Summary, Box<TrainError>> {
    let mut run = Run::prepare(cfg, out)?;
    let mut collectors = Vec::with_capacity(cfg.run.num_actors);
    for i in 0..cfg.run.num_actors as u32 {
        collectors.push(run.collector(i)?);
    }
    let mut exchange = InProcess::spawn(
        collectors,
        cfg.queue_capacity(),
        cfg.staleness(),
        cfg.run.actor_nice,
    )
    .map_err(|e| Box::new(e.into()))?;
    run.interrupt_on(interrupt);
    Ok(run.learn(&mut exchange, progress)?)
}

/// Trains trials with the learner in this process.
pub struct LearnerRunner {
    /// The configuration every trial starts from.
    pub base: TrainConfig,
    /// The evaluation an `eval_*` objective runs.
    pub eval: EvalProtocol,
    /// Where to show each running trial (none: nowhere).
    pub display: Option<Arc<dyn TrialDisplay>>,
}

impl LearnerRunner {
    /// A runner showing nothing.
    pub fn new(base: TrainConfig) -> LearnerRunner {
        LearnerRunner {
            base,
            eval: EvalProtocol::default(),
            display: None,
        }
    }

    /// Trains and measures trial `spec`; `Ok` also when the study stopped it.
    pub fn run_trial(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialRunError> {
        let cfg = trial_config(&self.base, spec)?;
        if spec.objective != Objective::TrainSuccess && cfg.layouts().len() > 1 {
            return Err(TrialRunError::SeveralLayouts(cfg.map_label()));
        }
        tracing::info!(
            trial = spec.id,
            overrides = %buridan_study::overrides::describe(&spec.overrides),
            resume = ?cfg.run.resume,
            "trial starts"
        );
        let interrupt = Arc::new(AtomicBool::new(false));
        let mut progress = TrialProgress {
            reporter,
            interrupt: interrupt.clone(),
            last: Measurement::default(),
            stopped: false,
            view: trial_view(self.display.as_ref(), spec),
        };
        let outcome = train_interruptible(&cfg, &spec.run_dir, &mut progress, interrupt);
        // The view ends with the training, before any evaluation.
        drop(progress.view.take());
        let summary = match outcome {
            Ok(summary) => summary,
            Err(e) if progress.stopped && matches!(*e, TrainError::Interrupted(_)) => {
                tracing::info!(trial = spec.id, step = progress.last.step, "trial stopped");
                return Ok(progress.last);
            }
            Err(source) => {
                return Err(TrialRunError::Train {
                    dir: spec.run_dir.clone(),
                    source,
                })
            }
        };
        measure(&cfg, spec, &self.eval, &summary)
    }
}

/// What trial `spec` (trained with `cfg`) amounted to under its objective:
/// the summary's training success, or the seed-42 evaluation of its final
/// policy, written into `eval-sampled/` or `eval-greedy/` of its run directory.
pub fn measure(
    cfg: &TrainConfig,
    spec: &TrialSpec,
    eval: &EvalProtocol,
    summary: &Summary,
) -> Result<Measurement, TrialRunError> {
    let mut m = summary_measurement(summary);
    let act_mode = match spec.objective {
        Objective::TrainSuccess => return Ok(m),
        Objective::EvalSampled => ActMode::Sample,
        Objective::EvalGreedy => ActMode::Greedy,
    };
    if cfg.task.is_plant() {
        return Err(TrialRunError::PlantEvaluation {
            plant: cfg.map_label(),
        });
    }
    // One layout: `run_trial` refuses evaluation objectives over several.
    let map = Arc::new(Map::load(&cfg.layouts()[0].name)?);
    let eval_spec = EvalSpec {
        agents: cfg.agents,
        episodes: eval.episodes,
        seed: eval.seed,
        starts: cfg.starts,
        t_max: cfg.t_max,
        jobs: 1,
        // The env's thesis rules: this caller does not choose a rule set yet.
        ..EvalSpec::default()
    };
    let report = evaluate_policy(&spec.run_dir, &map, &eval_spec, act_mode)?;
    // Objectives evaluate sampled or greedy; a greedy mix counts as sampled.
    let name = match act_mode {
        ActMode::Sample | ActMode::GreedyMix(_) => "eval-sampled",
        ActMode::Greedy => "eval-greedy",
    };
    write_report(&spec.run_dir.join(name), &report, &map.grid)?;
    let s = &report.summary;
    let len = mean_len(&report);
    match act_mode {
        ActMode::Sample | ActMode::GreedyMix(_) => {
            (m.eval_sampled_success, m.eval_sampled_len) = (Some(s.success_rate), len)
        }
        ActMode::Greedy => (m.eval_greedy_success, m.eval_greedy_len) = (Some(s.success_rate), len),
    }
    Ok(m)
}

/// Mean length of the evaluated episodes (failures count `T_max`-long): the
/// tie-breaker of eval objectives.
fn mean_len(report: &EvalReport) -> Option<f64> {
    let n = report.records.len();
    (n > 0).then(|| {
        report
            .records
            .iter()
            .map(|r| f64::from(r.timesteps))
            .sum::<f64>()
            / n as f64
    })
}

impl TrialRunner for LearnerRunner {
    fn run(
        &self,
        spec: &TrialSpec,
        reporter: &mut dyn Reporter,
    ) -> Result<Measurement, TrialError> {
        self.run_trial(spec, reporter)
            .map_err(|e| TrialError::new(chain(&e)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use buridan_study::Decision;

    fn tiny_base() -> TrainConfig {
        toml::from_str(
            r#"
            map = "rm-1.1"
            agents = 2
            starts = "fixed"
            envs_per_actor = 4
            checkpoint_every = 1
            [ppo]
            train_batch = 1000
            minibatch = 500
            epochs = 2
            "#,
        )
        .unwrap()
    }

    fn spec(dir: &Path, steps: u64, objective: Objective) -> TrialSpec {
        TrialSpec {
            id: 0,
            overrides: [("ppo.lr".to_string(), toml::Value::Float(3e-4))].into(),
            steps,
            seed: 5,
            run_dir: dir.to_path_buf(),
            resume: false,
            start_from: None,
            objective,
        }
    }

    struct StopAfter {
        reports: Vec<Measurement>,
        stop_at: usize,
    }

    impl Reporter for StopAfter {
        fn report(&mut self, m: &Measurement) -> Decision {
            self.reports.push(m.clone());
            if self.reports.len() >= self.stop_at {
                Decision::Stop
            } else {
                Decision::Continue
            }
        }
    }

    #[test]
    fn the_config_takes_overrides_seed_steps_and_resume() {
        let dir = tempfile::tempdir().unwrap();
        let mut s = spec(dir.path(), 1234, Objective::TrainSuccess);
        let cfg = trial_config(&tiny_base(), &s).unwrap();
        assert_eq!(
            (cfg.algorithm.ppo().unwrap().lr, cfg.run.seed, cfg.run.steps),
            (3e-4, 5, 1234)
        );
        assert_eq!(cfg.run.resume, None);
        // Resuming without a checkpoint starts fresh.
        s.resume = true;
        assert_eq!(trial_config(&tiny_base(), &s).unwrap().run.resume, None);
        s.overrides
            .insert("ppo.epochs".into(), toml::Value::String("many".into()));
        let e = trial_config(&tiny_base(), &s).unwrap_err();
        assert!(chain(&e).contains("ppo.epochs=\"many\""), "{}", chain(&e));
    }

    #[test]
    fn a_trial_starts_from_its_own_checkpoint_else_from_start_from() {
        let dir = tempfile::tempdir().unwrap();
        let fake_checkpoint = |run: &Path| {
            let c = checkpoint::final_dir(run);
            std::fs::create_dir_all(&c).unwrap();
            std::fs::write(c.join(buridan_policy::SPEC_FILE), "{}").unwrap();
            c
        };
        let (own, other) = (dir.path().join("own"), dir.path().join("other"));
        let mut s = spec(&own, 1000, Objective::TrainSuccess);
        assert_eq!(start_checkpoint(&s).unwrap(), None);
        s.start_from = Some(other.clone());
        let e = start_checkpoint(&s).unwrap_err();
        assert!(matches!(e, TrialRunError::StartFrom { .. }), "{e}");
        let theirs = fake_checkpoint(&other);
        assert_eq!(start_checkpoint(&s).unwrap(), Some(theirs.clone()));
        // Resuming without a checkpoint of its own: still the start.
        s.resume = true;
        assert_eq!(start_checkpoint(&s).unwrap(), Some(theirs));
        let mine = fake_checkpoint(&own);
        assert_eq!(start_checkpoint(&s).unwrap(), Some(mine));
    }

    #[test]
    fn a_stop_decision_interrupts_the_run_with_a_checkpoint_and_resume_continues() {
        let dir = tempfile::tempdir().unwrap();
        let runner = LearnerRunner::new(tiny_base());
        let s = spec(dir.path(), 5000, Objective::TrainSuccess);
        let mut stop = StopAfter {
            reports: vec![],
            stop_at: 2,
        };
        let m = runner.run_trial(&s, &mut stop).unwrap();
        assert_eq!(stop.reports.len(), 2, "no reports after the stop");
        assert_eq!(m.step, stop.reports[1].step);
        assert!(m.step < 5000);
        assert!(!dir.path().join("summary.json").exists());
        assert!(
            checkpoint::resolve(dir.path()).is_ok(),
            "checkpoint on stop"
        );
        // Resumed, the trial continues from its checkpoint to the budget.
        let resumed = TrialSpec {
            resume: true,
            objective: Objective::EvalGreedy,
            ..s
        };
        let mut go = StopAfter {
            reports: vec![],
            stop_at: usize::MAX,
        };
        let runner = LearnerRunner {
            eval: EvalProtocol {
                episodes: 3,
                seed: 42,
            },
            ..runner
        };
        let m = runner.run_trial(&resumed, &mut go).unwrap();
        assert!(m.step >= 5000);
        assert!(go.reports.first().unwrap().step > stop.reports[1].step);
        assert!(m.eval_greedy_success.is_some() && m.eval_greedy_len.is_some());
        assert!(dir.path().join("eval-greedy/summary.json").is_file());
    }
}
